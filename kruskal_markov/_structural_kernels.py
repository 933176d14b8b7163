"""Numba kernel of the structural term: the exact entropy range of a total-variation ball, per row.

Private: :func:`kruskal_markov.structural.entropy_range_tv` validates and calls it. One row at a
time, in parallel over rows: sort the row once, then

* largest entropy — clip from above at ``u`` with ``sum (p - u)+ = d`` and from below at ``l`` with
  ``sum (l - p)+ = d`` (both found exactly on the sorted row); the uniform distribution once
  ``l >= u``;
* smallest entropy — empty the smallest cells in turn by ``min(d, 1 - max p)`` and add it to the
  largest.

Ho and Yeung, "The interplay between entropy and variational distance", IEEE Trans. Inf. Theory
56(12):5906-5929, 2010.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

_INV_LN2 = 1.0 / np.log(2.0)


@njit(cache=True)
def _h_term(x):
    return -x * np.log(x) * _INV_LN2 if x > 0.0 else 0.0


@njit(cache=True)
def _row_range(p, d):
    n = p.shape[0]
    s = np.sort(p)                                   # ascending
    h = 0.0
    for i in range(n):
        h += _h_term(s[i])
    if d <= 0.0:
        return h, h
    # smallest entropy: the smallest cells' mass onto the largest
    room = min(d, 1.0 - s[n - 1])
    hmin = _h_term(s[n - 1] + room)
    left = room
    for i in range(n - 1):
        take = min(s[i], left)
        left -= take
        hmin += _h_term(s[i] - take)
    # largest entropy: upper level u (descending scan) and lower level l (ascending scan)
    u = s[n - 1]
    acc = 0.0
    for k in range(1, n + 1):
        acc += s[n - k]
        cand = (acc - d) / k
        nxt = s[n - k - 1] if k < n else -1.0
        if cand >= nxt:
            u = cand
            break
    lo = s[0]
    acc = 0.0
    for k in range(1, n + 1):
        acc += s[k - 1]
        cand = (acc + d) / k
        nxt = s[k] if k < n else 2.0
        if cand <= nxt:
            lo = cand
            break
    if lo >= u:
        hmax = np.log(n) * _INV_LN2
    else:
        hmax = 0.0
        for i in range(n):
            hmax += _h_term(min(max(s[i], lo), u))
    return min(hmin, h), max(hmax, h)


@njit(cache=True, parallel=True)
def entropy_range_rows(p, d, hmin, hmax):
    """Fill ``hmin[r], hmax[r]`` with the entropy range of the TV ball of radius ``d[r]`` around ``p[r]``
    (rows normalised, ``0 <= d <= 1``)."""
    for r in prange(p.shape[0]):
        a, b = _row_range(p[r], d[r])
        hmin[r] = a
        hmax[r] = b
