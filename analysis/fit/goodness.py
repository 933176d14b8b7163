"""Goodness of fit: can the best model explain the log at all?

The statistic is the log's mean total-variation distance between its report-cell histogram and the
model's prediction, over the observed steps >= 1 (:func:`analysis.fit.histograms.histogram_distance`'s
measure). Its reference distribution is a parametric bootstrap (Efron & Tibshirani 1993, ch. 16):
``draws`` logs of the same shape (trials, tilt sequences, observed steps) simulated from the model's
Markov chain (of a *sibling*: the same point built again with another build seed, when given), each trial started in the state of its observed start cell (the likelihood conditions
on the observed start too, so an unknown start distribution does not count against the model; a
trial without an observed start starts from the model's initial distribution). The prediction ``p_k``
is the mean of the simulated histograms (the same conditioning). The p-value is
``(1 + #{D_b >= D_log}) / (draws + 1)``; below :data:`ALPHA` the verdict is ``"not explained"``:
the log differs from the model more than logs of its size from the model do, i.e. the interval
need not cover, because no model of the family matches the log's physics.

Why a sibling: logs of the same physics as the models, fitted by them, differ from a model's
prediction by more than that model's own logs do (the models are sampled, discretised builds: on
a 500 x 50 planar log of the key, 0.035 against a 95th percentile of 0.018 for the model's own
logs), so a reference drawn from the model alone calls such a log "not explained". Drawn from the
sibling and scored against the first build's prediction, the reference carries the builds'
disagreement too (95th percentile 0.027 there): a first approximation of the models' error
(docs/fit.md, "Goodness of fit").

Not counted: the camera noise (a pose near a cell boundary may be observed in the neighbouring
cell; at the default 4x4x4 grid the cells are 50 mm and 90 degrees wide against 0.5 mm / 0.5
degree), and misreads (each wild pose adds up to ``1 / n_k`` to its step's distance).
"""
from __future__ import annotations

import numpy as np

__all__ = ["ALPHA", "goodness_of_fit", "simulate_cell_histograms"]

#: the p-value below which the verdict is "not explained".
ALPHA = 0.01


def _start_states(model, log, grid, rng, draws: int) -> np.ndarray:
    """(draws, T) start states: the observed start cell's state, else drawn from the initial distribution."""
    init = np.asarray(model.initial, dtype=np.float64)
    starts = np.flatnonzero(init > 0)
    start_of_cell = np.full(grid.n_voxels, -1, dtype=np.int64)
    start_of_cell[np.asarray(model.partition)[starts]] = starts
    T = log.trials
    fixed = np.full(T, -1, dtype=np.int64)
    o0 = log.observed[:, 0]
    if o0.any():
        fixed[o0] = start_of_cell[grid.voxel_index(log.obs[o0, 0])]
    out = np.repeat(fixed[None, :], draws, axis=0)
    free = out < 0
    if free.any():
        out[free] = rng.choice(starts, int(free.sum()), p=init[starts] / init[starts].sum())
    return out


def _step(matrix, states: np.ndarray, rng) -> np.ndarray:
    """One sampled transition of every state in ``states`` under the CSR ``matrix``."""
    ptr, idx = matrix.indptr, matrix.indices
    cum = np.cumsum(matrix.data.astype(np.float64))
    base = np.where(ptr[states] > 0, cum[np.maximum(ptr[states] - 1, 0)], 0.0)
    total = cum[ptr[states + 1] - 1] - base
    k = np.searchsorted(cum, base + rng.random(len(states)) * total, side="right")
    nxt = idx[np.clip(k, ptr[states], np.maximum(ptr[states + 1] - 1, ptr[states]))]
    return np.where(ptr[states + 1] > ptr[states], nxt, states)   # an empty row: the state stays


def simulate_cell_histograms(model, log, grid, rng, draws: int = 200) -> np.ndarray:
    """(draws, L+1, cells) report-cell counts of ``draws`` logs simulated from ``model`` with the
    log's shape: its trials, tilts and observed steps (see the module)."""
    part = np.asarray(model.partition)
    state = _start_states(model, log, grid, rng, draws)
    L1 = log.obs.shape[1]
    out = np.zeros((draws, L1, model.n_cells))
    obs = log.observed
    rows = np.arange(draws)[:, None]
    for k in range(L1):
        if k > 0:
            act = log.actions[:, k - 1]
            for a in np.unique(act[act >= 0]):
                cols = np.flatnonzero(act == a)
                sub = state[:, cols]
                state[:, cols] = _step(model.matrices[a], sub.ravel(), rng).reshape(sub.shape)
        seen = np.flatnonzero(obs[:, k])
        if seen.size:
            np.add.at(out, (rows, k, part[state[:, seen]]), 1.0)
    return out


def _mean_tv(h: np.ndarray, p: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """Mean over ``steps`` of the TV distance of histograms ``h`` (..., L+1, cells) to ``p`` (L+1, cells)."""
    n = h[..., steps, :].sum(axis=-1, keepdims=True)
    return 0.5 * np.abs(h[..., steps, :] / n - p[steps]).sum(axis=-1).mean(axis=-1)


def goodness_of_fit(model, log, grid, counts: np.ndarray, rng, draws: int = 200, sibling=None) -> dict:
    """The log's histogram distance against logs of its size from ``model`` (see the module).

    Parameters
    ----------
    model : TransitionModel
        The best model.
    log : FitLog
    grid : ReportGrid
        The model's report grid.
    counts : ndarray (L+1, cells)
        The log's cell counts (:func:`analysis.fit.histograms.log_histograms`).
    rng : numpy.random.Generator
    draws : int
    sibling : TransitionModel, optional
        Another build of the same point (another build seed): the reference logs are drawn from it,
        so that they carry the models' own error as well as the trials' (see the module); the
        prediction stays ``model``'s. None: drawn from ``model`` itself.

    Returns
    -------
    dict
        ``statistic`` (its name), ``log`` (the log's distance), ``model_median`` and ``model_95`` (the
        simulated logs' median and 95th percentile), ``p_value``, ``draws``, ``verdict``
        (``"explained"`` or ``"not explained"``) and ``note``.
    """
    sim = simulate_cell_histograms(model, log, grid, rng, draws)
    ref = sim if sibling is None else simulate_cell_histograms(sibling, log, grid, rng, draws)
    n = counts.sum(axis=1)
    steps = np.flatnonzero(n[1:] > 0) + 1
    if steps.size == 0:
        return {"statistic": "mean_tv_distance", "log": None, "verdict": None, "note": "no observation after a tilt"}
    p = (sim / np.maximum(sim.sum(axis=2, keepdims=True), 1.0)).mean(axis=0)
    d_log = float(_mean_tv(counts, p, steps))
    d_sim = _mean_tv(ref, p, steps)
    pval = float((1 + np.sum(d_sim >= d_log)) / (draws + 1))
    explained = pval >= ALPHA
    note = ("the log's cell histograms lie within what logs of its size from the best model show" if explained else
            f"the log's cell histograms differ from the best model's more than {draws} simulated logs of its size "
            "do: the models cannot explain this log (another physics?), and the interval need not cover")
    return {"statistic": "mean_tv_distance", "log": d_log, "model_median": float(np.median(d_sim)),
            "model_95": float(np.quantile(d_sim, 0.95)), "p_value": pval, "draws": draws,
            "reference": "model" if sibling is None else "sibling build",
            "verdict": "explained" if explained else "not explained", "note": note}
