"""Write a reference of tests/transition_builder/builder/test_build_identity.py: the arrays and the
cache key of the small allen-key build (8 mm / 8 deg, 50 starts, seed 5) under one physics.

Run from the repository root with the code to record, only when that physics is meant to change:
``python tests/data/make_build_identity.py planar`` (or ``pybullet``, ``legacy``).
"""
import sys

import numpy as np

sys.path.insert(0, ".")
from tests.transition_builder.builder.test_build_identity import REFERENCES, model_arrays, small_build  # noqa: E402


def record(physics: str) -> str:
    name, changes = REFERENCES[physics]
    m = small_build(changes)
    arrays = {**model_arrays(m), "build_key": np.array(m.metadata["build_key"])}
    path = f"tests/data/{name}"
    np.savez_compressed(path, **arrays)
    return f"{path}: {m.n_states} states, key {m.metadata['build_key'][:16]}"


if __name__ == "__main__":
    print(record(sys.argv[1] if len(sys.argv) > 1 else "planar"))
