"""Subset tries split by set size: "does the query contain a stored set" asked only of the stored
sets small enough to fit in it.

A stored set of ``t`` states lies in a query of ``s`` states only if ``t <= s``. The implicit
subset trie (:mod:`kruskal_markov.sync._trie`) already answers a query smaller than every stored
set at once (its size filter), but a query a little larger than the smallest stored set walks the
trie of all of them, and most of the walk is among stored sets larger than the query. Here the
stored rows are ordered by size bucket first (``edges``: bucket ``b`` holds the sizes
``edges[b] <= t < edges[b + 1]``) and lexicographically within a bucket, so that each bucket is
an implicit trie of its own; a query of ``s`` states walks only the buckets whose smallest size is
at most ``s``, smallest bucket first, and stops at its first hit.

The size bound is the one the tries of A. Kisielewicz, J. Kowalski and M. Szykula ("Computing the
shortest reset words of synchronizing automata", J. Comb. Optim. 29 (2015) 88-124) and
synchrowords' implicit trie (M. Szykula and A. Zyzik, "An improved algorithm for finding the
shortest synchronizing words", ESA 2022, LIPIcs 244) apply to the smallest stored set only; the
split into several tries by size is our own arrangement (measured in docs/plans.md, issue 43,
seventh round), and so is the code.
"""
from __future__ import annotations

import numpy as np

from kruskal_markov.sync import _trie

__all__ = ["SizeBuckets", "bucket_edges", "order_by_buckets"]


def bucket_edges(sizes: np.ndarray, first: int = 1 << 16, growth: float = 4.0) -> np.ndarray:
    """Size edges for :class:`SizeBuckets`: the first bucket holds the smallest sizes up to about
    ``first`` stored sets, each next bucket about ``growth`` times the sets of all before it (so a
    query walks tries whose total is at most about ``1 + 1 / growth`` times the sets it must be
    asked against); the last edge is one past the largest size.

    >>> bucket_edges(np.array([3, 3, 4, 5, 5, 5, 9]), first=2, growth=1.0).tolist()
    [3, 4, 6, 10]
    """
    sizes = np.asarray(sizes, dtype=np.int64)
    if sizes.size == 0:
        return np.zeros(1, dtype=np.int64)
    if first < 1 or growth <= 0:
        raise ValueError("first must be positive and growth positive")
    counts = np.bincount(sizes)
    below = np.cumsum(counts)                   # below[t]: stored sets of at most t states
    lo = int(sizes.min())
    edges = [lo]
    target = float(first)
    t = lo
    while t < counts.size:
        while t < counts.size - 1 and below[t] < target:
            t += 1
        edges.append(t + 1)
        target = max(target, below[t] * (1.0 + growth))
        t += 1
    return np.asarray(edges, dtype=np.int64)


def order_by_buckets(rows: np.ndarray, edges: np.ndarray, lex_sorted: bool = False) -> np.ndarray:
    """The permutation ordering ``rows`` by size bucket, and lexicographically
    (:func:`~kruskal_markov.sync._trie.lex_order`) within a bucket (``lex_sorted``: ``rows`` are
    already in that order, only the buckets are sorted, stably)."""
    rows = np.ascontiguousarray(rows, dtype=np.uint64)
    if lex_sorted:
        b = np.searchsorted(edges, _trie._row_sizes(rows), side="right") - 1
        return np.argsort(b, kind="stable")
    lex = _trie.lex_order(rows)
    b = np.searchsorted(edges, _trie._row_sizes(rows[lex]), side="right") - 1
    return lex[np.argsort(b, kind="stable")]


class SizeBuckets:
    """Stored rows ordered by :func:`order_by_buckets` and their bucket bounds.

    Parameters
    ----------
    rows : ndarray of uint64, shape (m, W)
        The stored rows, already in :func:`order_by_buckets` order for ``edges`` (the caller sorts,
        possibly in place; :meth:`build` does it on a copy).
    edges : ndarray of int
        Increasing size edges (:func:`bucket_edges`); every row's size in ``[edges[0], edges[-1])``.
    """

    def __init__(self, rows: np.ndarray, edges: np.ndarray):
        self.rows = rows
        self.edges = np.asarray(edges, dtype=np.int64)
        sizes = _trie._row_sizes(rows)
        if rows.shape[0] and (sizes.min() < self.edges[0] or sizes.max() >= self.edges[-1]):
            raise ValueError("a stored row's size lies outside the edges")
        b = np.searchsorted(self.edges, sizes, side="right") - 1
        if b.size and np.any(np.diff(b) < 0):
            raise ValueError("rows are not ordered by size bucket")
        self.starts = np.searchsorted(b, np.arange(self.edges.size), side="left").astype(np.int64)
        self.min_size = int(self.edges[0])

    @classmethod
    def build(cls, rows: np.ndarray, first: int = 1 << 16, growth: float = 4.0) -> SizeBuckets:
        """Buckets of a copy of ``rows`` (any order), edges by :func:`bucket_edges`."""
        rows = np.ascontiguousarray(rows, dtype=np.uint64)
        edges = bucket_edges(_trie._row_sizes(rows), first, growth)
        return cls(np.ascontiguousarray(rows[order_by_buckets(rows, edges)]), edges)

    def superset_mask(self, query: np.ndarray, tasks: int = 1) -> np.ndarray:
        """For each row of ``query``, whether it contains some stored row (as
        :func:`~kruskal_markov.sync._trie.superset_mask`, the same answers)."""
        query = np.ascontiguousarray(query, dtype=np.uint64)
        if query.ndim != 2 or query.shape[1] != self.rows.shape[1]:
            raise ValueError("query must be a 2-d bitset array of the stored rows' width")
        out = np.zeros(query.shape[0], dtype=np.bool_)
        if self.rows.shape[0] == 0 or query.shape[0] == 0:
            return out
        qs = _trie._row_sizes(query)
        for b in range(self.edges.size - 1):
            lo, hi = int(self.starts[b]), int(self.starts[b + 1])
            if lo == hi:
                continue
            ask = np.flatnonzero((qs >= self.edges[b]) & ~out).astype(np.int64)
            if ask.size == 0:
                break
            par = tasks > 1 and ask.size >= 2 * _trie._PAR_MIN
            bounds = np.linspace(0, ask.size, (tasks if par else 1) + 1).astype(np.int64)
            (_trie._mask_par if par else _trie._mask_seq)(self.rows[lo:hi], query, ask, bounds, False, out)
        return out
