"""Upper bounds with a word: inverse beam search for short synchronizing words.

The exact search (:mod:`kruskal_markov.sync.exact`) only has to prove that no word is shorter than
its best known word; the closer that word is to the optimum, the fewer levels the proof needs and
the sooner a proven bound equal to the word's length makes the answer exact. Eppstein's greedy
(:mod:`kruskal_markov.sync.greedy`) is often 1.5x the optimum on random automata; the inverse beam
search of synchrowords (Szykula and Zyzik 2022, the ``Beam`` algorithm with a dynamic width) is
usually within one or two letters of it.

References
----------
M. Szykula and A. Zyzik, "An improved algorithm for finding the shortest synchronizing words",
ESA 2022, LIPIcs 244, 85:1-85:17 (synchrowords, ``synchrolib/algorithm/beam``).
"""
from __future__ import annotations

import math
import time

import numpy as np

from kruskal_markov import _sync_kernels as _k
from kruskal_markov._subsets import SubsetStore

__all__ = ["inverse_beam_word", "beam_width_schedule"]


def beam_width_schedule(n: int, k: int, bound: int | None) -> int:
    """The second beam's width: synchrowords' dynamic rule, ``1%`` of the cost ``2 k^floor((L+1)/2)``
    of a bidirectional exact search to the first beam's length ``L``, per level, clamped to
    ``[n log2 n, n^2 log2 n]`` (the exponent is an integer division in synchrowords'
    ``beam.hpp``, ``(bound + 1) / 2`` on an unsigned ``bound``)."""
    lo = max(16, int(n * math.log2(max(n, 2))))
    hi = max(lo, int(n * n * math.log2(max(n, 2))))
    if bound is None:
        return lo
    exact_cost = 2.0 * float(k) ** ((bound + 1) // 2)
    return int(min(hi, max(lo, round(exact_cost * 0.01 / max(bound, 1)))))


def inverse_beam_word(aut, start_bits: np.ndarray, width: int, max_length: int | None = None,
                      node_budget: int | None = None, deadline: float | None = None, *, clock=time.perf_counter):
    """A synchronizing word found by inverse beam search, or None.

    Level 0 holds the singletons; level ``i + 1`` the distinct non-empty preimages ``a^-1(B)`` of
    level ``i``, of which the ``width`` largest are kept (ties in generation order). The first
    preimage containing the start set gives a word ``a_1 ... a_i`` that maps the start set into
    one state.

    Parameters
    ----------
    aut : SyncAutomaton
    start_bits : ndarray of uint64
        The start set as a bitset.
    width : int
        Sets kept per level.
    max_length : int, optional
        Give up past this length (the caller's best word so far).
    node_budget : int, optional
        Give up after generating this many sets (``width x k`` a level).
    deadline : float, optional
        Give up past this ``clock()`` reading (checked between levels).
    clock : callable, default time.perf_counter
        The clock ``deadline`` is read on.

    Returns
    -------
    list of int or None
        The word, first letter first.
    """
    W = aut.n_words
    n = aut.n
    rows = np.zeros((n, W), dtype=np.uint64)
    for q in range(n):
        rows[q, q >> 6] = np.uint64(1) << np.uint64(q & 63)
    words = np.zeros((n, 0), dtype=np.int16)
    generated = 0
    length = 0
    while rows.shape[0] and (max_length is None or length < max_length):
        m = rows.shape[0]
        st = SubsetStore(W, m * aut.k + m, m * aut.k + m)
        st.add_roots(list(rows))
        if st.expand(aut, False) is None:
            return None
        lo, hi = st.levels[-1]
        generated += m * aut.k
        length += 1
        if hi == lo:
            return None
        new = st.rows[lo:hi]
        hit = _k.first_superset(new, start_bits)
        par = st.parent[lo:hi]
        let = st.letter[lo:hi].astype(np.int16)
        if hit >= 0:
            return [int(let[hit])] + [int(a) for a in words[par[hit]]]
        if (node_budget is not None and generated >= node_budget) or \
                (deadline is not None and clock() > deadline):
            return None
        size = _k._level_sizes(st.rows, lo, hi)
        keep = np.argsort(-size, kind="stable")[:width]
        rows = new[keep].copy()
        words = np.concatenate([let[keep, None], words[par[keep]]], axis=1)
    return None
