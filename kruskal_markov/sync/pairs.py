"""The pair test: synchronizability in polynomial time through the pair graph (Cerny 1964;
Eppstein 1990), and the memory the pair tables need."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from kruskal_markov._subsets import as_start, pair_index
from kruskal_markov.sync.automaton import SyncAutomaton, as_automaton

if TYPE_CHECKING:
    from kruskal_markov.model import TransitionModel

__all__ = ["PAIR_CHECK_BYTES", "eppstein_memory_mb", "pair_check_memory_mb", "synchronizability"]

#: bytes per state pair of the pair-graph synchronizability check (distance table and BFS work arrays).
PAIR_CHECK_BYTES = 40


def synchronizability(aut: SyncAutomaton | TransitionModel, start=None) -> dict:
    """Polynomial synchronizability test via the pair graph.

    Parameters
    ----------
    aut : SyncAutomaton or TransitionModel
        Deterministic automata are decided; for a set-valued one only a "no" is certain.
    start : array_like of int, optional
        Start states (default: all of an automaton's, a model's start set); on a proper subset the
        test may leave the question open.

    Returns
    -------
    dict
        ``{"synchronizing": True | False | None, "witness": dict | None}``. ``False`` comes with
        a pair of start states that no word merges; ``None`` means the pair test cannot decide (a
        proper start subset, or a set-valued automaton: those questions are PSPACE-complete in
        general and are settled by the exhaustive search of :func:`shortest_synchronizing_word`).

    References
    ----------
    J. Černý, "Poznámka k homogénnym experimentom s konečnými automatmi", Matematicko-fyzikálny
    časopis 14 (1964) 208-216; D. Eppstein, "Reset sequences for monotonic automata", SIAM J.
    Comput. 19 (1990) 500-510.

    Examples
    --------
    >>> a = SyncAutomaton.from_table([[1, 2, 3, 0], [0, 1, 2, 0]])   # Cerny C_4
    >>> synchronizability(a)["synchronizing"]
    True
    """
    aut, start = as_automaton(aut, start)
    s = as_start(aut, start)
    if s.size == 1:
        return {"synchronizing": True, "witness": None}
    dist, _ = aut.pair_distances()
    n = aut.n
    p, q = np.meshgrid(s, s, indexing="ij")
    mask = p < q
    p, q = p[mask], q[mask]
    idx = pair_index(p, q, n)
    bad = np.flatnonzero(dist[idx] < 0)
    if bad.size:
        i = bad[0]
        pair = [int(p[i]), int(q[i])]
        return {"synchronizing": False,
                "witness": {"kind": "pair", "states": pair,
                            "reason": f"no word merges states {pair[0]} and {pair[1]}"}}
    if not aut.deterministic:
        return {"synchronizing": None, "witness": None}
    if s.size == aut.n:
        return {"synchronizing": True, "witness": None}
    # states reachable from the start set: if all their pairs merge, greedy merging succeeds
    reach = _reachable_states(aut, s)
    p, q = np.meshgrid(reach, reach, indexing="ij")
    mask = p < q
    p, q = p[mask], q[mask]
    idx = pair_index(p, q, n)
    if np.all(dist[idx] >= 0):
        return {"synchronizing": True, "witness": None}
    return {"synchronizing": None, "witness": None}


def _reachable_states(aut: SyncAutomaton, s) -> np.ndarray:
    seen = np.zeros(aut.n, dtype=bool)
    seen[s] = True
    frontier = np.asarray(s)
    while frontier.size:
        nxt = []
        for a in range(aut.k):
            lo, hi = aut.indptr[a, frontier], aut.indptr[a, frontier + 1]
            for x, y in zip(lo, hi):
                nxt.append(aut.indices[x:y])
        cand = np.unique(np.concatenate(nxt)) if nxt else np.zeros(0, dtype=np.int64)
        cand = cand[~seen[cand]]
        seen[cand] = True
        frontier = cand.astype(np.int64)
    return np.flatnonzero(seen)


def pair_check_memory_mb(n: int) -> float:
    """Memory (MB) of the pair table on ``n`` states (the pair-graph check and Eppstein's greedy).

    Parameters
    ----------
    n : int
        States.

    Returns
    -------
    float
        ``n (n - 1) / 2`` pairs at :data:`PAIR_CHECK_BYTES` each, in MiB.
    """
    return n * (n - 1) / 2 * PAIR_CHECK_BYTES / 2 ** 20


def eppstein_memory_mb(n: int) -> float:
    """Memory (MB) of Eppstein's greedy on ``n`` states: the pair table and the word buffer."""
    return pair_check_memory_mb(n) + 16.0 * n * n / 2 ** 20


def _eppstein_fits(aut: SyncAutomaton, memory_budget_mb: float | None) -> bool:
    """Whether the greedy word is Eppstein's: a deterministic automaton whose tables fit the budget."""
    return aut.deterministic and (memory_budget_mb is None or eppstein_memory_mb(aut.n) <= memory_budget_mb)
