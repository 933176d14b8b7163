"""A build's model is bit-identical to the one the committed code built before.

Two references of a small allen-key build (8 mm / 8 deg, 50 start poses, seed 5):

- ``tests/data/build_allen_key_8mm.npz`` (1,540 tilts, 672 states), made by main at commit 5c4b492
  before issue 44's changes to the builder, the tilt engine and the stepping loop, under the physics
  of then: the legacy settings (:data:`transition_builder.sim_settings.LEGACY_CHOICES`);
- ``tests/data/build_allen_key_8mm_default.npz``, made at the seventh session's switch to the lighter
  physics (``needed`` pairs, ``floating`` part, ``free+stick`` steps): PyBullet's default physics since;
- ``tests/data/build_allen_key_8mm_planar.npz``, made when the planar engine was added (the eighth
  session), under its physics; the same arrays on one worker as on two.

Regenerate one only when its physics is meant to change (``python -m tests.data.make_build_identity``);
changes that only remove overhead must leave every array and the cache key as they were.
"""
from __future__ import annotations

import numpy as np
import pytest

import tests
from transition_builder.builder import BuildSettings, build_model
from transition_builder.executors import make_executor
from transition_builder.scene import scene_from_options
from transition_builder.sim_settings import LEGACY_CHOICES

#: (reference file, settings changes from the defaults)
REFERENCES = {"legacy": ("build_allen_key_8mm.npz", LEGACY_CHOICES),
              "pybullet": ("build_allen_key_8mm_default.npz", {"engine": "pybullet"}),
              "planar": ("build_allen_key_8mm_planar.npz", {"engine": "planar"})}


def small_build(changes, workers: int = 2):
    """The references' build: the allen key at 8 mm / 8 deg, 50 starts, seed 5, on 2 workers."""
    return build_model(scene_from_options("allen-key", **changes),
                       BuildSettings(tol_mm=8, tol_deg=8, start_samples=50, seed=5),
                       executor=make_executor(workers)).model


def model_arrays(m) -> dict:
    """The arrays a reference holds (without its ``build_key``): the initial distribution, the
    partition, the state poses and every action's CSR arrays, named as in the ``.npz``."""
    out = {"initial": m.initial, "partition": m.partition, "state_poses": m.extras["state_poses"]}
    for a, M in zip(m.actions, m.matrices):
        out[f"{a}_indptr"], out[f"{a}_indices"], out[f"{a}_data"] = M.indptr, M.indices, M.data
    return out


@pytest.mark.parametrize("physics", sorted(REFERENCES))
def test_small_build_is_bit_identical_to_the_committed_arrays(physics):
    name, changes = REFERENCES[physics]
    ref = np.load(str(tests.DATA / name))
    m = small_build(changes)
    assert m.metadata["build_key"] == str(ref["build_key"])
    got = model_arrays(m)
    assert sorted(got) == sorted(k for k in ref.files if k != "build_key")
    for k, v in got.items():
        assert v.dtype == ref[k].dtype and v.shape == ref[k].shape, k
        assert np.array_equal(v, ref[k], equal_nan=v.dtype.kind == "f"), f"{k} differs from the committed build"


def test_planar_build_is_the_same_on_one_worker():
    """Chunks and workers do not change a planar build: one worker gives the committed two-worker arrays."""
    name, changes = REFERENCES["planar"]
    ref = np.load(str(tests.DATA / name))
    m = small_build(changes, workers=1)
    assert m.metadata["build_key"] == str(ref["build_key"])
    for k, v in model_arrays(m).items():
        assert np.array_equal(v, ref[k], equal_nan=v.dtype.kind == "f"), k
