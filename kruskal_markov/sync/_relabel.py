"""States relabelled by their frequency in the stored sets of a subset trie, so that the trie
branches first on the states most stored sets hold.

The implicit subset trie (:mod:`kruskal_markov.sync._trie`) answers "does the query contain a
stored set" by walking the stored rows bit by bit: at the node of state ``s``, the stored rows
holding ``s`` are visited only with the queries holding ``s``. When the first bits are the states
that most stored sets hold, a query missing one of them leaves most of the trie unvisited at its
first nodes. synchrowords does the same before its inverse depth-first phase (``Dfs::prepare``:
states sorted by their count in the forward list, the automaton, both lists and the trie
permuted; M. Szykula and A. Zyzik, "An improved algorithm for finding the shortest synchronizing
words", ESA 2022, LIPIcs 244). Our own code.

Only the bit order changes: a relabelled automaton has the same words, so a word found on it is
a word of the original.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from kruskal_markov._sync_kernels import _ctz
from kruskal_markov.sync.automaton import SyncAutomaton

__all__ = ["for_phase", "frequency_order", "permute_rows", "relabel_sorted", "relabelled"]


@njit(cache=True)
def _counts(rows, n):
    """Rows holding each state: only the set bits are visited (lowest first, ``x & (x - 1)``
    clears it), about a fifth of the bits on the 8 x 200 forward levels."""
    out = np.zeros(rows.shape[1] * 64, dtype=np.int64)
    for i in range(rows.shape[0]):
        for w in range(rows.shape[1]):
            x = rows[i, w]
            while x != np.uint64(0):
                low = x & (~x + np.uint64(1))
                out[64 * w + _ctz(low)] += 1
                x ^= low
    return out[:n]


def frequency_order(rows: np.ndarray, n: int) -> np.ndarray:
    """``perm`` with ``perm[q]`` the new label of state ``q``: the state held by most of ``rows``
    gets the first label the trie branches on (in the trie's bit order, bit 63 of word 0 first,
    :func:`~kruskal_markov.sync._trie.lex_order`, the highest label below ``n``), the next one the
    next label, and so on (ties by state index).

    >>> rows = np.array([[0b110], [0b100], [0b101]], dtype=np.uint64)   # state 2 in all three rows, 0 and 1 in one each
    >>> frequency_order(rows, 3).tolist()                                # state 2 gets label 2, then 0 (tie by index) label 1
    [1, 0, 2]
    """
    rows = np.ascontiguousarray(rows, dtype=np.uint64)
    if rows.ndim != 2 or rows.shape[1] * 64 < n:
        raise ValueError("rows must be a 2-d bitset array of at least n bits")
    counts = _counts(rows, n)
    by_count = np.argsort(-counts, kind="stable")          # most frequent first
    # the trie's bit order: bit 63 of word 0, then 62, ..., bit 0, then bit 63 of word 1, ...
    w = rows.shape[1]
    trie_bits = np.array([64 * (j // 64) + 63 - (j % 64) for j in range(64 * w)], dtype=np.int64)
    trie_bits = trie_bits[trie_bits < n]
    perm = np.empty(n, dtype=np.int64)
    perm[by_count] = trie_bits[:n]
    return perm


@njit(cache=True)
def _permute_inplace(rows, perm):
    tmp = np.empty(rows.shape[1], dtype=rows.dtype)
    for i in range(rows.shape[0]):
        tmp[:] = 0
        for w in range(rows.shape[1]):
            x = rows[i, w]
            while x != np.uint64(0):        # the set bits only
                low = x & (~x + np.uint64(1))
                p = perm[64 * w + _ctz(low)]
                tmp[p >> 6] |= np.uint64(1) << np.uint64(p & 63)
                x ^= low
        rows[i] = tmp


def permute_rows(rows: np.ndarray, perm: np.ndarray) -> np.ndarray:
    """Bitset rows with state ``q`` moved to bit ``perm[q]`` (a new array)."""
    out = np.array(rows, dtype=np.uint64, order="C")
    _permute_inplace(out, np.ascontiguousarray(perm, dtype=np.int64))
    return out


def relabelled(aut: SyncAutomaton, perm: np.ndarray) -> SyncAutomaton:
    """The deterministic automaton ``aut`` with state ``q`` renamed ``perm[q]`` (same letters)."""
    if not aut.deterministic:
        raise ValueError("only deterministic automata are relabelled")
    perm = np.asarray(perm, dtype=np.int64)
    if sorted(perm.tolist()) != list(range(aut.n)):
        raise ValueError("perm must be a permutation of the states")
    table = np.empty((aut.k, aut.n), dtype=np.int64)
    table[:, perm] = perm[aut.delta]
    return SyncAutomaton.from_table(table, aut.actions)


@njit(cache=True)
def _apply_order(rows, order):
    """``rows[:] = rows[order]`` in place (cycle by cycle; one row of scratch)."""
    m = rows.shape[0]
    done = np.zeros(m, dtype=np.bool_)
    tmp = np.empty(rows.shape[1], dtype=rows.dtype)
    for i in range(m):
        if done[i] or order[i] == i:
            done[i] = True
            continue
        tmp[:] = rows[i]
        j = i
        while order[j] != i:
            rows[j] = rows[order[j]]
            done[j] = True
            j = order[j]
        rows[j] = tmp
        done[j] = True


def relabel_sorted(sorted_rows: np.ndarray, perm: np.ndarray) -> np.ndarray:
    """The rows of a trie (any order) relabelled by ``perm`` and sorted again in
    :func:`~kruskal_markov.sync._trie.lex_order`, in place (the array is reused: a level of
    millions of sets is not copied)."""
    from kruskal_markov.sync._trie import lex_order

    rows = sorted_rows
    _permute_inplace(rows, np.ascontiguousarray(perm, dtype=np.int64))
    _apply_order(rows, lex_order(rows))
    return rows


def for_phase(aut: SyncAutomaton, fwd, cache: dict):
    """The inverse depth-first phase's relabelling (:class:`~kruskal_markov.sync.exact._InverseDepthFirst`):
    ``((perm, inverse), relabelled automaton, forward trie rows, their SizeSplit)``, the order by
    the newest forward level of store ``fwd``; the sorted copy of that level in ``cache`` (the
    breadth-first meet test's, :func:`~kruskal_markov.sync.exact._sorted_forward`) is relabelled
    in place and taken out of ``cache``."""
    from kruskal_markov.sync._trie import SizeSplit

    flo, fhi = fwd.levels[-1]
    perm = frequency_order(fwd.rows[flo:fhi], aut.n)
    rows = cache.pop("rows")
    cache.pop("level", None)
    cache.pop("split", None)
    rows = relabel_sorted(rows, perm)
    return (perm, np.argsort(perm)), relabelled(aut, perm), rows, SizeSplit(rows)
