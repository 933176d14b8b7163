"""Expected length of a random synchronizing sequence (the Kruskal effect).

Letters are drawn independently (uniformly, or with given weights) and applied to the start set
of a :class:`~kruskal_markov.sync.SyncAutomaton` (for set-valued automata the image of a set is the
union of supports) until the image is a single state. ``T`` is that first time. Three answers,
side by side:

* exact ``E[T]``: the absorbing Markov chain on the subsets reachable from the start set, solved
  with sparse linear algebra, when their number is within a budget;
* Monte Carlo with a 95% confidence interval (normal approximation);
* pair-chain bounds (deterministic automata): each pair of states follows a Markov chain that is
  absorbed when the two states merge; with ``h`` its expected merging times,
  ``max_{pairs in S} h <= E[T]`` (every pair must have merged), and, from the union bound
  ``P(T > t) <= min(1, m_t)`` with ``m_t = sum_{pairs in S} P(pair not merged by t)``,
  ``E[T] <= sum_{t < t0} min(1, m_t) + sum_{t >= t0} m_t`` where the tail is exactly ``v_{t0} . h``
  (``v_t`` the pair mass vector at time ``t``). See Eppstein (1990) for the pair automaton and
  Berlinkov, "On the probability of being synchronizable" (2016) for pair-chain arguments.

For stochastic models :func:`monte_carlo_entropy_tilts` estimates the expected number of random
tilts until the predicted report-grid entropy is ``<= epsilon``.
"""
from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse import csgraph

from kruskal_markov import _convergence_kernels as _ck
from kruskal_markov._subsets import SubsetStore, as_start, pair_index, pair_offsets
from kruskal_markov.entropy import partition_entropy_bits
from kruskal_markov.sync import (
    SyncAutomaton,
    as_automaton,
    pair_check_memory_mb,
    synchronizability,
)
from kruskal_markov.validation import action_weights

if TYPE_CHECKING:
    from kruskal_markov.model import TransitionModel

__all__ = [
    "censored_mean",
    "default_mc_steps",
    "exact_expected_length",
    "expected_sync_length",
    "letter_weights",
    "monte_carlo_entropy_tilts",
    "monte_carlo_sync_length",
    "pair_chain_bounds",
    "pair_chain_memory_mb",
]


def letter_weights(k: int, weights=None) -> np.ndarray:
    """Validated letter probabilities (uniform by default); weights are normalised to sum 1
    (:func:`kruskal_markov.validation.action_weights`)."""
    return action_weights(k, weights)


def _finite_or_none(x):
    return None if x is None or not math.isfinite(x) else float(x)


# ----------------------------------------------------------------------------- exact
def exact_expected_length(aut: SyncAutomaton | TransitionModel, start=None, weights=None, max_subsets: int = 200_000):
    """Exact ``E[T]`` from the absorbing chain on reachable subsets.

    Returns ``(value, info)``: ``value`` is a float, ``math.inf`` (some reachable subset can never
    be synchronized, so ``T`` is infinite with positive probability) or None (more than
    ``max_subsets`` reachable subsets). ``info`` holds ``subsets`` (how many were enumerated).

    Parameters
    ----------
    aut : SyncAutomaton or TransitionModel
        The automaton (a model's support automaton).
    start, weights : array_like, optional
        Start set (default every state); letter probabilities up to a factor (default uniform).
    max_subsets : int, default 200000
        Give up beyond this many reachable subsets.

    Returns
    -------
    value : float, math.inf or None
    info : dict

    References
    ----------
    .. [1] J. G. Kemeny, J. L. Snell, "Finite Markov Chains", Van Nostrand (1960): expected absorption
       times of an absorbing chain, ``(I - Q) t = 1``.
    """
    aut, start = as_automaton(aut, start)
    s = as_start(aut, start)
    w = letter_weights(aut.k, weights)
    if s.size == 1:
        return 0.0, {"subsets": 1}
    st = SubsetStore(aut.n_words, 1024, max_subsets)
    st.add_roots([aut.bits(s)])
    while True:
        grown = st.expand(aut, True)
        if grown is None:
            return None, {"subsets": f">{max_subsets}"}
        if grown == 0:
            break
    count = st.count
    img = np.empty((count, aut.k), dtype=np.int64)
    _ck.subset_chain_table(st.rows, count, aut.delta, aut.sup, aut.deterministic, st.table, img)
    if np.any(img < 0):
        raise AssertionError("internal error: subset chain not closed")
    sizes = np.array([_popcount_row(st.rows[i]) for i in range(count)])
    absorbing = sizes == 1
    # which subsets can reach a singleton?
    rows = np.repeat(np.arange(count), aut.k)
    cols = img.ravel()
    wts = np.tile(w, count)
    keep = (wts > 0) & ~absorbing[rows]
    G = sp.csr_matrix((np.ones(int(keep.sum())), (rows[keep], cols[keep])), shape=(count, count))
    # subsets reachable from the start (through positive-weight letters, before absorption)
    reach = csgraph.breadth_first_order(G, 0, directed=True, return_predecessors=False)
    live = np.zeros(count, dtype=bool)
    live[reach] = True
    # which of them can reach a singleton?  reverse BFS from a virtual source linked to singletons
    targets = np.flatnonzero(absorbing)
    can = np.zeros(count, dtype=bool)
    if targets.size:
        src = np.concatenate([cols[keep], np.full(targets.size, count)])
        dst = np.concatenate([rows[keep], targets])
        GT = sp.csr_matrix((np.ones(src.size, dtype=np.int8), (src, dst)), shape=(count + 1, count + 1))
        order = csgraph.breadth_first_order(GT, count, directed=True, return_predecessors=False)
        can[order[order < count]] = True
    if np.any(live & ~can):
        return math.inf, {"subsets": count}
    absorbing = absorbing | ~live      # unreachable subsets play no role
    trans = np.flatnonzero(~absorbing)
    pos = np.full(count, -1, dtype=np.int64)
    pos[trans] = np.arange(trans.size)
    r = rows[keep]
    c = cols[keep]
    ww = wts[keep]
    inner = ~absorbing[c] & ~absorbing[r]
    Q = sp.csr_matrix((ww[inner], (pos[r[inner]], pos[c[inner]])), shape=(trans.size, trans.size))
    A = (sp.identity(trans.size, format="csc") - Q.tocsc())
    x = spla.spsolve(A, np.ones(trans.size))
    x = np.atleast_1d(x)
    return float(x[pos[0]]), {"subsets": count}


def _popcount_row(row):
    return sum(int(v).bit_count() for v in row)


# ----------------------------------------------------------------------------- Monte Carlo
def monte_carlo_sync_length(aut: SyncAutomaton | TransitionModel, start=None, weights=None, runs: int = 2000, seed=0,
                            max_steps: int = 100_000, chunk: int = 64, time_budget: float | None = None,
                            clock=time.perf_counter):
    """Monte Carlo estimate of ``E[T]`` over ``runs`` random words (seeded).

    Returns ``dict(mean, ci95, runs, censored, std, lower)``; runs that are not synchronized after
    ``max_steps`` letters (or still running after ``time_budget`` seconds, when one is given) are
    censored. A mean over the finished runs alone would be biased low, so with any censored run
    ``mean``, ``ci95`` and ``std`` are None and only ``lower`` is given: the mean of ``min(T,
    letters run)`` over all runs, an estimate of a lower bound of ``E[T]`` (equal to ``mean``
    when nothing is censored). Without a time budget the result depends only on the inputs and
    ``seed``; with one, censoring (and so the result) can depend on the machine's speed.

    Parameters
    ----------
    aut, start, weights
        As for :func:`exact_expected_length`.
    runs, seed : int
        Random words and their seed.
    max_steps, chunk : int
        Letters before a run is censored, and runs advanced together.
    time_budget : float, optional
        Seconds before the remaining runs are censored.
    clock : callable
        Seconds, for ``time_budget`` (tests pass a fake one).

    Returns
    -------
    dict
    """
    aut, start = as_automaton(aut, start)
    t0 = clock()
    if runs < 2:
        raise ValueError("Monte Carlo needs at least 2 runs")
    s = as_start(aut, start)
    w = letter_weights(aut.k, weights)
    rng = np.random.default_rng(seed)
    cur = np.tile(aut.bits(s), (runs, 1))
    steps = np.zeros(runs, dtype=np.int64)
    done = np.zeros(runs, dtype=bool)
    if s.size == 1:
        done[:] = True
    while (not np.all(done) and steps[~done].max(initial=0) < max_steps
           and (time_budget is None or clock() - t0 < time_budget)):
        active = np.flatnonzero(~done)
        chunk = min(chunk, max_steps - int(steps[active].max()))
        letters = rng.choice(aut.k, size=(active.size, chunk), p=w).astype(np.int64)
        sub_cur = cur[active]
        sub_steps = steps[active]
        sub_done = done[active]
        _ck.mc_sync_steps(sub_cur, letters, aut.delta, aut.sup, aut.deterministic, sub_steps, sub_done)
        cur[active] = sub_cur
        steps[active] = sub_steps
        done[active] = sub_done
        chunk = min(4 * chunk, 4096)
    return censored_mean(steps.astype(np.float64), done)


# ----------------------------------------------------------------------------- pair chain
#: pair chains up to this many pairs are solved directly (sparse LU); larger ones iteratively
#: (BiCGSTAB, then GMRES from its iterate), checking the time budget between iterations
_DIRECT_SOLVE_MAX_PAIRS = 30_000


class _OverBudget(Exception):
    """Raised inside an iterative solver's callback when the time budget has passed."""


def pair_chain_bounds(aut: SyncAutomaton | TransitionModel, start=None, weights=None, max_iterations: int = 200_000,
                      time_budget: float = 45.0, tol: float = 1e-12, memory_budget_mb: float | None = None,
                      clock=time.perf_counter, direct_max_pairs: int = _DIRECT_SOLVE_MAX_PAIRS,
                      iterative_solver=None):
    """Lower and upper bounds on ``E[T]`` from the chain on pairs (deterministic automata).

    Returns ``dict(lower, upper, pairs, memory_mb, iterations, residual)``; bounds are ``inf``
    when some start pair can never merge, and None for set-valued automata (the image of a pair
    is then a set, not a pair) or when the pair chain's worst-case arrays
    (:func:`pair_chain_memory_mb`) exceed ``memory_budget_mb`` (``note`` says so; nothing is
    allocated). The pair chain is restricted to the pairs reachable in one or more steps from
    the start pairs; the expected merging times ``h`` solve ``(I - Q) h = 1``.

    Parameters
    ----------
    aut, start, weights
        As for :func:`exact_expected_length` (a deterministic automaton).
    max_iterations, time_budget, tol
        Iterations, seconds and residual of the iterative solve.
    memory_budget_mb : float, optional
        Skip when the pair chain would need more.
    clock : callable
        Seconds, for ``time_budget`` (tests pass a fake one).
    direct_max_pairs : int
        Chains up to this many pairs are solved directly (sparse LU), larger ones iteratively.
    iterative_solver : callable, optional
        ``iterative_solver(A, b, rtol=, maxiter=, callback=) -> (x, info)``, the first iterative
        solve (default :func:`scipy.sparse.linalg.bicgstab`); when ``info != 0`` GMRES continues
        from its iterate.

    Returns
    -------
    dict
    """
    aut, start = as_automaton(aut, start)
    solve = spla.bicgstab if iterative_solver is None else iterative_solver
    t0 = clock()
    s = as_start(aut, start)
    w = letter_weights(aut.k, weights)
    if s.size == 1:
        return {"lower": 0.0, "upper": 0.0, "pairs": 0, "memory_mb": 0.0, "iterations": 0, "residual": 0.0}
    if not aut.deterministic:
        return {"lower": None, "upper": None, "pairs": None, "memory_mb": None, "iterations": 0,
                "residual": None, "note": "pair bounds need a deterministic automaton"}
    need = pair_chain_memory_mb(aut.n, aut.k, s.size)
    if memory_budget_mb is not None and need > memory_budget_mb:
        return {"lower": None, "upper": None, "pairs": None, "memory_mb": None, "iterations": 0,
                "residual": None, "note": f"pair bounds skipped: {aut.n:,} states need up to {need:,.0f} MB "
                                          f"(over the memory budget of {memory_budget_mb:,.0f} MB)"}
    n = aut.n
    delta = aut.delta
    p, q = np.triu_indices(s.size, 1)
    p, q = s[p].astype(np.int64), s[q].astype(np.int64)
    start_pairs = pair_index(p, q, n)
    del p, q
    # letters of zero weight do not move the chain
    use = np.flatnonzero(w > 0)
    d_use = np.ascontiguousarray(delta[use])
    w_use = w[use]
    order, local = _ck.pair_reachable(d_use, start_pairs)
    R = order.size
    img = _ck.pair_images(d_use, order, local)
    mem = (img.nbytes + order.nbytes + local.nbytes + start_pairs.nbytes) / 2 ** 20
    # can every reachable pair merge?  reverse BFS from the virtual "merged" node R
    rows = np.repeat(np.arange(R), use.size)
    cols = img.ravel().copy()
    cols[cols < 0] = R
    G = sp.csr_matrix((np.ones(rows.size, dtype=np.int8), (cols, rows)), shape=(R + 1, R + 1))
    reach = csgraph.breadth_first_order(G, R, directed=True, return_predecessors=False)
    can = np.zeros(R + 1, dtype=bool)
    can[reach] = True
    start_ok = _start_pairs_can_merge(d_use, start_pairs, local, can, n)
    if not start_ok or not np.all(can[:R]):
        # some pair never merges: if it is reachable from a start pair, T = inf with positive prob.
        return {"lower": math.inf, "upper": math.inf, "pairs": int(R), "memory_mb": mem,
                "iterations": 0, "residual": None}
    h = np.zeros(R)
    residual = 0.0
    if R:
        keep = img.ravel() >= 0
        Q = sp.csr_matrix((np.tile(w_use, R)[keep], (rows[keep], img.ravel()[keep])), shape=(R, R))
        A = sp.identity(R, format="csr") - Q
        mem += (Q.data.nbytes + Q.indices.nbytes + Q.indptr.nbytes) * 2 / 2 ** 20
        if R <= direct_max_pairs:
            h = spla.spsolve(A.tocsc(), np.ones(R))
        else:
            def stop_at_budget(*_):
                if clock() - t0 > time_budget:
                    raise _OverBudget

            try:
                h, info = solve(A, np.ones(R), rtol=1e-12, maxiter=20_000, callback=stop_at_budget)
                if info != 0:
                    h, info = spla.gmres(A, np.ones(R), x0=h, rtol=1e-12, restart=50, maxiter=100,
                                         callback=stop_at_budget, callback_type="pr_norm")
            except _OverBudget:
                return {"lower": None, "upper": None, "pairs": int(R), "memory_mb": float(mem), "iterations": 0,
                        "residual": None, "note": f"pair bounds stopped by the time budget ({time_budget:g} s) "
                                                  f"while solving for the merging times of {R:,} pairs"}
        h = np.asarray(h, dtype=np.float64)
        tmp = np.empty(R)
        _ck.pair_value_step(img, w_use, h, tmp)
        residual = float(np.max(np.abs(tmp - h))) if R else 0.0
    v = np.zeros(R)
    lower = _ck.start_pair_stats(d_use, start_pairs, local, w_use, h, v)
    # upper bound: sum_{t < T} min(1, m_t) + sum_{t >= T} m_t, with m_0 = #start pairs,
    # m_t = v_1 . u_{t-1} (u_s = Q^s 1 = survival probabilities of the pairs) and
    # sum_{t >= T} m_t = v_1 . h - sum_{t=1}^{T-1} m_t   (h = sum_s u_s)
    vh = float(v @ h)
    head = min(1.0, float(start_pairs.size))           # t = 0
    m = float(v.sum())                                  # m_1 = v_1 . u_0
    seen = 0.0                                          # sum_{t=1}^{T-1} m_t
    t = 1
    u = np.ones(R)
    nxt = np.empty(R)
    while m >= 1.0 and t < max_iterations and clock() - t0 < time_budget:
        head += 1.0                                     # min(1, m_t) with m_t >= 1
        seen += m
        m = _ck.pair_survival_step(img, w_use, u, nxt, v)   # m_{t+1} = v_1 . u_t
        u, nxt = nxt, u
        t += 1
    upper = head + max(0.0, vh - seen)
    return {"lower": float(lower), "upper": float(upper), "pairs": int(R), "memory_mb": float(mem),
            "iterations": int(t), "residual": residual}


def pair_chain_memory_mb(n: int, k: int, n_start: int) -> float:
    """Worst-case memory (MB) of :func:`pair_chain_bounds` on ``n`` states, ``k`` letters and
    ``n_start`` start states: the dense pair index (8 bytes per pair of states), the reachable
    pairs with their images and the chain's matrix (every pair reachable, row pointers included),
    the start pairs, and a page of fixed overhead."""
    pairs = n * (n - 1) / 2
    start_pairs = n_start * (n_start - 1) / 2
    return (pairs * (8 + 8 + 4 * k + 12 * (k + 1)) + start_pairs * 24 + 16 * (pairs + 1) + 4096) / 2 ** 20


def _start_pairs_can_merge(d_use, start_pairs, local, can, n):
    k = d_use.shape[0]
    first = pair_offsets(n)
    p = np.searchsorted(first, start_pairs, side="right") - 1
    q = start_pairs - first[p] + p + 1
    ok = np.zeros(start_pairs.size, dtype=bool)
    for a in range(k):
        pp, qq = d_use[a, p], d_use[a, q]
        merged = pp == qq
        lo, hi = np.minimum(pp, qq).astype(np.int64), np.maximum(pp, qq).astype(np.int64)
        idx = np.where(merged, 0, pair_index(lo, hi, n))
        loc = np.where(merged, -1, local[idx])
        ok |= merged | can[np.where(loc >= 0, loc, 0)] & (loc >= 0)
    return bool(np.all(ok))


# ----------------------------------------------------------------------------- all together
#: Monte Carlo work bound of :func:`default_mc_steps`: runs x letters x 64-state words (about 20 s
#: at the 1e9 word operations per second measured on a 100,000-state random automaton).
MC_WORD_OPERATIONS = 2e10


def default_mc_steps(n_states: int, runs: int) -> int:
    """Letters per Monte Carlo run before it is censored: 100,000, or fewer (at least 1,000) so
    that ``runs x letters x ceil(n_states / 64) <= MC_WORD_OPERATIONS``. A bound on the work, not
    on the clock, so the answer depends on the inputs and the seed alone.

    >>> default_mc_steps(2_000, 2_000), default_mc_steps(100_000, 2_000)
    (100000, 6397)

    Parameters
    ----------
    n_states, runs : int
        Size of the automaton and Monte Carlo runs.

    Returns
    -------
    int
    """
    words = -(-int(n_states) // 64)
    return int(min(100_000, max(1_000, MC_WORD_OPERATIONS // (max(1, int(runs)) * words))))


def expected_sync_length(aut: SyncAutomaton | TransitionModel, start=None, weights=None, seed=0, runs: int = 2000,
                         max_subsets: int = 200_000, max_steps: int | None = None,
                         pair_time_budget: float = 45.0, mc_time_budget: float | None = None,
                         memory_budget_mb: float = 2048.0) -> dict:
    """``E[T]`` by every method: keys ``exact``, ``monte_carlo``, ``ci95``, ``monte_carlo_lower``,
    ``pair_lower``, ``pair_upper`` (None where unavailable or infinite; ``infinite`` True when
    ``E[T] = inf``) plus diagnostics. With censored Monte Carlo runs (``mc_censored``) only
    ``monte_carlo_lower`` is given (:func:`monte_carlo_sync_length`).

    The pair-graph synchronizability check (quadratic in the states) runs first only when its
    arrays fit in half of ``memory_budget_mb``; otherwise it is skipped (``pair_check`` says so) and
    a never-merging start set shows as censored Monte Carlo runs instead. The pair-chain bounds
    run only within ``memory_budget_mb`` (``pair_bounds`` says why they are missing).

    Monte Carlo runs are censored after ``max_steps`` letters; None means
    :func:`default_mc_steps` (100,000, fewer on big automata, so that the phase's work is bounded
    without a clock and the seed alone fixes the answer). ``mc_max_steps`` says what was used.

    Parameters
    ----------
    aut, start, weights
        As for :func:`exact_expected_length`.
    seed : int
        Seed of the Monte Carlo runs.
    runs, max_subsets, max_steps
        Monte Carlo runs, the exact method's subset budget, and letters before a run is censored.
    pair_time_budget, mc_time_budget, memory_budget_mb
        Budgets of the pair chain, the Monte Carlo runs and memory.

    Returns
    -------
    dict
    """
    aut, start = as_automaton(aut, start)
    out = {}
    pair_mb = pair_check_memory_mb(aut.n)
    if pair_mb > 0.5 * memory_budget_mb:
        out["pair_check"] = f"skipped: it needs {pair_mb:,.0f} MB, over half the memory budget"
        check = {"synchronizing": None, "witness": None}
    else:
        out["pair_check"] = "done"
        check = synchronizability(aut, as_start(aut, start))
    if check["synchronizing"] is False:
        # some start pair never merges: T is infinite on every word
        return {"exact": None, "monte_carlo": None, "ci95": [None, None], "monte_carlo_lower": None,
                "mc_max_steps": None,
                "pair_lower": None,
                "pair_upper": None, "subsets": None, "mc_runs": 0, "mc_censored": 0, "pair_states": None,
                "pair_memory_mb": None, "pair_residual": None, "infinite": True,
                "witness": check["witness"], "pair_check": out["pair_check"]}
    mc_steps = default_mc_steps(aut.n, runs) if max_steps is None else int(max_steps)
    out["mc_max_steps"] = mc_steps
    exact, info = exact_expected_length(aut, start, weights, max_subsets)
    infinite = exact is not None and math.isinf(exact)
    out["exact"] = _finite_or_none(exact)
    out["subsets"] = info["subsets"]
    if infinite:
        mc = {"mean": None, "ci95": [None, None], "runs": 0, "censored": 0, "lower": None}
    else:
        mc = monte_carlo_sync_length(aut, start, weights, runs=runs, seed=seed, max_steps=mc_steps,
                                     time_budget=mc_time_budget)
    out["monte_carlo"] = mc["mean"]
    out["ci95"] = mc["ci95"]
    out["monte_carlo_lower"] = mc.get("lower")
    out["mc_runs"] = mc["runs"]
    out["mc_censored"] = mc["censored"]
    pb = pair_chain_bounds(aut, start, weights, time_budget=pair_time_budget, memory_budget_mb=memory_budget_mb)
    if "note" in pb:
        out["pair_bounds"] = pb["note"]
    if pb["lower"] is not None and math.isinf(pb["lower"]):
        infinite = True
    out["pair_lower"] = _finite_or_none(pb["lower"])
    out["pair_upper"] = _finite_or_none(pb["upper"])
    out["pair_states"] = pb["pairs"]
    out["pair_memory_mb"] = pb["memory_mb"]
    out["pair_residual"] = pb["residual"]
    out["infinite"] = bool(infinite)
    return out


def monte_carlo_entropy_tilts(model, epsilon: float, weights=None, runs: int = 500, seed=0,
                              max_steps: int = 1000):
    """Monte Carlo: expected number of random tilts until the predicted entropy from
    ``model.initial`` is ``<= epsilon`` (partition cells, or states without a partition).

    Returns ``dict(mean, ci95, runs, censored, std, lower)`` as :func:`monte_carlo_sync_length`
    does: with any run censored (not reached within ``max_steps``) only ``lower``, the mean of
    ``min(tilts, max_steps)``, is given.

    Parameters
    ----------
    model : TransitionModel
        The model.
    epsilon : float
        Entropy threshold (bits).
    weights : array_like, optional
        Action probabilities up to a factor (default uniform).
    runs : int
        Random runs.
    seed : int
        Their seed.
    max_steps : int
        Tilts before a run is censored.

    Returns
    -------
    dict

    See Also
    --------
    kruskal_markov.ensemble.run_ensemble : entropy statistics of random sequences of a fixed length.
    kruskal_markov.sync.shortest.shortest_word : the shortest word that orients the part.
    """
    epsilon = float(epsilon)
    if not epsilon >= 0:
        raise ValueError(f"epsilon must be >= 0, got {epsilon}")
    w = letter_weights(model.n_actions, weights)
    rng = np.random.default_rng(seed)
    indptr, indices, data = model.packed()
    if model.partition is None:
        part = np.arange(model.n_states, dtype=np.int64)
        part.flags.writeable = False    # as the model's own partition: one compiled signature
        ncells = model.n_states
    else:
        part = np.asarray(model.partition, dtype=np.int64)
        ncells = int(model.n_cells if model.n_cells else part.max() + 1)
    letters = rng.choice(model.n_actions, size=(runs, max_steps), p=w).astype(np.int64)
    steps = np.empty(runs, dtype=np.int64)
    _ck.mc_entropy_steps(np.asarray(model.initial, dtype=np.float64), indptr, indices, data, part,
                         ncells, letters, epsilon, steps)
    # entropy already <= epsilon before any tilt
    if partition_entropy_bits(np.asarray(model.initial, dtype=np.float64), part, ncells) <= epsilon:
        steps[:] = 0
    done = steps >= 0
    return censored_mean(np.where(done, steps, max_steps).astype(np.float64), done)


def censored_mean(steps: np.ndarray, done: np.ndarray) -> dict:
    """The Monte Carlo summary of run lengths, some of which may be censored.

    Mean and 95% interval (mean +- 1.96 sample standard errors, ``ddof=1``) of ``steps`` when
    every run is ``done``; else only ``lower``, the mean of the steps run (each censored run
    counts the steps it ran: a lower bound of its length) -- a mean over the finished runs alone
    would be biased low.

    Parameters
    ----------
    steps : ndarray of float
        Per run, its length, or the steps it ran when censored.
    done : ndarray of bool
        Per run, whether it finished.

    Returns
    -------
    dict
        ``mean``, ``ci95``, ``runs``, ``censored``, ``std`` and ``lower`` (the keys of
        :func:`monte_carlo_sync_length` and :func:`monte_carlo_entropy_tilts`).

    Examples
    --------
    >>> censored_mean(np.array([2.0, 4.0]), np.array([True, False]))["lower"]
    3.0
    """
    runs = int(steps.size)
    censored = int(runs - done.sum())
    lower = float(steps.mean()) if runs else None
    if censored or runs == 0:
        return {"mean": None, "ci95": [None, None], "runs": runs, "censored": censored, "std": None,
                "lower": lower}
    sd = float(steps.std(ddof=1)) if runs > 1 else 0.0
    half = 1.96 * sd / math.sqrt(runs)
    return {"mean": lower, "ci95": [lower - half, lower + half], "runs": runs, "censored": 0, "std": sd,
            "lower": lower}
