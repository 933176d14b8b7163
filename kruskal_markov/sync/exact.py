"""Exact shortest synchronizing words: bidirectional breadth-first subset search, then a
memory-bounded depth-first phase.

References
----------
A. Kisielewicz, J. Kowalski and M. Szykula, "Computing the shortest reset words of synchronizing
automata", J. Comb. Optim. 29 (2015) 88-124.
M. Szykula and A. Zyzik, "An improved algorithm for finding the shortest synchronizing words",
ESA 2022, LIPIcs 244, 85:1-85:17 (synchrowords).
"""
from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from kruskal_markov import _sync_kernels as _k
from kruskal_markov._subsets import SubsetStore, as_start
from kruskal_markov.sync.automaton import SyncAutomaton, as_automaton, is_synchronizing_word
from kruskal_markov.sync.greedy import greedy_synchronizing_word
from kruskal_markov.sync.pairs import _eppstein_fits, eppstein_memory_mb, pair_check_memory_mb, synchronizability
from kruskal_markov.sync.result import SyncResult

if TYPE_CHECKING:
    from kruskal_markov.model import TransitionModel

__all__ = ["shortest_synchronizing_word"]

#: share of ``time_budget`` the greedy word may use before the exact search starts.
_GREEDY_SHARE = 0.4
#: forward sets per call of the meet test (the time budget is checked between calls)
_MEET_SLICE = 2048


_BLOCK = 1 << 16


def _choose_forward(fwd, bwd, k):
    """Which side to expand: the one with the smaller newest level (forward on a tie)."""
    (flo, fhi), (blo, bhi) = fwd.levels[-1], bwd.levels[-1]
    return (fhi - flo) <= (bhi - blo)


def _exact_search(aut: SyncAutomaton, start, time_budget, memory_budget_mb):
    """Bidirectional BFS. Returns ``(word | None, status, explored, lower_bound)`` with status
    'found', 'none' (proven: no word) or 'budget'."""
    t0 = time.perf_counter()
    W = aut.n_words
    row_bytes = 8 * W + 8 + 4 + 16 * 2      # rows + parent + letter + hash table (load <= 1/2, x2 growth)
    max_rows = max(1024, int(memory_budget_mb * 2 ** 20 / row_bytes / 2))   # per direction
    if aut.n >= max_rows:       # not even the n backward roots fit: no exact search in this budget
        return None, "budget", 0, 1
    fwd = SubsetStore(W, 1024, max_rows)
    bwd = SubsetStore(W, max(1024, aut.n), max_rows)
    fwd.add_roots([aut.bits(start)])
    singletons = []
    for q in range(aut.n):
        b = np.zeros(W, dtype=np.uint64)
        b[q >> 6] = np.uint64(1) << np.uint64(q & 63)
        singletons.append(b)
    bwd.add_roots(singletons)
    total = 0
    block = _BLOCK
    # first guesses (updated from measurements); both grow with the bitset width W
    rate_row = 2e-7 * max(1.0, W / 16)     # seconds per generated row
    rate_pair = 5e-11 * max(1.0, W / 4)    # seconds per (forward set x backward set) pair in the meet test
    while True:
        (flo, fhi), (blo, bhi) = fwd.levels[-1], bwd.levels[-1]
        tm = time.perf_counter()
        # the meet test in slices of the forward level, so that the budget is checked between them
        # (its cost depends on how the set sizes of the two levels overlap, which is hard to predict)
        f = b = -1
        for lo in range(flo, fhi, _MEET_SLICE):
            if total and time.perf_counter() - t0 > time_budget:
                return None, "budget", fwd.count + bwd.count, total + 1
            f, b = _k.meet(fwd.rows, lo, min(fhi, lo + _MEET_SLICE), bwd.rows, blo, bhi, aut.n, block)
            if f >= 0:
                break
        pairs = (fhi - flo) * (bhi - blo)
        if pairs > 10_000_000:
            rate_pair = (time.perf_counter() - tm) / pairs
        if f >= 0:
            u, _ = fwd.path(f)
            v, _ = bwd.path(b)
            word = u[::-1] + v
            return word, "found", fwd.count + bwd.count, total
        # expand the side with the smaller newest level (inverse steps cost ~ n per set)
        forward = _choose_forward(fwd, bwd, aut.k)
        store = fwd if forward else bwd
        # predicted cost of the next level (expansion + meet test); stop before the budget is blown
        lo, hi = store.levels[-1]
        growth = aut.k if len(store.levels) < 2 else \
            max(1.0, (hi - lo) / max(1, store.levels[-2][1] - store.levels[-2][0]))
        new_rows = (hi - lo) * min(growth, aut.k)
        other = (bhi - blo) if forward else (fhi - flo)
        predicted = new_rows * rate_row + new_rows * other * rate_pair
        if time.perf_counter() - t0 + predicted > time_budget:
            return None, "budget", fwd.count + bwd.count, total + 1
        te = time.perf_counter()
        grown = store.expand(aut, forward)
        if grown is None:
            return None, "budget", fwd.count + bwd.count, total + 1
        if grown > 10_000:
            rate_row = max(1e-9, (time.perf_counter() - te) / grown)
        if grown == 0:
            return None, "none", fwd.count + bwd.count, total
        total += 1


def shortest_synchronizing_word(aut: SyncAutomaton | TransitionModel, start=None, time_budget: float = 60.0,
                                memory_budget_mb: float = 2048.0) -> SyncResult:
    """The shortest word synchronizing ``start`` (default: all states).

    Exact bidirectional subset search (Kisielewicz, Kowalski and Szykula 2015): forward images of
    the start set and inverse images of singletons, breadth-first, hashed bitsets, meeting when a
    forward set lies inside a backward one; totals ``i + j`` are checked in increasing order, so
    the first meeting is a shortest word. If a direction is exhausted without meeting, no word
    exists. Past ``time_budget`` seconds or ``memory_budget_mb`` the result is the greedy word
    (:func:`greedy_synchronizing_word`, found first within 40% of the time) with ``exact=False``
    and a proven ``lower_bound``.

    >>> a = SyncAutomaton.from_table([[1, 2, 0], [0, 1, 0]])   # Cerny C_3
    >>> r = shortest_synchronizing_word(a)
    >>> r.length, r.exact
    (4, True)
    """
    aut, start = as_automaton(aut, start)
    if time_budget <= 0 or memory_budget_mb <= 0:
        raise ValueError("time and memory budgets must be positive")
    t0 = time.perf_counter()
    s = as_start(aut, start)
    if s.size == 1:
        return SyncResult([], 0, True, "trivial", seconds=time.perf_counter() - t0)
    # a greedy word first (within a share of the time): it answers if the exact search stops, and
    # it proves synchronizability, so the quadratic pair-graph check runs only without one (to
    # find a witness that no word exists); the exact search then has the rest of the time
    eppstein = _eppstein_fits(aut, memory_budget_mb)
    greedy = greedy_synchronizing_word(aut, s, memory_budget_mb=memory_budget_mb,
                                       deadline=t0 + _GREEDY_SHARE * time_budget)
    pair_mb = pair_check_memory_mb(aut.n)
    skipped = greedy is None and pair_mb > 0.5 * memory_budget_mb
    if greedy is None and not skipped:
        check = synchronizability(aut, s)
        if check["synchronizing"] is False:
            return SyncResult(None, None, True, "pair-graph", witness=check["witness"],
                              seconds=time.perf_counter() - t0)
    remaining = max(time_budget - (time.perf_counter() - t0), 1e-3)
    word, status, explored, lower = _exact_search(aut, s, remaining, memory_budget_mb)
    if status == "found":
        if not is_synchronizing_word(aut, word, s):
            raise AssertionError("internal error: exact search returned a non-synchronizing word")
        return SyncResult(word, len(word), True, "bidirectional-bfs", states_explored=explored,
                          lower_bound=len(word), seconds=time.perf_counter() - t0)
    if status == "none":
        return SyncResult(None, None, True, "bidirectional-bfs", states_explored=explored,
                          witness={"kind": "exhaustive", "subsets_explored": explored,
                                   "reason": "exhaustive subset search: no image of the start set "
                                             "is a single state"},
                          seconds=time.perf_counter() - t0)
    method = "greedy-eppstein" if eppstein else "greedy"
    notes = [f"exact search stopped by its budget; no synchronizing word is shorter than {lower}"]
    if skipped:
        notes.append(f"pair-graph synchronizability check skipped: {aut.n} states would need about "
                     f"{pair_mb:,.0f} MB (over half the memory budget)")
    if aut.deterministic and not eppstein:
        notes.append(f"greedy by merging one pair at a time (pair graph searched from each pair): Eppstein's "
                     f"tables would need about {eppstein_memory_mb(aut.n):,.0f} MB (over the memory budget)")
    if greedy is None:
        notes.append(f"greedy word not found within {_GREEDY_SHARE:.0%} of the time budget")
    meets_bound = greedy is not None and len(greedy) <= lower   # the greedy word meets the proven lower bound
    return SyncResult(greedy, None if greedy is None else len(greedy), meets_bound,
                      method + "+lower-bound" if meets_bound else method,
                      lower_bound=lower, states_explored=explored,
                      greedy_length=None if greedy is None else len(greedy),
                      seconds=time.perf_counter() - t0, notes=notes)
