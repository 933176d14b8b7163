"""Validation of inputs shared by several engines: one home, one set of messages."""
from __future__ import annotations

import numpy as np

from kruskal_markov.model import ModelError

__all__ = ["action_weights"]


def action_weights(n_actions: int, weights=None) -> np.ndarray:
    """Action probabilities from ``weights`` (non-negative, up to a factor; None: uniform).

    Raises :class:`~kruskal_markov.model.ModelError` (a ``ValueError``) naming what is wrong.

    >>> action_weights(4, [1, 1, 2, 0]).tolist()
    [0.25, 0.25, 0.5, 0.0]
    """
    if weights is None:
        return np.full(n_actions, 1.0 / n_actions)
    try:
        w = np.asarray(weights, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise ModelError("action weights must be numbers") from None
    if w.size != n_actions:
        raise ModelError(f"{w.size} action weights given for {n_actions} actions")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise ModelError("action weights must be finite and non-negative")
    if w.sum() <= 0:
        raise ModelError("action weights must not all be zero")
    return w / w.sum()
