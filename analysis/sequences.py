"""Random action sequences: one seed stream, so ``--sequence random:N --seed S`` is the same N
actions in every command (a model's prediction and a direct simulation of it can be compared)."""
from __future__ import annotations

import numpy as np

from analysis.streams import SALTS, salted_rng

__all__ = ["SEQUENCE_STREAM", "sequence_rng", "random_sequences_for"]

#: seed stream of random sequences (start poses use the bare seed; noise its own stream):
#: ``SALTS["sequences"]`` of :mod:`analysis.streams`.
SEQUENCE_STREAM = SALTS["sequences"]


def sequence_rng(seed: int) -> np.random.Generator:
    """The generator of ``--sequence random:N --seed seed``."""
    return salted_rng(seed, "sequences")


def random_sequences_for(n_actions: int, count: int, length: int, seed: int) -> np.ndarray:
    """``count`` random sequences of ``length`` actions from ``seed``; the first is exactly what
    ``--sequence random:LENGTH --seed SEED`` gives in every command.

    >>> random_sequences_for(8, 2, 5, seed=1).shape
    (2, 5)

    Parameters
    ----------
    n_actions : int
        Number of actions.
    count, length : int
        Sequences and actions per sequence.
    seed : int
        The seed.

    Returns
    -------
    ndarray (count, length) of int
        Action indices.
    """
    return sequence_rng(seed).integers(0, n_actions, size=(count, length)).astype(np.int64)
