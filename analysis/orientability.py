"""How well random (or planned) tilts orient one part, from its built model: the ranking metrics.

Every number comes from the model alone (no re-simulation):

- the shortest synchronizing word of the support automaton from the initial support (the optimal
  sensorless plan; exact within a time budget, else a greedy word with a proven lower bound);
- the expected number of uniformly random tilts until the predicted report-grid entropy is
  ``<= epsilon`` (Monte Carlo over random sequences through the model), and the expected length of a
  random *synchronizing* sequence of the support automaton (Monte Carlo, every start state merged);
- the mean predicted entropy after 10 and after 50 random tilts, and the share of random 50-tilt
  sequences that converge (entropy ``<= epsilon``), over an ensemble of random sequences.

"Converged" means a predicted entropy of at most ``epsilon`` bits: 1e-3 by default, which is what
a leak of about 1e-4 of the mass into a second cell gives, i.e. about one trial in 10,000 of a
direct simulation (the paper's zero entropy at M = 10,000). The report grid takes theta modulo the
part's rotational symmetry order, so every metric is up to the part's symmetry.
"""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from analysis.streams import salted
from kruskal_markov.entropy import CONVERGED_BITS
from kruskal_markov.model import TransitionModel

__all__ = ["CONVERGED_BITS", "PartMetrics", "part_metrics", "rank_parts"]


@dataclasses.dataclass(frozen=True)
class PartMetrics:
    """Orientability metrics of one part (see the module docstring).

    ``sync_word`` is a list of action names (None when none was found); ``sync_exact`` says whether it
    is proven shortest; ``sync_lower_bound`` is a proven lower bound on the shortest length.
    ``random_tilts`` is the Monte Carlo mean of random tilts until entropy <= epsilon with its 95%
    interval ``random_tilts_ci95`` and ``random_tilts_censored`` runs that never got there within
    ``max_tilts``; ``random_sync_length`` the same for merging every start state of the support
    automaton. A mean over the finished runs alone would be biased low, so with any censored run
    the mean is None and ``random_tilts_lower`` / ``random_sync_lower`` (each censored run counted
    at the tilts it ran: a lower bound) is what is known; without censoring they equal the means.

    Attributes
    ----------
    states : int
        States of the model.
    sync_word, sync_length, sync_exact, sync_lower_bound, sync_method
        The shortest synchronizing word found (action names; None if none), its length, whether it is
        proven shortest, a proven lower bound and the search that found it.
    random_tilts, random_tilts_ci95, random_tilts_censored, random_tilts_lower
        Random tilts until entropy <= ``epsilon``: mean, 95% interval, censored runs, lower bound.
    random_sync_length, random_sync_ci95, random_sync_censored, random_sync_lower
        The same for merging every start state of the support automaton.
    mean_entropy_10, mean_entropy_50 : float
        Mean entropy (bits) after 10 and 50 random tilts.
    converging_share_50 : float
        Share of random 50-tilt sequences that reach ``epsilon``.
    initial_entropy : float
        Entropy of the start distribution (bits).
    epsilon : float
        The convergence threshold (bits).
    seconds : float
        Time taken.
    sync_target : str
        The plan target of ``sync_word``.
    intervals : dict or None
        Each answer's ``value``, ``mc_ci95``, ``posterior_ci90``, ``structural_range`` and
        ``model_ci90`` (:func:`kruskal_markov.answers.answer_intervals`).
    """

    states: int
    sync_word: list | None
    sync_length: int | None
    sync_exact: bool
    sync_lower_bound: int | None
    sync_method: str
    random_tilts: float | None
    random_tilts_ci95: tuple
    random_tilts_censored: int
    random_sync_length: float | None
    random_sync_ci95: tuple
    random_sync_censored: int
    random_tilts_lower: float | None
    random_sync_lower: float | None
    mean_entropy_10: float
    mean_entropy_50: float
    converging_share_50: float
    initial_entropy: float
    epsilon: float
    seconds: float
    #: the plan target of ``sync_word`` (kruskal_markov.sync.targets): every start state to one model state
    sync_target: str = "state"
    #: :func:`kruskal_markov.answers.answer_intervals` of the converging share, the mean entropies and
    #: the random tilts (Monte Carlo and model intervals); None when not computed
    intervals: dict | None = None

    def to_dict(self) -> dict:
        """Plain JSON-ready dictionary of the fields."""
        return dataclasses.asdict(self)

    def as_dict(self) -> dict:
        """Deprecated alias of :meth:`to_dict` (every result serialises with ``to_dict``)."""
        import warnings

        from kruskal_markov.errors import KruskalDeprecationWarning

        warnings.warn("PartMetrics.as_dict is deprecated; use to_dict", KruskalDeprecationWarning, stacklevel=2)
        return self.to_dict()


def part_metrics(model: TransitionModel, *, seed: int = 0, count: int = 2000, runs: int = 500,
                 epsilon: float = CONVERGED_BITS, max_tilts: int = 1000, sync_time_budget: float = 30.0,
                 threads: int | None = None, sync_node_budget: int | None = None, draws: int = 10,
                 structural_delta: float | None = None) -> PartMetrics:
    """Orientability metrics of the part a model describes.

    Parameters
    ----------
    model : TransitionModel
        A built model (report partition expected; without one the entropy is on the states).
    seed : int
        Seeds the random sequences (ensemble: ``seed``; Monte Carlo lengths: the salted streams ``orientability.*`` of :mod:`analysis.streams`).
    count : int
        Random 50-tilt sequences of the ensemble (mean entropy at 10 and 50, converging share).
    runs : int
        Monte Carlo runs of the expected random lengths.
    epsilon : float
        Convergence threshold in bits.
    max_tilts : int
        A Monte Carlo run not converged after this many tilts is censored (and counted).
    sync_time_budget : float
        Seconds for the exact shortest-word search before the greedy fallback.
    threads : int, optional
        Numba threads of the ensemble.
    sync_node_budget : int, optional
        Subsets per direction of the exact search; when given it replaces ``sync_time_budget``, so
        the metrics do not depend on the machine's speed.
    draws : int
        Posterior draws of the answers' model intervals (0: none).
    structural_delta : float, optional
        Relative structural error of those intervals (None: the model's own, :func:`kruskal_markov.structural.structural_term`).

    Returns
    -------
    PartMetrics

    Notes
    -----
    The shortest word is searched from the support of the initial distribution (every pose a part
    can come to rest in after its first tilt, plus the start cells), i.e. the ``kruskal sync
    --start initial`` question, the plan target ``state``: it orients a part placed anywhere. Search:
    Kisielewicz, Kowalski and Szykula (2015) bidirectional BFS, then depth-first when memory runs out
    (Szykula and Zyzik 2022), Eppstein (1990) greedy fallback at the time budget (``kruskal_markov.sync``).

    References
    ----------
    .. [1] A. Kisielewicz, J. Kowalski, M. Szykula, "Computing the shortest reset words of
       synchronizing automata", J. Comb. Optim. 29 (2015).
    .. [2] D. Eppstein, "Reset sequences for monotonic automata", SIAM J. Comput. 19 (1990).
    """
    from kruskal_markov.convergence import (
        monte_carlo_entropy_tilts,
        monte_carlo_sync_length,
    )
    from kruskal_markov.ensemble import run_ensemble
    from kruskal_markov.entropy import entropy_trajectory
    from kruskal_markov.sync import shortest_word, start_set, support_automaton

    t0 = time.perf_counter()
    ens = run_ensemble(model, count, 50, seed=seed, epsilon=epsilon, threads=threads)
    aut = support_automaton(model, 0.0)
    start = start_set(model, False)
    sync = shortest_word(model, "state", start="initial", time_budget=sync_time_budget, node_budget=sync_node_budget)
    tilts = monte_carlo_entropy_tilts(model, epsilon, runs=runs, seed=salted(seed, "orientability.entropy_tilts"), max_steps=max_tilts)
    rsync = monte_carlo_sync_length(aut, start, runs=runs, seed=salted(seed, "orientability.sync_length"), max_steps=max_tilts)
    h0 = float(entropy_trajectory(model, []).entropy_bits[0])
    from kruskal_markov.answers import answer_intervals

    intervals = answer_intervals(model, seed=seed, count=count, length=50, epsilon=epsilon, runs=runs,
                                 max_steps=max_tilts, draws=draws, draw_count=min(count, 1000),
                                 structural_delta=structural_delta,
                                 structural_sequences=100, ensemble=ens, entropy_tilts=tilts, threads=threads)
    return PartMetrics(
        states=model.n_states,
        sync_word=None if sync.word is None else list(sync.word),
        sync_length=sync.length, sync_exact=bool(sync.exact),
        sync_lower_bound=sync.length if sync.exact else sync.lower_bound, sync_method=sync.method,
        random_tilts=_num(tilts["mean"]), random_tilts_ci95=tuple(_num(x) for x in tilts["ci95"]),
        random_tilts_censored=int(tilts["censored"]),
        random_sync_length=_num(rsync["mean"]), random_sync_ci95=tuple(_num(x) for x in rsync["ci95"]),
        random_sync_censored=int(rsync["censored"]),
        random_tilts_lower=_num(tilts["lower"]), random_sync_lower=_num(rsync["lower"]),
        mean_entropy_10=float(ens.mean[10]), mean_entropy_50=float(ens.mean[50]),
        converging_share_50=ens.converged / count, initial_entropy=h0, epsilon=float(epsilon),
        seconds=time.perf_counter() - t0, intervals=intervals)


def _num(x):
    return None if x is None or not np.isfinite(x) else float(x)


def random_tilts_text(metrics: dict) -> str:
    """The expected random tilts of a part's metrics: the mean, ``>= lower`` when runs were
    censored (the mean of the finished runs alone would be biased low), ``-`` when unknown."""
    if metrics.get("random_tilts") is not None:
        return f"{metrics['random_tilts']:.1f}"
    if metrics.get("random_tilts_lower") is not None:
        return f">= {metrics['random_tilts_lower']:.1f}"
    return "-"


def _first_number(*values):
    return next(v for v in values if v is not None)


def _sort_key(m: PartMetrics):
    inf = float("inf")
    return (0 if m.sync_length is not None else 1,
            (m.random_tilts_censored, _first_number(m.random_tilts, m.random_tilts_lower, inf)),
            inf if m.sync_length is None else m.sync_length,
            -m.converging_share_50, m.mean_entropy_50, m.mean_entropy_10)


#: the ranking's metrics in the order they decide (lower is better unless marked).
RANK_ORDER = ("synchronizable (a word found first)", "random_tilts", "sync_length",
              "converging_share_50 (higher is better)", "mean_entropy_50", "mean_entropy_10")


def rank_parts(metrics: dict[str, PartMetrics]) -> list[dict]:
    """Rank parts: those with a synchronizing word first (a sensorless plan exists), then the fewest
    expected random tilts (first the fewest censored runs, i.e. random sequences that never
    converged, then the mean, or its lower bound when runs were censored), then the shortest word,
    then the larger converging share, then the lower mean entropy after 50 and 10 tilts.

    The expected random length comes before the shortest word because it is always a number with
    a confidence interval, while the shortest word is often only a greedy upper bound (the exact
    search stops at its time budget, sooner on larger models), which would rank a part by how much
    time its search was given; the word still separates parts the random length does not.

    Returns one dictionary per part, best first, with ``shape``, ``rank`` (1 = most orientable), the
    metrics and ``decided_by``: the first metric in that order that separates the part from the next
    one in the ranking (None for the last).

    >>> a = PartMetrics(10, ["N"], 1, True, 1, "exact", 3.0, (2.0, 4.0), 0, 3.0, (2.0, 4.0), 0,
    ...                 3.0, 3.0, 0.1, 0.0, 1.0, 4.0, 1e-3, 0.0)
    >>> b = dataclasses.replace(a, sync_length=2, sync_word=["N", "E"])
    >>> [(r["shape"], r["rank"], r["decided_by"]) for r in rank_parts({"b": b, "a": a})]
    [('a', 1, 'sync_length'), ('b', 2, None)]
    >>> c = dataclasses.replace(a, sync_length=None, sync_word=None)
    >>> [(r["shape"], r["decided_by"]) for r in rank_parts({"c": c, "b": b})]
    [('b', 'synchronizable'), ('c', None)]

    Parameters
    ----------
    metrics : dict of str to PartMetrics
        Shape name -> its metrics (:func:`part_metrics`).

    Returns
    -------
    list of dict
        One per part, best first.
    """
    order = sorted(metrics, key=lambda name: (_sort_key(metrics[name]), name))
    out = []
    for i, name in enumerate(order):
        decided = None
        if i + 1 < len(order):
            k1, k2 = _sort_key(metrics[name]), _sort_key(metrics[order[i + 1]])
            decided = next((RANK_ORDER[j].split(" ")[0] for j in range(len(k1)) if k1[j] != k2[j]), "name")
        out.append({"shape": name, "rank": i + 1, "decided_by": decided, **metrics[name].to_dict()})
    return out
