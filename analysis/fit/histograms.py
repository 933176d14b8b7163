"""The likelihood-free view of a log: report-cell histograms by step, against a model's prediction.

The baseline criterion of a fit (the way the paper compares simulation with its camera log, on
the entropy grid): at every step, the total-variation distance between the log's histogram of
observed poses over the report cells and the model's predicted distribution over them, averaged
over steps. The same predictions give the goodness of fit: the model's entropy curve with a 90%
band of what a log of the same size would show (multinomial draws of the observed counts).
"""
from __future__ import annotations

import numpy as np

from kruskal_markov.entropy import histogram_entropy_bits, propagate

__all__ = ["log_histograms", "predicted_histograms", "histogram_distance", "entropy_band"]


def log_histograms(log, grid) -> np.ndarray:
    """(L+1, cells) counts of the log's observed poses on ``grid`` at every step."""
    L1 = log.obs.shape[1]
    out = np.zeros((L1, grid.n_voxels))
    obs = log.observed
    for k in range(L1):
        if obs[:, k].any():
            out[k] = grid.counts(log.obs[obs[:, k], k])
    return out


def predicted_histograms(model, log) -> np.ndarray:
    """(L+1, cells) the model's predicted cell distribution at every step, weighted over the log's
    distinct tilt sequences by the trials observed there (one sequence: its prediction)."""
    L1 = log.obs.shape[1]
    out = np.zeros((L1, model.n_cells))
    weight = np.zeros(L1)
    obs = log.observed
    seqs, inverse = np.unique(log.actions, axis=0, return_inverse=True)
    inverse = np.asarray(inverse).ravel()
    part = np.asarray(model.partition)
    for g, seq in enumerate(seqs):
        rows = inverse == g
        n = int(np.sum(seq >= 0))
        dist = propagate(model, seq[:n])
        for k in range(n + 1):
            w = float(obs[rows, k].sum())
            if w:
                out[k] += w * np.bincount(part, weights=dist[k], minlength=model.n_cells)
                weight[k] += w
    nz = weight > 0
    out[nz] /= weight[nz, None]
    return out


def histogram_distance(model, log, grid, counts=None) -> float:
    """Mean over observed steps >= 1 of the total-variation distance between the log's cell
    histogram and the model's prediction (0 = identical, 1 = disjoint)."""
    h = log_histograms(log, grid) if counts is None else counts
    p = predicted_histograms(model, log)
    n = h.sum(axis=1)
    steps = np.flatnonzero(n[1:] > 0) + 1
    if steps.size == 0:
        return float("nan")
    tv = 0.5 * np.abs(h[steps] / n[steps, None] - p[steps]).sum(axis=1)
    return float(tv.mean())


def entropy_band(pred: np.ndarray, counts: np.ndarray, rng, draws: int = 200) -> dict:
    """The model's entropy curve and the 5-95% band of a log of the same size.

    Parameters
    ----------
    pred : ndarray (L+1, cells)
        Predicted cell distributions (:func:`predicted_histograms`).
    counts : ndarray (L+1, cells)
        The log's counts (:func:`log_histograms`); their row sums are the sample sizes drawn.
    rng : numpy.random.Generator
    draws : int

    Returns
    -------
    dict
        ``model`` (entropy of the prediction, bits), ``band_lo``, ``band_hi`` (5% and 95% of the
        plug-in entropy of ``draws`` multinomial samples), ``log`` (the log's entropy), ``inside``
        (share of observed steps where the log lies in the band).
    """
    L1 = pred.shape[0]
    model_h, lo, hi, logh = (np.zeros(L1) for _ in range(4))
    inside = []
    for k in range(L1):
        p = np.clip(pred[k], 0, None)
        n = int(counts[k].sum())
        if p.sum() > 0:
            p = p / p.sum()
            model_h[k] = histogram_entropy_bits(p)
        if n == 0 or p.sum() == 0:
            lo[k] = hi[k] = logh[k] = np.nan
            continue
        sample = rng.multinomial(n, p, size=draws)
        hs = np.array([histogram_entropy_bits(s) for s in sample])
        lo[k], hi[k] = np.quantile(hs, [0.05, 0.95])
        logh[k] = histogram_entropy_bits(counts[k])
        inside.append(lo[k] - 1e-9 <= logh[k] <= hi[k] + 1e-9)
    return {"model": model_h.tolist(), "band_lo": lo.tolist(), "band_hi": hi.tolist(), "log": logh.tolist(),
            "inside": float(np.mean(inside)) if inside else None}
