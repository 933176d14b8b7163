"""Epsilon-synchronizing words of stochastic models: the shortest word whose predicted entropy
is at most epsilon (breadth-first over distributions)."""
from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from kruskal_markov.entropy import distribution_entropy_bits, partition_entropy_bits
from kruskal_markov.sync.result import SyncResult

__all__ = ["epsilon_synchronizing_word"]


def _cell_entropy(p, partition, n_cells):
    """Entropy (bits) of ``p`` on the report cells (on the states without a partition)."""
    if partition is None:
        return distribution_entropy_bits(p)
    return partition_entropy_bits(p, partition, n_cells)


def epsilon_synchronizing_word(model, epsilon: float, max_length: int = 30, time_budget: float | None = 30.0,
                               node_budget: int = 2_000_000, decimals: int = 12, *, clock=time.perf_counter,
                               max_nodes: int | None = None) -> SyncResult:
    """Shortest word whose predicted entropy from ``model.initial`` is ``<= epsilon``.

    Entropy is taken on the report partition (on the states if the model has none), in bits.
    Breadth-first search over the distributions reached by words, with duplicate distributions
    (equal after rounding to ``decimals``) merged. ``exact`` is True only when the search was
    exhaustive up to the returned length (the first level with a hit). If no hit exists and the
    set of reachable distributions is exhausted, the answer is "none" (exact).

    Parameters
    ----------
    model : TransitionModel
        Searched from ``model.initial``.
    epsilon : float
        The entropy (bits, >= 0) a word must reach.
    max_length : int, default 30
        Longest word tried.
    time_budget : float or None, default 30.0
        Seconds before the search gives up; None: no time limit (the node budget still holds), as
        in :func:`kruskal_markov.sync.shortest.shortest_word`.
    node_budget : int, default 2,000,000
        Distributions kept before the search gives up (the family's budget name,
        :mod:`kruskal_markov.sync.shortest`).
    decimals : int, default 12
        Distributions equal after rounding to this many decimals count as one.
    clock : callable
        Seconds, for ``time_budget`` (tests pass a fake one).
    max_nodes : int, optional
        Deprecated name of ``node_budget``.

    Returns
    -------
    SyncResult
        ``word`` (letter indices) of the first level with a hit, ``method`` ``distribution-bfs``;
        when a budget ran out, ``word`` None, ``exact`` False and ``best_word`` the lowest-entropy
        word seen.

    See Also
    --------
    kruskal_markov.sync.shortest.shortest_word : set targets (one state, one cell, probability:E).
    kruskal_markov.ensemble.run_ensemble : the entropy of random sequences.
    """
    epsilon = float(epsilon)
    if not epsilon >= 0:
        raise ValueError(f"epsilon must be >= 0, got {epsilon}")
    if max_nodes is not None:
        import warnings

        from kruskal_markov.errors import KruskalDeprecationWarning

        warnings.warn("max_nodes is deprecated; use node_budget", KruskalDeprecationWarning, stacklevel=2)
        node_budget = max_nodes
    max_nodes = node_budget
    t0 = clock()
    mats = [sp.csr_matrix(m).T.tocsr() for m in model.matrices]
    part = None if model.partition is None else np.asarray(model.partition, dtype=np.int64)
    ncells = None if part is None else int(model.n_cells if model.n_cells else part.max() + 1)
    p0 = np.asarray(model.initial, dtype=np.float64)
    h0 = _cell_entropy(p0, part, ncells)
    if h0 <= epsilon:
        return SyncResult([], 0, True, "distribution-bfs", seconds=clock() - t0)
    seen = {np.round(p0, decimals).tobytes()}
    frontier = [(p0, [])]
    explored = 1
    best = (h0, [])
    for depth in range(1, max_length + 1):
        nxt = []
        for p, w in frontier:
            for a, m in enumerate(mats):
                q = m @ p
                key = np.round(q, decimals).tobytes()
                if key in seen:
                    continue
                seen.add(key)
                explored += 1
                h = _cell_entropy(q, part, ncells)
                if h < best[0]:
                    best = (h, w + [a])
                if h <= epsilon:
                    return SyncResult(w + [a], depth, True, "distribution-bfs", states_explored=explored,
                                      lower_bound=depth, seconds=clock() - t0,
                                      notes=[f"entropy {h:.6g} bits"])
                nxt.append((q, w + [a]))
            if explored > max_nodes or (time_budget is not None and clock() - t0 > time_budget):
                return SyncResult(None, None, False, "distribution-bfs", states_explored=explored,
                                  lower_bound=depth, seconds=clock() - t0,
                                  greedy_length=len(best[1]), best_word=best[1],
                                  notes=[f"budget reached at depth {depth}; lowest entropy seen "
                                         f"{best[0]:.6g} bits by a word of length {len(best[1])}"])
        if not nxt:
            return SyncResult(None, None, True, "distribution-bfs", states_explored=explored,
                              witness={"kind": "exhaustive",
                                       "reason": f"all {explored} reachable distributions have entropy "
                                                 f"> {epsilon}"},
                              seconds=clock() - t0)
        frontier = nxt
    return SyncResult(None, None, False, "distribution-bfs", states_explored=explored,
                      lower_bound=max_length + 1, seconds=clock() - t0,
                      notes=[f"no word of length <= {max_length} reaches entropy <= {epsilon}"])
