"""Shared pieces of the subset searches in :mod:`kruskal_markov.sync` and
:mod:`kruskal_markov.convergence`: start-set validation and the hashed bitset store."""
from __future__ import annotations

import numpy as np

from kruskal_markov import _sync_kernels as _k

__all__ = ["as_start", "SubsetStore", "pow2", "pair_index", "pair_offsets"]

#: parent sets per slice when a large level is expanded in two passes (:meth:`SubsetStore.expand`)
_EXPAND_SLICE = 1 << 17


def as_start(aut, start) -> np.ndarray:
    """The sorted start states of ``aut`` (all states when ``start`` is None), validated."""
    if start is None:
        return np.arange(aut.n)
    s = np.unique(np.asarray(start, dtype=np.int64).ravel())
    if s.size == 0:
        raise ValueError("the start set is empty")
    if s[0] < 0 or s[-1] >= aut.n:
        raise ValueError(f"start states must lie in [0, {aut.n})")
    return s


def pair_index(p, q, n: int):
    """Index of the state pair ``{p, q}`` (``p != q``; arrays or ints) among the ``n (n - 1) / 2``
    pairs, in row order ``(0, 1), (0, 2), ..., (1, 2), ...``. The Numba kernels keep their own copies
    (``_sync_kernels.pair_index``, ``_convergence_kernels._pair_index``): the same formula."""
    p, q = np.minimum(p, q), np.maximum(p, q)
    return p * n - (p * (p + 1)) // 2 + (q - p - 1)


def pair_offsets(n: int) -> np.ndarray:
    """``first[p]``: the index of the first pair ``(p, q > p)`` in :func:`pair_index` order, p = 0..n."""
    p = np.arange(n + 1, dtype=np.int64)
    return p * n - (p * (p + 1)) // 2


def pow2(x):
    """The hash table size for ``x`` entries: a power of two, at least 16."""
    return 1 << max(4, int(x - 1).bit_length())


class SubsetStore:
    """A growable, hashed store of bitsets with parent pointers (one search direction)."""

    def __init__(self, W, cap, max_rows):
        self.W = W
        self.max_rows = max_rows
        cap = max(16, min(cap, max_rows))
        self.rows = np.zeros((cap, W), dtype=np.uint64)
        self.parent = np.full(cap, -1, dtype=np.int64)
        self.letter = np.full(cap, -1, dtype=np.int32)
        self.table = np.full(pow2(2 * cap), -1, dtype=np.int64)
        self.count = 0
        self.levels = []

    def ensure(self, need):
        need = min(need, self.max_rows)
        cap = self.rows.shape[0]
        if need <= cap:
            return
        new = min(self.max_rows, max(need, 2 * cap))
        rows = np.zeros((new, self.W), dtype=np.uint64)
        rows[:self.count] = self.rows[:self.count]
        parent = np.full(new, -1, dtype=np.int64)
        parent[:self.count] = self.parent[:self.count]
        letter = np.full(new, -1, dtype=np.int32)
        letter[:self.count] = self.letter[:self.count]
        self.rows, self.parent, self.letter = rows, parent, letter
        self.table = np.full(pow2(2 * new), -1, dtype=np.int64)
        _k.rehash(self.rows, self.count, self.table)

    def add_roots(self, bitsets):
        self.ensure(self.count + len(bitsets))
        lo = self.count
        for b in bitsets:
            self.rows[self.count] = b
            self.count += 1
        _k.rehash(self.rows, self.count, self.table)
        self.levels.append((lo, self.count))

    def expand(self, aut, forward, tasks=1):
        lo, hi = self.levels[-1]
        self.ensure(self.count + (hi - lo) * aut.k)
        inv_ptr, inv_idx, supcount = aut.inverse
        if tasks > 1 and hi - lo >= 2 * _k._IMAGES_PAR_MIN:
            # a large level: the images computed slice by slice on both cores (level_images), then
            # inserted in the same order on one (the hash table is shared) -- the same rows,
            # parents and letters as expand_level
            new = self.count
            for a in range(lo, hi, _EXPAND_SLICE):
                b = min(hi, a + _EXPAND_SLICE)
                images = _k.level_images(self.rows, a, b, aut.delta, aut.step_table(forward), aut.deterministic, forward,
                                         inv_ptr, inv_idx, supcount, tasks=tasks)
                new = _k.insert_images(self.rows, new, images, a, aut.k, self.table, self.parent, self.letter,
                                       self.rows.shape[0])
                if new < 0:
                    break
        else:
            new = _k.expand_level(self.rows, self.count, lo, hi, aut.delta, aut.step_table(forward), aut.deterministic,
                                  forward, self.table, self.parent, self.letter, self.rows.shape[0],
                                  inv_ptr, inv_idx, supcount)
        if new < 0:
            _k.rehash(self.rows, self.count, self.table)   # drop the partial level
            return None
        lo2 = self.count
        self.count = new
        self.levels.append((lo2, new))
        return new - lo2

    def keep_last(self, keep):
        """Keep the rows of the newest level where ``keep`` (bool, one per row) is True, in order;
        rows of earlier levels (the parents) do not move. Returns how many were dropped."""
        lo, hi = self.levels[-1]
        idx = lo + np.flatnonzero(keep)
        m = idx.size
        if m == hi - lo:
            return 0
        self.rows[lo:lo + m] = self.rows[idx]
        self.parent[lo:lo + m] = self.parent[idx]
        self.letter[lo:lo + m] = self.letter[idx]
        self.count = lo + m
        self.levels[-1] = (lo, lo + m)
        _k.rehash(self.rows, self.count, self.table)
        return hi - lo - m

    def path(self, i):
        out = []
        while self.parent[i] >= 0:
            out.append(int(self.letter[i]))
            i = self.parent[i]
        return out, i

    def nbytes(self):
        return self.rows.nbytes + self.parent.nbytes + self.letter.nbytes + self.table.nbytes
