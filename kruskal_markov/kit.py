"""Kits: one tilt sequence applied to several parts, each in its own compartment of one tray.

Each compartment has its own model (its own states, cells and start distribution); every model
shares the action alphabet. Given the sequence, the parts move independently (they never touch:
each lies in its own walled compartment), so

- the kit's joint pose distribution after a sequence is the product of the compartments' ones,
  and its report-cell entropy is the **sum** of theirs (:func:`kit_ensemble` reports that sum);
- a sequence orients the kit when it orients every compartment **at the same step** (a part can
  be oriented at one step and spread again later under a stochastic model); the kit's convergence
  step is the first step at which every compartment is converged;
- a plan for the kit is one word that meets the target under every compartment's model, which is
  the robust-plan search over several models (:func:`~kruskal_markov.sync.plan.shortest_plan`:
  the states of all models form one disjoint union and each model's image must lie in one of its
  own cells), so the kit plan is proven shortest (or bracketed) exactly as a single part's; the
  joint success probability of the plan is the product of the compartments' (independence).

The random-convergence time of a kit is **not** the maximum of the compartments' expected times:
the compartments share the sequence, so their times are dependent. It is computed by sampling
shared random sequences (:func:`kit_sync_lengths`, :func:`kit_entropy_tilts`): each sampled
sequence drives every compartment, and the run ends when all are converged at once. Every
compartment's own expected time is a proven lower bound of the kit's (the kit cannot be converged
before each of its parts first is).

The letters are drawn exactly as the single-part Monte Carlo draws them
(:func:`~kruskal_markov.convergence.monte_carlo_sync_length`,
:func:`~kruskal_markov.convergence.monte_carlo_entropy_tilts`,
:func:`~kruskal_markov.ensemble.run_ensemble`), so a one-compartment kit gives the single part's
answers exactly, and the compartments' own figures are taken on the kit's sequences.
"""
from __future__ import annotations

import math

import numpy as np

from kruskal_markov import _kit_kernels as _kk
from kruskal_markov.convergence import censored_mean, letter_weights
from kruskal_markov.entropy import partition_entropy_bits

__all__ = ["kit_plan", "kit_ensemble", "kit_sync_lengths", "kit_entropy_tilts", "union_automaton", "wilson_interval"]


def _check_models(models) -> list:
    models = list(models)
    if not models:
        raise ValueError("a kit needs at least one compartment model")
    actions = tuple(models[0].actions)
    for m in models[1:]:
        if tuple(m.actions) != actions:
            raise ValueError(f"the compartments' models do not share their actions: {list(actions)} and "
                             f"{list(m.actions)}")
    return models


def kit_plan(models, target="cell", **budgets) -> dict:
    """The shortest common plan of a kit and each compartment's own shortest plan.

    Parameters
    ----------
    models : list of TransitionModel
        One per compartment (shared action names).
    target : str
        ``state``, ``cell`` or ``probability:E`` (per compartment: for ``probability:E`` every
        compartment must end in one of its cells with probability >= 1 - E).
    **budgets
        Passed to :func:`~kruskal_markov.sync.plan.shortest_plan` (``node_budget``,
        ``time_budget``, ``memory_budget_mb``, ``beam_width``, ``max_length``, ``threshold``,
        ``cells``: one cell map per model).

    Returns
    -------
    dict
        ``common`` (:class:`~kruskal_markov.sync.plan.PlanResult` over all models), ``own`` (one
        PlanResult per compartment) and ``joint_success`` (the product of the compartments'
        success probabilities of the common word, None without a word).

    Examples
    --------
    >>> from kruskal_markov.automaton_json import model_from_automaton
    >>> a = model_from_automaton({"states": 3, "actions": {"x": [1, 2, 2], "y": [0, 0, 1]}})
    >>> b = model_from_automaton({"states": 2, "actions": {"x": [0, 0], "y": [1, 1]}})
    >>> r = kit_plan([a, b], "state")
    >>> [p.length for p in r["own"]], r["common"].length, "".join(r["common"].word)
    ([2, 1], 2, 'xx')
    """
    from kruskal_markov.sync.plan import shortest_plan

    models = _check_models(models)
    cells = budgets.pop("cells", None)
    common = shortest_plan(models, target, cells=cells, **budgets)
    own = [common] if len(models) == 1 else [
        shortest_plan(m, target, cells=None if cells is None else [cells[i]], **budgets) for i, m in enumerate(models)]
    joint = None
    if common.word is not None:
        probs = common.success_probability
        probs = probs if isinstance(probs, list) else [probs]
        joint = float(np.prod(probs))
    return {"common": common, "own": own, "joint_success": joint}


def kit_ensemble(models, count: int, length: int, seed=None, epsilon: float = 1e-9, weights=None,
                 threads: int | None = None) -> dict:
    """Random sequences through every compartment: the kit's Fig. 3 statistics.

    Every compartment runs the same ``count`` random sequences
    (:func:`~kruskal_markov.ensemble.run_ensemble` with one ``seed``). The kit's entropy is the
    sum of the compartments' (the joint distribution is their product); a sequence converges at
    the first step where every compartment's entropy is ``<= epsilon``.

    Parameters
    ----------
    models : list of TransitionModel
    count, length : int
        Random sequences and their length.
    seed : int or None
        Seed of the sequences.
    epsilon : float
        Convergence threshold (bits) of every compartment.
    weights : array_like, optional
        Action probabilities.
    threads : int, optional
        Numba threads.

    Returns
    -------
    dict
        ``sequences``, ``entropy`` (K x (N+1), the kit's), ``mean``, ``q25``, ``q75``,
        ``convergence_steps`` (-1: never), ``converged``, ``best_index``, ``best_sequence``,
        ``best_entropy``, ``compartments`` (each compartment's
        :class:`~kruskal_markov.ensemble.EnsembleResult`, entropy kept).
    """
    from kruskal_markov.ensemble import best_sequence_index, convergence_steps, run_ensemble

    models = _check_models(models)
    parts = [run_ensemble(m, count, length, seed=seed, epsilon=epsilon, weights=weights, keep_entropy=True,
                          threads=threads) for m in models]
    h = parts[0].entropy.copy() if len(parts) == 1 else np.sum([p.entropy for p in parts], axis=0)
    hmax = parts[0].entropy if len(parts) == 1 else np.max([p.entropy for p in parts], axis=0)
    steps = convergence_steps(hmax, float(epsilon))
    best = best_sequence_index(steps, h[:, -1])
    q25, q75 = np.quantile(h, [0.25, 0.75], axis=0)
    return {"sequences": parts[0].sequences, "entropy": h, "mean": h.mean(axis=0), "q25": q25, "q75": q75,
            "convergence_steps": steps, "converged": int(np.count_nonzero(steps >= 0)), "best_index": best,
            "best_sequence": parts[0].sequences[best].astype(np.int64), "best_entropy": h[best].copy(),
            "epsilon": float(epsilon), "compartments": parts}


def union_automaton(automata):
    """The disjoint union of support automata sharing their letters, and each union state's compartment.

    Parameters
    ----------
    automata : list of SyncAutomaton

    Returns
    -------
    (SyncAutomaton, ndarray of int64, ndarray of int64)
        The union, ``comp_of`` (compartment of every union state) and the state offsets.
    """
    from kruskal_markov.sync.automaton import SyncAutomaton

    k = automata[0].k
    sizes = [a.n for a in automata]
    offsets = np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)
    n = int(offsets[-1])
    indptr = np.zeros((k, n + 1), dtype=np.int64)
    parts, pos = [], 0
    for x in range(k):
        indptr[x, 0] = pos
        counts = []
        for i, a in enumerate(automata):
            lo, hi = a.indptr[x, 0], a.indptr[x, -1]
            parts.append(a.indices[lo:hi].astype(np.int32) + np.int32(offsets[i]))
            counts.append(np.diff(a.indptr[x]))
        indptr[x, 1:] = pos + np.cumsum(np.concatenate(counts))
        pos = int(indptr[x, -1])
    union = SyncAutomaton(tuple(automata[0].actions), n, all(a.deterministic for a in automata), indptr,
                          np.concatenate(parts).astype(np.int32),
                          mass_dropped=max(a.mass_dropped for a in automata))
    comp_of = np.repeat(np.arange(len(automata), dtype=np.int64), sizes)
    return union, comp_of, offsets


def kit_sync_lengths(automata, starts, weights=None, runs: int = 2000, seed=0, max_steps: int = 100_000,
                     chunk: int = 64) -> dict:
    """Monte Carlo of the random tilts until every compartment's support set is one state at once.

    Letters are drawn as :func:`~kruskal_markov.convergence.monte_carlo_sync_length` draws them
    (one generator from ``seed``, chunks of letters for the runs still going), and one drawn
    sequence drives every compartment: the compartments' times are dependent, so the kit's
    expected time is not the maximum of theirs (each of theirs is a lower bound of it).

    Parameters
    ----------
    automata : list of SyncAutomaton
        The compartments' support automata (shared letters).
    starts : list of array_like of int
        Each compartment's start set.
    weights : array_like, optional
        Letter probabilities (default uniform).
    runs, seed, max_steps, chunk : int
        As for :func:`~kruskal_markov.convergence.monte_carlo_sync_length`.

    Returns
    -------
    dict
        ``mean``, ``ci95``, ``runs``, ``censored``, ``std``, ``lower``
        (:func:`~kruskal_markov.convergence.censored_mean`).
    """
    if runs < 2:
        raise ValueError("Monte Carlo needs at least 2 runs")
    union, comp_of, offsets = union_automaton(list(automata))
    if not union.deterministic:        # the kernel's successor bitsets: letters x states x words
        from kruskal_markov.limits import check_memory

        check_memory(8.0 * union.k * union.n * union.n_words,
                     f"the Monte Carlo bitsets of a kit of {union.n:,} states in all",
                     "use coarser compartment models (--resolution)")
    start = np.concatenate([np.asarray(s, dtype=np.int64) + offsets[i] for i, s in enumerate(starts)])
    w = letter_weights(union.k, weights)
    rng = np.random.default_rng(seed)
    cur = np.tile(union.bits(start), (runs, 1))
    steps = np.zeros(runs, dtype=np.int64)
    done = np.zeros(runs, dtype=bool)
    if all(np.asarray(s).size == 1 for s in starts):
        done[:] = True
    n_comp = len(starts)
    while not np.all(done) and steps[~done].max(initial=0) < max_steps:
        active = np.flatnonzero(~done)
        chunk = min(chunk, max_steps - int(steps[active].max()))
        letters = rng.choice(union.k, size=(active.size, chunk), p=w).astype(np.int64)
        sub_cur, sub_steps, sub_done = cur[active], steps[active], done[active]
        _kk.mc_kit_sync_steps(sub_cur, letters, union.delta, union.sup, union.deterministic, comp_of, n_comp,
                              sub_steps, sub_done)
        cur[active], steps[active], done[active] = sub_cur, sub_steps, sub_done
        chunk = min(4 * chunk, 4096)
    return censored_mean(steps.astype(np.float64), done)


def _union_model_arrays(models):
    """The compartments' matrices side by side: ``(p0, indptr, indices, data, partition, cell_comp)``."""
    k = models[0].n_actions
    sizes = [m.n_states for m in models]
    offsets = np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)
    n = int(offsets[-1])
    packed = [m.packed() for m in models]
    indptr = np.zeros((k, n + 1), dtype=np.int64)
    idx_parts, data_parts, pos = [], [], 0
    for a in range(k):
        indptr[a, 0] = pos
        counts = []
        for i, (ip, ix, dt) in enumerate(packed):
            lo, hi = ip[a, 0], ip[a, -1]
            idx_parts.append(ix[lo:hi].astype(np.int32) + np.int32(offsets[i]))
            data_parts.append(dt[lo:hi])
            counts.append(np.diff(ip[a]))
        indptr[a, 1:] = pos + np.cumsum(np.concatenate(counts))
        pos = int(indptr[a, -1])
    part, cell_comp, cell_off = [], [], 0
    for i, m in enumerate(models):
        if m.partition is None:
            p, nc = np.arange(m.n_states, dtype=np.int64), m.n_states
        else:
            p = np.asarray(m.partition, dtype=np.int64)
            nc = int(m.n_cells if m.n_cells else p.max() + 1)
        part.append(p + cell_off)
        cell_comp.append(np.full(nc, i, dtype=np.int64))
        cell_off += nc
    p0 = np.concatenate([np.asarray(m.initial, dtype=np.float64) for m in models])
    return (p0, indptr, np.concatenate(idx_parts), np.concatenate(data_parts), np.concatenate(part),
            np.concatenate(cell_comp))


def kit_entropy_tilts(models, epsilon: float, weights=None, runs: int = 500, seed=0, max_steps: int = 1000) -> dict:
    """Monte Carlo of the random tilts until every compartment's predicted entropy is ``<= epsilon`` at once.

    The letters are those of :func:`~kruskal_markov.convergence.monte_carlo_entropy_tilts` with
    the same arguments (one drawn sequence drives every compartment).

    Parameters
    ----------
    models : list of TransitionModel
    epsilon : float
        Entropy threshold (bits) of every compartment.
    weights : array_like, optional
        Action probabilities.
    runs, seed, max_steps : int
        Random runs, their seed, tilts before a run is censored.

    Returns
    -------
    dict
        As :func:`~kruskal_markov.convergence.censored_mean`.
    """
    models = _check_models(models)
    epsilon = float(epsilon)
    if not epsilon >= 0:
        raise ValueError(f"epsilon must be >= 0, got {epsilon}")
    w = letter_weights(models[0].n_actions, weights)
    rng = np.random.default_rng(seed)
    p0, indptr, indices, data, part, cell_comp = _union_model_arrays(models)
    letters = rng.choice(models[0].n_actions, size=(runs, max_steps), p=w).astype(np.int64)
    steps = np.empty(runs, dtype=np.int64)
    _kk.mc_kit_entropy_steps(p0, indptr, indices, data, part, cell_comp, int(cell_comp.size), len(models), letters,
                             epsilon, steps)
    if all(_initial_entropy(m) <= epsilon for m in models):
        steps[:] = 0
    done = steps >= 0
    return censored_mean(np.where(done, steps, max_steps).astype(np.float64), done)


def _initial_entropy(model) -> float:
    if model.partition is None:
        part, nc = np.arange(model.n_states, dtype=np.int64), model.n_states
    else:
        part = np.asarray(model.partition, dtype=np.int64)
        nc = int(model.n_cells if model.n_cells else part.max() + 1)
    return float(partition_entropy_bits(np.asarray(model.initial, dtype=np.float64), part, nc))


def wilson_interval(successes: int, trials: int, z: float = 1.96) -> list:
    """The Wilson score interval of a binomial share (95% by default).

    >>> [round(x, 3) for x in wilson_interval(5, 10)]
    [0.237, 0.763]
    """
    if trials <= 0:
        return [None, None]
    p = successes / trials
    den = 1.0 + z * z / trials
    mid = (p + z * z / (2 * trials)) / den
    half = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / den
    lo = 0.0 if successes <= 0 else max(0.0, mid - half)
    hi = 1.0 if successes >= trials else min(1.0, mid + half)
    return [lo, hi]
