"""The paper-level answers of a model, each with a Monte Carlo and a model-uncertainty interval.

The answers: the converging share of random ``length``-tilt sequences (entropy <= epsilon at some
tilt), the mean entropy at tilts 10, 20 and 50, and the expected random tilts until the entropy is
<= epsilon. Each comes with

* ``mc_ci95`` — the Monte Carlo interval of its estimate from finitely many random sequences
  (Wilson for the share, ``1.96 sd / sqrt(n)`` for means);
* ``posterior_ci90`` — the 5-95% spread of the answer over draws from the Dirichlet posterior of
  the model's rows (:func:`kruskal_markov.posterior.resample_model`), each draw run on the same
  random sequences as the model (common random numbers, so the spread is the model's, not the
  sequences'); widened, where needed, to contain the point estimate;
* ``structural_range`` — the answer's range when every step's report-cell distribution may lie
  anywhere within the structural total-variation ball of :mod:`kruskal_markov.structural`
  (smallest and largest entropy at each step, on a subsample of sequences, applied as a shift to
  the point estimate);
* ``model_ci90`` — the two model terms added end to end: ``posterior_ci90`` widened by the
  structural range.

The structural ball scales with the probability outside the most likely cell, so a converged
distribution stays converged: the structural range of the converging share and of the expected
tilts measures only how the ball moves the entropy across ``epsilon`` on the way.
"""
from __future__ import annotations

import math

import numpy as np

from kruskal_markov.estimate import Estimate
from kruskal_markov.structural import _entropy_rows, entropy_range_tv, structural_share, structural_term

__all__ = ["answer_intervals", "plan_success_interval", "wilson_interval"]

_ENTROPY_TILTS = (10, 20, 50)
_STREAM_POSTERIOR = 7
_STREAM_STRUCTURAL = 8


def wilson_interval(successes: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (Wilson, JASA 22, 1927), holding ``successes / n``.

    Parameters
    ----------
    successes, n : int
        Successes out of ``n`` trials (``n >= 1``).
    z : float
        Normal quantile (default: 95%).

    Returns
    -------
    (float, float)

    Examples
    --------
    >>> [round(x, 3) for x in wilson_interval(54, 60)]
    [0.799, 0.953]
    """
    if n < 1 or not 0 <= successes <= n:
        raise ValueError(f"need 0 <= successes <= n and n >= 1, got {successes} of {n}")
    p = successes / n
    den = 1 + z * z / n
    mid = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return min(p, max(0.0, mid - half)), max(p, min(1.0, mid + half))


def _cell_curves(model, sequences, delta: float):
    """Per sequence and step: the entropy and the structural ball's smallest and largest entropy.

    Without a structural term only the entropies are computed (Numba, :func:`batch_entropy`); with
    one, each sequence's distributions are summed onto the report cells by one sparse product and
    the ball's range is taken on all rows at once (:func:`entropy_range_tv`).
    """
    import scipy.sparse as sp

    from kruskal_markov.entropy import batch_entropy, entropy_trajectory

    if delta <= 0:
        h = np.asarray(batch_entropy(model, np.asarray(sequences)).entropy_bits, dtype=np.float64)
        return h, h, h
    ncells = int(model.n_cells) if model.partition is not None else model.n_states
    part = np.asarray(model.partition) if model.partition is not None else np.arange(model.n_states)
    onto = sp.csr_matrix((np.ones(model.n_states), (np.arange(model.n_states), part)),
                         shape=(model.n_states, ncells))
    c = np.stack([np.asarray(onto.T @ np.asarray(entropy_trajectory(model, seq, return_distributions=True)
                                                 .distributions).T).T for seq in sequences])
    flat = c.reshape(-1, c.shape[-1])
    flat = flat / flat.sum(1, keepdims=True)
    h = _entropy_rows(flat)
    hmin, hmax = entropy_range_tv(flat, delta * structural_share(flat))
    shape = c.shape[:2]
    return h.reshape(shape), np.minimum(hmin, h).reshape(shape), np.maximum(hmax, h).reshape(shape)


def _first_hit(h: np.ndarray, epsilon: float) -> np.ndarray:
    hit = h <= epsilon
    first = np.argmax(hit, axis=1).astype(np.float64)
    first[~hit.any(axis=1)] = np.nan
    return first


def _combine(value, mc, post, struct, note=None, **extra) -> dict:
    return Estimate.combine(value, mc=mc, posterior=post, structural=struct, note=note, **extra).to_dict()


def answer_intervals(model, *, seed=0, count: int = 2000, length: int = 50, epsilon: float = 1e-3,
                     runs: int = 0, max_steps: int = 1000, draws: int = 20, draw_count: int = 200,
                     structural_delta: float | None = None, structural_sequences: int = 200,
                     weights=None, ensemble=None, entropy_tilts=None, threads=None) -> dict:
    """The converging share, mean entropies and expected random tilts, each with its intervals.

    Parameters
    ----------
    model : TransitionModel
        The model (a report partition: entropy on cells; otherwise on states).
    seed : int or sequence of int
        Seeds the random sequences (the ensemble: ``seed``, as :func:`run_ensemble`).
    count, length : int
        Random sequences of the ensemble and their length.
    epsilon : float
        Convergence threshold in bits.
    runs : int
        Monte Carlo runs of the expected random tilts (0: not computed).
    max_steps : int
        Censoring length of those runs.
    draws : int
        Posterior draws (0, or a model without counts: no ``posterior_ci90``).
    draw_count : int
        Sequences each draw is run on (and at most 200 Monte Carlo runs).
    structural_delta : float, optional
        Relative structural error (0: empty structural ranges); None: the model's own
        (:func:`kruskal_markov.structural.structural_term` — its calibration, the default for a built
        model, none for a model that was not sampled).
    structural_sequences : int
        Sequences of the structural subsample (they also give the mean entropies' Monte Carlo sd).
    weights : array_like, optional
        Action probabilities (default uniform).
    ensemble : EnsembleResult, optional
        The model's ensemble for these settings, if already run.
    entropy_tilts : dict, optional
        :func:`monte_carlo_entropy_tilts` of the model for these settings, if already run.
    threads : int, optional
        Numba threads.

    Returns
    -------
    dict
        ``converging_share``, ``mean_entropy_<t>`` for t in 10, 20, 50 up to ``length`` and, with
        ``runs``, ``random_tilts``: each a dict of ``value``, ``mc_ci95``, ``posterior_ci90``,
        ``structural_range`` and ``model_ci90`` (:meth:`Estimate.to_dict`; ``note`` when the model has
        no structural term); and ``settings`` (with ``structural_delta``, ``structural_source`` and
        ``structural_note``).
    """
    from kruskal_markov.convergence import monte_carlo_entropy_tilts
    from kruskal_markov.ensemble import random_sequences, run_ensemble
    from kruskal_markov.posterior import has_counts, resample_model

    for name, v in (("count", count), ("length", length), ("structural_sequences", structural_sequences)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"{name} must be a positive integer, got {v!r}")
    term = structural_term(model, structural_delta)
    structural_delta = term.delta
    note = term.note if term.source == "none" else None
    tilts = [t for t in _ENTROPY_TILTS if t <= length]
    ens = ensemble if ensemble is not None else run_ensemble(model, count, length, seed=seed, epsilon=epsilon,
                                                              weights=weights, threads=threads)

    def answers(m, n, tilts_runs):
        e = run_ensemble(m, n, length, seed=seed, epsilon=epsilon, weights=weights, threads=threads)
        out = {"converging_share": e.converged / n, **{f"mean_entropy_{t}": float(e.mean[t]) for t in tilts}}
        if tilts_runs:
            r = monte_carlo_entropy_tilts(m, epsilon, weights, runs=tilts_runs, seed=[seed, 5] if np.isscalar(seed)
                                          else [*seed, 5], max_steps=max_steps)
            out["random_tilts"] = r["mean"] if r["mean"] is not None else r["lower"]
        return out

    point = {"converging_share": ens.converged / count, **{f"mean_entropy_{t}": float(ens.mean[t]) for t in tilts}}
    if runs:
        et = entropy_tilts if entropy_tilts is not None else monte_carlo_entropy_tilts(
            model, epsilon, weights, runs=runs, seed=[seed, 5] if np.isscalar(seed) else [*seed, 5],
            max_steps=max_steps)
        point["random_tilts"] = et["mean"] if et["mean"] is not None else et["lower"]
    # posterior: each draw against the model on the same sequences and runs
    post = {k: None for k in point}
    if draws and has_counts(model):
        n = min(count, draw_count)
        r = min(runs, 200)
        base = answers(model, n, r)
        diffs = {k: [] for k in point}
        for i in range(draws):
            d = answers(resample_model(model, np.random.default_rng([int(np.sum(seed)), _STREAM_POSTERIOR, i])), n, r)
            for k in point:
                if d.get(k) is not None and base.get(k) is not None:
                    diffs[k].append(d[k] - base[k])
        for k, v in diffs.items():
            if v and point[k] is not None:
                q = np.quantile(v, [0.05, 0.95])
                post[k] = [point[k] + float(q[0]), point[k] + float(q[1])]
    # structural: the ball's extremes on a subsample of sequences
    cap = max(length, max_steps if runs else 0)
    cap = min(cap, 400)
    seqs = random_sequences(model.n_actions, structural_sequences, cap,
                            seed=[int(np.sum(seed)), _STREAM_STRUCTURAL], weights=weights)
    h, hmin, hmax = _cell_curves(model, seqs, structural_delta)
    out = {}
    conv = lambda a: (a[:, :length + 1] <= epsilon).any(1).mean()          # noqa: E731
    share = point["converging_share"]
    out["converging_share"] = _combine(
        share, list(wilson_interval(ens.converged, count)), post["converging_share"],
        (max(0.0, share + conv(hmax) - conv(h)), min(1.0, share + conv(hmin) - conv(h))), note)
    for t in tilts:
        k = f"mean_entropy_{t}"
        v = point[k]
        sd = float(h[:, t].std(ddof=1)) if len(h) > 1 else 0.0
        half = 1.96 * sd / math.sqrt(count)
        out[k] = _combine(v, [v - half, v + half], post[k],
                          (max(0.0, v + float(np.mean(hmin[:, t] - h[:, t]))), v + float(np.mean(hmax[:, t] - h[:, t]))),
                          note)
    if runs:
        v = point["random_tilts"]
        t0, t_lo, t_hi = _first_hit(h, epsilon), _first_hit(hmin, epsilon), _first_hit(hmax, epsilon)
        fill = lambda a: np.where(np.isnan(a), cap, a)                     # noqa: E731
        mc = et["ci95"] if et["mean"] is not None else [None, None]
        if v is None:
            out["random_tilts"] = Estimate(None, mc_ci95=mc, note=note).to_dict()
        else:
            out["random_tilts"] = _combine(v, mc, post["random_tilts"],
                                           (max(0.0, v + float(np.mean(fill(t_lo) - fill(t0)))),
                                            v + float(np.mean(fill(t_hi) - fill(t0)))), note,
                                           censored=int(et["censored"]))
    out["settings"] = {"count": count, "length": length, "epsilon": epsilon, "runs": runs, "draws":
                       draws if has_counts(model) else 0, "draw_count": min(count, draw_count),
                       **term.to_dict(), "structural_sequences": structural_sequences}
    return out


def plan_success_interval(model, word, success: float, draws: int = 20, seed=0,
                          structural_delta: float | None = None, final_cell: int | None = None) -> dict:
    """A plan's success probability with its posterior and structural intervals.

    Parameters
    ----------
    model : TransitionModel
    word : sequence of int
        The plan (action indices).
    success : float
        Its success probability in the model (the probability in ``final_cell`` after the word).
    draws : int
        Posterior draws (none without counts).
    seed : int
    structural_delta : float, optional
        None: the model's own (:func:`kruskal_markov.structural.structural_term`).
    final_cell : int, optional
        The target cell (default: the most likely cell after the word).

    Returns
    -------
    dict
        ``value``, ``posterior_ci90`` (or None), ``structural_range`` (the final distribution's
        probability outside its most likely cell, times ``structural_delta``, either way) and
        ``model_ci90``; probabilities clipped to [0, 1].
    """
    from kruskal_markov.entropy import entropy_trajectory
    from kruskal_markov.posterior import has_counts, resample_model

    part = np.asarray(model.partition) if model.partition is not None else np.arange(model.n_states)
    ncells = int(model.n_cells) if model.partition is not None else model.n_states

    def final(m):
        p = entropy_trajectory(m, list(word), return_distributions=True).distributions[-1]
        return np.bincount(part, weights=p, minlength=ncells)

    c = final(model)
    cell = int(np.argmax(c)) if final_cell is None else int(final_cell)
    post = None
    if draws and has_counts(model):
        vals = [final(resample_model(model, np.random.default_rng([int(seed), _STREAM_POSTERIOR, i])))[cell]
                for i in range(draws)]
        q = np.quantile(np.asarray(vals) - c[cell], [0.05, 0.95])
        post = [max(0.0, success + float(q[0])), min(1.0, success + float(q[1]))]
    term = structural_term(model, structural_delta)
    share = float(structural_share(c / c.sum())[0])
    s = term.delta * share
    return Estimate.combine(float(success), posterior=post, structural=(max(0.0, success - s), min(1.0, success + s)),
                            note=term.note if term.source == "none" else None, clip=(0.0, 1.0)).to_dict()
