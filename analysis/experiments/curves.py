"""When an entropy curve converges: first reach (:func:`first_at_most`) and reach-and-stay
(:func:`settled_steps`)."""
from __future__ import annotations

import numpy as np

__all__ = ["best_settled", "first_at_most", "settled_steps"]


def settled_steps(entropy, epsilon: float) -> np.ndarray:
    """Per row of ``entropy`` (sequences x steps): the step from which the entropy stays ``<= epsilon``
    to the end, -1 if it ends above. (Zero entropy on the report grid is one *cell*, not one pose, so
    a sequence can reach it and split again; "converged" in the paper's sense is reached and stayed.)

    >>> settled_steps([[3.0, 0.0, 1.0, 0.0], [3.0, 0.0, 0.0, 0.0], [3.0, 1.0, 0.0, 1.0]], 1e-3).tolist()
    [3, 1, -1]
    """
    h = np.asarray(entropy, dtype=float)
    if h.ndim == 1:
        h = h[None, :]
    above = h > epsilon
    n = h.shape[1]
    last_above = np.where(above.any(axis=1), n - 1 - np.argmax(above[:, ::-1], axis=1), -1)
    return np.where(last_above < n - 1, last_above + 1, -1).astype(np.int64)


def best_settled(h: np.ndarray, epsilon: float, fallback: int) -> int:
    """The sequence that settles first (ties: lowest mean entropy); ``fallback`` if none settles.

    >>> best_settled(np.array([[3.0, 1.0, 0.0], [3.0, 0.0, 0.0]]), 1e-3, 0)
    1
    """
    st = settled_steps(h, epsilon)
    ok = np.flatnonzero(st >= 0)
    if not ok.size:
        return fallback
    return int(min(ok, key=lambda i: (st[i], h[i].mean(), i)))


def first_at_most(curve, eps) -> int | None:
    """First step of ``curve`` with entropy ``<= eps`` (None if never): one row of
    :func:`kruskal_markov.ensemble.convergence_steps`.

    >>> first_at_most([2.0, 0.5, 0.0], 0.5), first_at_most([2.0, 1.0], 0.5)
    (1, None)
    """
    from kruskal_markov.ensemble import convergence_steps

    step = int(convergence_steps(np.atleast_2d(np.asarray(curve, dtype=float)), eps)[0])
    return None if step < 0 else step
