"""Validation of inputs shared by several engines: one home, one set of messages."""
from __future__ import annotations

import numpy as np

from kruskal_markov.errors import ModelError

__all__ = ["action_position", "action_weights", "beyond", "distribution"]


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


def beyond(deviation: float, tol: float) -> str:
    """``deviation`` signed, with as many digits as it takes to read as larger than ``tol``.

    >>> beyond(1.0000000001e-9, 1e-9)
    '+1.0000000001e-09'
    """
    for digits in range(6, 18):
        text = f"{deviation:+.{digits}g}"
        if f"{abs(deviation):.{digits}g}" != f"{tol:.{digits}g}":
            return text
    return f"{deviation:+.17g}"


def distribution(values, n_states: int, tol: float, what: str = "initial distribution") -> np.ndarray:
    """``values`` as a probability vector over ``n_states`` states (a new float64 array).

    Raises :class:`~kruskal_markov.errors.ModelError` naming the first problem: not numeric, the
    wrong length, a non-finite or negative entry (with its state), or a sum off 1 by more than
    ``tol``. The vector is not renormalised.

    >>> distribution([0.25, 0.75], 2, 1e-9).tolist()
    [0.25, 0.75]
    >>> distribution([0.5, 0.6], 2, 1e-9)
    Traceback (most recent call last):
    ...
    kruskal_markov.errors.ModelError: initial distribution sums to 1.1, off by +0.1, more than the tolerance 1e-09
    """
    try:
        p = np.array(values, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise ModelError(f"{what} must be a numeric vector") from None
    if p.shape != (n_states,):
        raise ModelError(f"{what} has {p.size} entries, the model has {n_states} states")
    if not np.all(np.isfinite(p)):
        raise ModelError(f"{what} has a non-finite entry at state {int(np.flatnonzero(~np.isfinite(p))[0])}")
    if np.any(p < 0):
        i = int(np.argmin(p))
        raise ModelError(f"{what} has a negative entry {p[i]:.6g} at state {i}")
    total = p.sum()
    if abs(total - 1.0) > tol:
        raise ModelError(f"{what} sums to {float(total)!r}, off by "
                         f"{beyond(float(total) - 1.0, tol)}, more than the tolerance {tol:g}")
    return p


def action_position(actions, name, context: str = "") -> int:
    """Index of the action called ``name`` in ``actions``: the exact name first, else the one name
    equal to it ignoring case and surrounding spaces. The one way every layer (model, scene, command
    line) turns an action name into an index.

    Raises :class:`~kruskal_markov.errors.ModelError` (a ``ValueError``) naming the unknown action
    and the known ones; ``context`` (e.g. ``" in sequence"``) says where it was met.

    >>> action_position(("N", "NE", "E"), " ne ")
    1
    """
    names = tuple(str(a) for a in actions)
    text = str(name)
    if text in names:
        return names.index(text)
    key = text.strip().upper()
    for i, a in enumerate(names):
        if a.strip().upper() == key:
            return i
    raise ModelError(f"unknown action {name!r}{context}; known actions: {','.join(names)}")
