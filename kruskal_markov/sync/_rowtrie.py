"""The implicit subset trie's batch walk with the query rows themselves moved, not their indices.

:func:`kruskal_markov.sync._trie.superset_mask` walks the trie of the stored rows with a batch of
query rows, partitioning an index array at each trie node by one bit of each query row: every
step reads a query row through its index, a gather over the whole batch (32 MB of rows for a
slice of a million preimages at 200 states), and most of those reads miss the cache. Here the
queries that need a walk (those at least as large as the smallest stored set, with the same size
filter, :class:`~kruskal_markov.sync._trie.SizeSplit`) are first copied into one compact array,
and the walk partitions that array's rows in place (with their original indices alongside), so
that each node's partition reads and writes consecutive rows.

The trie, its bit order and its answers are those of :mod:`kruskal_markov.sync._trie` (the
implicit subset trie of synchrowords, M. Szykula and A. Zyzik, ESA 2022, after the subset tries
of A. Kisielewicz, J. Kowalski and M. Szykula, J. Comb. Optim. 29 (2015) 88-124); moving rows
instead of indices is our own change, measured in docs/plans.md (issue 43, seventh round). Our
own code.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from kruskal_markov.sync import _trie

__all__ = ["superset_mask_rows"]

_ONE = np.uint64(1)
_ZERO = np.uint64(0)
_LEAF = _trie._LEAF


@njit(cache=True, inline="always")
def _bit(rows, i, depth):
    return (rows[i, depth >> 6] >> np.uint64(63 - (depth & 63))) & _ONE


@njit(cache=True, inline="always")
def _swap(C, ids, a, b):
    for w in range(C.shape[1]):
        t = C[a, w]
        C[a, w] = C[b, w]
        C[b, w] = t
    t2 = ids[a]
    ids[a] = ids[b]
    ids[b] = t2


@njit(cache=True)
def _leaf(S, s_lo, s_hi, C, ids, c_lo, c_hi, depth):
    """Row-by-row comparison at a trie leaf; query rows containing a stored row are swapped to the
    end of ``[c_lo, c_hi)``; returns the new end."""
    W = S.shape[1]
    w0 = min(depth, W * 64 - 1) >> 6
    c = c_lo
    while c < c_hi:
        hit = False
        for s in range(s_lo, s_hi):
            inside = True
            for w in range(w0, W):
                if S[s, w] & ~C[c, w]:
                    inside = False
                    break
            if inside:
                hit = True
                break
        if hit:
            c_hi -= 1
            _swap(C, ids, c, c_hi)
        else:
            c += 1
    return c_hi


@njit(cache=True)
def _walk(S, C, ids, c_lo, c_hi):
    """:func:`kruskal_markov.sync._trie._walk` (same stack, same nodes) over query rows ``C[c_lo:c_hi]``
    moved in place; returns the end of the rows containing no stored row."""
    nbits = S.shape[1] * 64
    size = nbits + 2
    st_depth = np.empty(size, dtype=np.int64)
    st_slo = np.empty(size, dtype=np.int64)
    st_smid = np.empty(size, dtype=np.int64)
    st_shi = np.empty(size, dtype=np.int64)
    st_clo = np.empty(size, dtype=np.int64)
    st_phase = np.empty(size, dtype=np.int64)
    st_depth[0], st_slo[0], st_shi[0], st_clo[0], st_phase[0] = 0, 0, S.shape[0], c_lo, 0
    sp = 1
    end = c_hi
    while sp > 0:
        t = sp - 1
        depth, s_lo, s_hi, lo_c = st_depth[t], st_slo[t], st_shi[t], st_clo[t]
        if st_phase[t] == 0:
            if s_lo >= s_hi or lo_c >= end:
                sp -= 1
                continue
            if s_hi - s_lo <= _LEAF or depth >= nbits:
                end = _leaf(S, s_lo, s_hi, C, ids, lo_c, end, depth)
                sp -= 1
                continue
            lo = s_lo
            hi = s_hi
            while lo < hi:
                mid = (lo + hi) >> 1
                if _bit(S, mid, depth) == _ZERO:
                    lo = mid + 1
                else:
                    hi = mid
            st_smid[t] = lo
            st_phase[t] = 1
            if lo > s_lo:
                st_depth[sp], st_slo[sp], st_shi[sp], st_clo[sp], st_phase[sp] = depth + 1, s_lo, lo, lo_c, 0
                sp += 1
            continue
        s_mid = st_smid[t]
        sp -= 1
        if s_mid >= s_hi or lo_c >= end:
            continue
        p = lo_c
        for c in range(lo_c, end):
            if _bit(C, c, depth) == _ZERO:
                if c != p:
                    _swap(C, ids, c, p)
                p += 1
        if p < end:
            st_depth[sp], st_slo[sp], st_shi[sp], st_clo[sp], st_phase[sp] = depth + 1, s_mid, s_hi, p, 0
            sp += 1
    return end


@njit(cache=True)
def _gather(query, sizes, min_size, cut):
    """The rows of ``query`` of at least ``cut`` states, copied into one array, with their indices;
    and the indices of the rows of ``min_size`` to ``cut - 1`` states."""
    m = 0
    mid = 0
    for i in range(sizes.shape[0]):
        if sizes[i] >= cut:
            m += 1
        elif sizes[i] >= min_size:
            mid += 1
    C = np.empty((m, query.shape[1]), dtype=np.uint64)
    ids = np.empty(m, dtype=np.int64)
    small = np.empty(mid, dtype=np.int64)
    j = 0
    k = 0
    for i in range(sizes.shape[0]):
        if sizes[i] >= cut:
            C[j] = query[i]
            ids[j] = i
            j += 1
        elif sizes[i] >= min_size:
            small[k] = i
            k += 1
    return C, ids, small


@njit(cache=True, parallel=True)
def _mask_par(S, C, ids, bounds, out):
    for t in prange(bounds.shape[0] - 1):
        end = _walk(S, C, ids, bounds[t], bounds[t + 1])
        for c in range(end, bounds[t + 1]):
            out[ids[c]] = True


@njit(cache=True)
def _mask_seq(S, C, ids, bounds, out):
    for t in range(bounds.shape[0] - 1):
        end = _walk(S, C, ids, bounds[t], bounds[t + 1])
        for c in range(end, bounds[t + 1]):
            out[ids[c]] = True


def superset_mask_rows(stored_sorted: np.ndarray, query: np.ndarray, split: _trie.SizeSplit, tasks: int = 1,
                       min_parallel: int = _trie._PAR_MIN) -> np.ndarray:
    """For each row of ``query``, whether it contains some row of ``stored_sorted`` (in
    :func:`~kruskal_markov.sync._trie.lex_order`): the answers of
    :func:`~kruskal_markov.sync._trie.superset_mask` with ``split``, the walk over a compact copy
    of the queries that need it.

    Parameters
    ----------
    stored_sorted : ndarray of uint64, shape (m, W)
        The stored rows, sorted.
    query : ndarray of uint64, shape (q, W)
        The query rows (not changed).
    split : SizeSplit
        The stored rows' sizes (:class:`~kruskal_markov.sync._trie.SizeSplit`).
    tasks, min_parallel : int
        As :func:`~kruskal_markov.sync._trie.superset_mask`.

    Returns
    -------
    ndarray of bool, shape (q,)
    """
    query = np.ascontiguousarray(query, dtype=np.uint64)
    if stored_sorted.ndim != 2 or query.ndim != 2 or stored_sorted.shape[1] != query.shape[1]:
        raise ValueError("stored and query must be 2-d bitset arrays of the same width")
    out = np.zeros(query.shape[0], dtype=np.bool_)
    if stored_sorted.shape[0] == 0 or query.shape[0] == 0:
        return out
    C, ids, mid = _gather(query, _trie._row_sizes(query), split.min_size, split.cut)
    if mid.size and split.small.shape[0]:
        _trie._scan_small(split.small, query, mid, out)
    if ids.size == 0:
        return out
    par = tasks > 1 and ids.size >= 2 * min_parallel
    bounds = np.linspace(0, ids.size, (tasks if par else 1) + 1).astype(np.int64)
    (_mask_par if par else _mask_seq)(stored_sorted, C, ids, bounds, out)
    return out
