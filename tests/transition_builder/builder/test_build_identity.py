"""A build's model is bit-identical to the one the committed code built before the speed work.

``tests/data/build_allen_key_8mm.npz`` holds the arrays of a small allen-key build (8 mm / 8 deg,
50 start poses, seed 5; 1,540 tilts, 672 states) made by main at commit 5c4b492, before issue 44's
changes to the builder, the tilt engine and the stepping loop (regenerate with the script in
``docs/builder.md`` only when the physics is meant to change: a new simulator version). Changes that
only remove overhead must leave every array and the cache key as they were.
"""
from __future__ import annotations

import numpy as np

import tests
from transition_builder.builder import BuildSettings, build_model
from transition_builder.executors import make_executor
from transition_builder.scene import scene_from_options

DATA = str(tests.DATA / "build_allen_key_8mm.npz")


def test_small_build_is_bit_identical_to_the_committed_arrays():
    ref = np.load(DATA)
    r = build_model(scene_from_options("allen-key"), BuildSettings(tol_mm=8, tol_deg=8, start_samples=50, seed=5),
                    executor=make_executor(2))
    m = r.model
    assert m.metadata["build_key"] == str(ref["build_key"])
    got = {"initial": m.initial, "partition": m.partition, "state_poses": m.extras["state_poses"]}
    for a, M in zip(m.actions, m.matrices):
        got[f"{a}_indptr"], got[f"{a}_indices"], got[f"{a}_data"] = M.indptr, M.indices, M.data
    assert sorted(got) == sorted(k for k in ref.files if k != "build_key")
    for k, v in got.items():
        assert v.dtype == ref[k].dtype and v.shape == ref[k].shape, k
        assert np.array_equal(v, ref[k], equal_nan=v.dtype.kind == "f"), f"{k} differs from the committed build"
