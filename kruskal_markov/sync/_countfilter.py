"""A necessary condition for "the query contains a stored set", checked by one table look-up: the
states are split into a few blocks, and a query can contain a stored set only if, in every
block, it holds at least as many states as that stored set does there.

The table says, for every vector of per-block counts, whether some stored set's count vector is at
most it in every block (the stored count vectors marked, then a running maximum along each block's
axis). A query's counts (clipped to the largest stored count of each block, which changes no
answer) index it. With one block this is the size filter of the implicit subset trie
(:class:`~kruskal_markov.sync._trie.SizeSplit`, as in synchrowords: M. Szykula and A. Zyzik, ESA
2022, LIPIcs 244); a query of ``s`` states in ``b`` blocks is kept only when some stored set fits
under it block by block, which fewer do the more uneven the query's blocks are. The blocks and the
table are our own arrangement and code (measured in docs/plans.md, issue 43, seventh round).

The filter never drops a query that contains a stored set, so answers do not change; the queries
it keeps still walk the trie.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from kruskal_markov._sync_kernels import _popcount

__all__ = ["CountFilter"]

#: table entries above which fewer blocks are used (a byte each)
MAX_TABLE = 1 << 26


@njit(cache=True)
def _counts(rows, masks):
    """``out[i, b]``: states of row ``i`` in block ``b`` (``masks[b]``: the block's bitset)."""
    m, W = rows.shape
    B = masks.shape[0]
    out = np.zeros((m, B), dtype=np.int64)
    for i in range(m):
        for b in range(B):
            c = 0
            for w in range(W):
                c += _popcount(rows[i, w] & masks[b, w])
            out[i, b] = c
    return out


@njit(cache=True)
def _mark(counts, strides, table):
    for i in range(counts.shape[0]):
        j = 0
        for b in range(counts.shape[1]):
            j += counts[i, b] * strides[b]
        table[j] = 1


@njit(cache=True)
def _keep(rows, masks, caps, strides, table, min_size, out):
    """``out[i]``: row ``i`` has at least ``min_size`` states and its clipped count vector is
    marked in ``table``."""
    m, W = rows.shape
    B = masks.shape[0]
    for i in range(m):
        j = 0
        size = 0
        for b in range(B):
            c = 0
            for w in range(W):
                c += _popcount(rows[i, w] & masks[b, w])
            size += c
            j += min(c, caps[b]) * strides[b]
        out[i] = size >= min_size and table[j] != 0


class CountFilter:
    """Per-block state counts of stored rows, for :meth:`keep`.

    Parameters
    ----------
    stored : ndarray of uint64, shape (m, W)
        The stored rows.
    n : int
        States (bits ``0..n-1`` of the rows).
    blocks : int, default 5
        Blocks of states (state ``q`` in block ``q % blocks``); fewer are used when the table would
        pass :data:`MAX_TABLE` entries.
    """

    def __init__(self, stored: np.ndarray, n: int, blocks: int = 5):
        stored = np.ascontiguousarray(stored, dtype=np.uint64)
        if stored.ndim != 2 or stored.shape[1] * 64 < n or n < 1:
            raise ValueError("stored must be a 2-d bitset array of at least n bits")
        if blocks < 1:
            raise ValueError("blocks must be positive")
        self.n = n
        self.min_size = 0
        for nb in range(min(blocks, n), 0, -1):
            masks = np.zeros((nb, stored.shape[1]), dtype=np.uint64)
            for q in range(n):
                masks[q % nb, q >> 6] |= np.uint64(1) << np.uint64(q & 63)
            counts = _counts(stored, masks)
            caps = counts.max(axis=0) if stored.shape[0] else np.zeros(nb, dtype=np.int64)
            shape = tuple(int(c) + 1 for c in caps)
            if int(np.prod(shape, dtype=np.float64)) <= MAX_TABLE or nb == 1:
                break
        self.masks, self.caps = masks, caps.astype(np.int64)
        self.strides = np.array([int(np.prod(shape[b + 1:], dtype=np.int64)) for b in range(nb)], dtype=np.int64)
        table = np.zeros(int(np.prod(shape, dtype=np.int64)), dtype=np.uint8)
        if stored.shape[0]:
            _mark(counts, self.strides, table)
            self.min_size = int(counts.sum(axis=1).min())
            t = table.reshape(shape)
            for b in range(nb):
                np.maximum.accumulate(t, axis=b, out=t)
        self.table = table
        self.empty = stored.shape[0] == 0

    @property
    def blocks(self) -> int:
        """Blocks used."""
        return int(self.masks.shape[0])

    def keep(self, query: np.ndarray) -> np.ndarray:
        """For each row of ``query``, False when it can contain no stored row (by its size or its
        per-block counts), True when it may."""
        query = np.ascontiguousarray(query, dtype=np.uint64)
        if query.ndim != 2 or query.shape[1] != self.masks.shape[1]:
            raise ValueError("query must be a 2-d bitset array of the stored rows' width")
        out = np.zeros(query.shape[0], dtype=np.bool_)
        if not self.empty:
            _keep(query, self.masks, self.caps, self.strides, self.table, self.min_size, out)
        return out
