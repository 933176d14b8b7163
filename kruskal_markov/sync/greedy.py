"""Greedy synchronizing words: Eppstein's pair merging, pair merging without tables, greedy descent.

References
----------
D. Eppstein, "Reset sequences for monotonic automata", SIAM J. Comput. 19 (1990) 500-510.
"""
from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from kruskal_markov import _sync_kernels as _k
from kruskal_markov._subsets import SubsetStore, as_start
from kruskal_markov.sync.automaton import SyncAutomaton, as_automaton, is_synchronizing_word
from kruskal_markov.sync.pairs import _eppstein_fits

if TYPE_CHECKING:
    from kruskal_markov.model import TransitionModel

__all__ = ["greedy_synchronizing_word"]


#: the greedy stages, in the order they are tried
GREEDY_STAGES = ("eppstein", "pairs", "descent")


def greedy_synchronizing_word(aut: SyncAutomaton | TransitionModel, start=None, node_budget: int = 200_000,
                              memory_budget_mb: float | None = None, deadline: float | None = None, *,
                              stages=GREEDY_STAGES, clock=time.perf_counter):
    """A synchronizing word, not necessarily shortest, or None if none was found.

    Deterministic automata: Eppstein's (1990) greedy pair merging (``O(k n^2)`` pair BFS plus
    ``O(n^3)`` merging), which always succeeds on a synchronizable start set whose reachable pairs
    all merge -- when its quadratic tables (:func:`eppstein_memory_mb`) fit in ``memory_budget_mb``.
    Otherwise, and for set-valued automata, one pair at a time (:func:`_pair_merging_greedy`:
    breadth-first in the pair graph from each pair, no tables); if that fails, greedy descent,
    repeatedly running a breadth-first
    search of at most ``node_budget`` subsets (fewer if ``memory_budget_mb`` says so) from the
    current set to the nearest strictly smaller image, until ``deadline`` (a ``clock()``
    reading; None if it passes). The returned word is verified.

    Parameters
    ----------
    aut : SyncAutomaton or TransitionModel
        The automaton, or a model standing for its support automaton and start set (:func:`as_automaton`).
    start : array_like of int, optional
        Start states (default: all states of an automaton, a model's start set); one state gives ``[]``.
    node_budget : int, default 200,000
        Subsets per breadth-first search of the greedy descent.
    memory_budget_mb : float or None, default None
        Memory the tables may take (None: no limit).
    deadline : float or None, default None
        A ``clock()`` reading after which the search gives up.
    stages : tuple of str, default ("eppstein", "pairs", "descent")
        Which of the three stages may run (always in that order): Eppstein's tables, pair merging
        without tables, greedy descent.
    clock : callable, default time.perf_counter
        The clock ``deadline`` is read on.

    Returns
    -------
    list of int or None
        A synchronizing word (letter indices; ``[]`` for a single start state), or None.

    References
    ----------
    D. Eppstein, "Reset sequences for monotonic automata", SIAM J. Comput. 19 (1990) 500-510.

    Examples
    --------
    >>> from kruskal_markov.generators import cerny_automaton
    >>> len(greedy_synchronizing_word(cerny_automaton(4))) >= 9
    True
    """
    aut, start = as_automaton(aut, start)
    unknown = set(stages) - set(GREEDY_STAGES)
    if unknown:
        raise ValueError(f"unknown greedy stages {sorted(unknown)}; known: {', '.join(GREEDY_STAGES)}")
    s = as_start(aut, start)
    if s.size == 1:
        return []
    word = None
    if memory_budget_mb is not None:
        row_bytes = 8 * aut.n_words + 8 + 4 + 32
        node_budget = max(1024, min(node_budget, int(memory_budget_mb * 2 ** 20 / row_bytes)))
    if "eppstein" in stages and _eppstein_fits(aut, memory_budget_mb):
        dist, nxt = aut.pair_distances()
        out = np.empty(max(16, aut.n ** 3 // 6 + aut.n), dtype=np.int32) if aut.n <= 256 else \
            np.empty(4 * aut.n * aut.n, dtype=np.int32)
        length = _k.eppstein_greedy(aut.delta, s.astype(np.int64), dist, nxt, out)
        if length >= 0:
            word = [int(x) for x in out[:length]]
    if word is None and "pairs" in stages:
        max_pairs = None if memory_budget_mb is None else max(1 << 16, int(memory_budget_mb * 2 ** 20 / 64))
        word = _pair_merging_greedy(aut, s, deadline, max_pairs, clock)
    if word is None and "descent" in stages:
        word = _greedy_descent(aut, s, node_budget, deadline, clock)
    if word is not None and not is_synchronizing_word(aut, word, s):
        raise AssertionError("internal error: greedy word does not synchronize")
    return word


def _set_image(aut, states, a):
    """Image of the state set ``states`` (int64, sorted) under letter ``a`` (every successor),
    straight from the CSR supports: :meth:`SyncAutomaton.image` would first build the set-valued
    automaton's ``(k, n, n/64)`` support bitsets (10 GB at 100,000 states)."""
    lo, hi = aut.indptr[a][states], aut.indptr[a][states + 1]
    lengths = hi - lo
    idx = np.repeat(lo - np.concatenate(([0], np.cumsum(lengths)[:-1])), lengths) + np.arange(lengths.sum())
    return np.unique(aut.indices[idx].astype(np.int64))


def _pair_merging_greedy(aut, s, deadline=None, max_pairs=None, clock=time.perf_counter):
    """Greedy pair merging without Eppstein's tables: while the current set has two or more
    states, search breadth-first in the pair graph from two of its states for the shortest word
    that merges them, and apply it to the whole set. The search follows single-valued rows only (a
    set-valued row -- e.g. the uniform start states' first tilt, or a row that member probes
    spread over several landings -- is left out of it; applied to the whole set, the word may still
    take other states through such rows, and the set grows by their images); while the set holds a
    state whose rows are set-valued under every letter (the uniform start states), the letter with
    the smallest image is applied first. Each search visits only the pairs reachable from its start
    pair (at most ``max_pairs``). None if a search exhausts its pairs without merging, exceeds
    ``max_pairs``, the word grows past ``4 n`` letters, or ``deadline`` passes."""
    n, k = aut.n, aut.k
    single = []
    for a in range(k):
        ptr = aut.indptr[a]
        one = np.diff(ptr) == 1
        single.append(np.where(one, aut.indices[np.minimum(ptr[:-1], aut.indices.size - 1)], -1).astype(np.int64))
    multi = np.ones(n, dtype=bool)                        # set-valued under every letter
    for a in range(k):
        multi &= single[a] < 0
    states = np.unique(np.asarray(s, dtype=np.int64))
    word = []
    while states.size > 1:
        if deadline is not None and clock() > deadline:
            return None
        if multi[states].any():
            images = [_set_image(aut, states, a) for a in range(k)]
            best = min(range(k), key=lambda a: images[a].size)
            word.append(best)
            states = images[best]
            if len(word) > 4 * n:
                return None
            continue
        u = _merging_word(single, n, int(states[0]), int(states[1]), deadline, max_pairs, clock)
        if u is None:
            return None
        word += u
        if len(word) > 4 * n:
            return None
        for a in u:
            states = _set_image(aut, states, a)
    return word


def _merging_word(single, n, p, q, deadline, max_pairs, clock=time.perf_counter):
    """Shortest word merging states ``p`` and ``q`` along single-valued rows (breadth-first in the
    pair graph, level by level in numpy); None if there is none within the limits."""
    level_keys = [np.array([min(p, q) * n + max(p, q)], dtype=np.int64)]
    parents, letters = [np.array([-1])], [np.array([-1])]
    seen = level_keys[0]
    while True:
        if deadline is not None and clock() > deadline:
            return None
        keys = level_keys[-1]
        if keys.size == 0:
            return None                                   # the pair never merges
        lo, hi = keys // n, keys % n
        nk, npar, nlet = [], [], []
        for a, nxt in enumerate(single):
            x, y = nxt[lo], nxt[hi]
            ok = (x >= 0) & (y >= 0)
            hit = np.flatnonzero(ok & (x == y))
            if hit.size:
                u = [a]
                depth, idx = len(level_keys) - 1, int(hit[0])
                while depth > 0:
                    u.append(int(letters[depth][idx]))
                    idx = int(parents[depth][idx])
                    depth -= 1
                return u[::-1]
            keep = np.flatnonzero(ok)
            nk.append(np.minimum(x[keep], y[keep]) * n + np.maximum(x[keep], y[keep]))
            npar.append(keep)
            nlet.append(np.full(keep.size, a))
        k_all = np.concatenate(nk)
        k_new, first = np.unique(k_all, return_index=True)
        fresh = ~np.isin(k_new, seen, assume_unique=True)
        k_new, first = k_new[fresh], first[fresh]
        seen = np.union1d(seen, k_new)
        if max_pairs is not None and seen.size > max_pairs:
            return None
        level_keys.append(k_new)
        parents.append(np.concatenate(npar)[first])
        letters.append(np.concatenate(nlet)[first])


def _greedy_descent(aut, s, node_budget, deadline=None, clock=time.perf_counter):
    """Greedy descent: apply the letter whose image of the current set is smallest while one
    shrinks it (deterministic automata), else search breadth-first for the nearest smaller image."""
    W = aut.n_words
    word = []
    if aut.deterministic:
        states = np.unique(np.asarray(s, dtype=np.int64))
        while states.size > 1:
            if deadline is not None and clock() > deadline:
                return None
            images = [np.unique(aut.delta[a][states]) for a in range(aut.k)]
            best = min(range(aut.k), key=lambda a: images[a].size)
            if images[best].size >= states.size:
                break
            word.append(best)
            states = images[best].astype(np.int64)
        s = states
    cur = aut.bits(s)
    while True:
        size = len(aut.states_of(cur))
        if size == 1:
            return word
        if deadline is not None and clock() > deadline:
            return None
        st = SubsetStore(W, 1024, node_budget)
        st.add_roots([cur])
        found = None
        while found is None:
            if deadline is not None and clock() > deadline:
                return None
            grown = st.expand(aut, True)
            if not grown:
                return None
            lo, hi = st.levels[-1]
            best, best_size = -1, size
            for i in range(lo, hi):
                c = _k.set_size(st.rows, i)
                if c < best_size:
                    best, best_size = i, c
            if best >= 0:
                found = best
        u, _ = st.path(found)
        word += u[::-1]
        cur = st.rows[found].copy()
