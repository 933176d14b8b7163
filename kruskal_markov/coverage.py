"""Band coverage with the sequence as the unit: how sure a measured coverage of the model's error
band is, and how many sequences a calibration needs.

Steps of one random sequence are correlated (an error in one chunk of the model persists to the
sequence's end), so statistics over steps overstate what a few sequences show. These take whole
sequences as the unit: a bootstrap interval of the pooled coverage
(:func:`sequence_bootstrap_interval`), resampled calibrations from ``k`` sequences
(:func:`calibration_study`) and conformal risk control per sequence (:func:`sequence_risk_delta`).
They judge :mod:`kruskal_markov.structural`'s calibration (``benchmarks/bench_coverage.py``,
docs/uncertainty.md).
"""
from __future__ import annotations

import math

import numpy as np

from kruskal_markov.structural import conformal_quantile

__all__ = ["sequence_bootstrap_interval", "calibration_study", "sequence_risk_delta"]


def sequence_bootstrap_interval(per_sequence: list[np.ndarray], resamples: int = 10_000,
                                seed: int = 0) -> tuple[float, float]:
    """A 95% interval of the pooled coverage that takes the sequence, not the step, as the unit.

    Steps of one sequence are correlated (a chunk error persists to the sequence's end), so the
    Wilson interval over steps is too narrow. This resamples whole sequences with replacement
    (Efron and Tibshirani 1993, ch. 6: the bootstrap of a ratio of sums) ``resamples`` times and
    returns the 2.5% and 97.5% quantiles of the resampled pooled coverage
    (steps inside / steps), seeded by ``numpy.random.default_rng(seed)``.

    Parameters
    ----------
    per_sequence : list of numpy.ndarray
        One boolean array per sequence: whether each of its steps is inside the band.
    resamples : int
        Bootstrap resamples.
    seed : int
        Seed of the resampling.

    Returns
    -------
    (float, float)
        The 2.5% and 97.5% quantiles of the resampled pooled coverage.
    """
    if not per_sequence:
        raise ValueError("no sequences")
    hits = np.array([float(np.sum(x)) for x in per_sequence])
    steps = np.array([float(len(x)) for x in per_sequence])
    pick = np.random.default_rng(seed).integers(0, len(hits), size=(resamples, len(hits)))
    share = hits[pick].sum(axis=1) / steps[pick].sum(axis=1)
    return float(np.quantile(share, 0.025)), float(np.quantile(share, 0.975))


def calibration_study(per_sequence: list[np.ndarray], sizes=(2, 4, 8, 12), resamples: int = 2000,
                      seed: int = 0, level: float = 0.9) -> dict:
    """How many sequences a per-model calibration needs: resampled calibrations from ``k`` of a model's kept
    sequences, each scored on the sequences it did not use and on all of them.

    For each ``k`` in ``sizes`` (below the number of sequences), ``resamples`` times: ``k`` sequences drawn
    without replacement (``numpy.random.default_rng(seed)``), delta = the split-conformal ``level``
    quantile of their pooled steps' scores (what ``kruskal validate --calibrate`` stores), and the pooled
    coverage at that delta of (a) the other sequences (``held_out``: calibration and test noise together)
    and (b) all sequences (``all``: the calibration's own spread; optimistic, the calibration sequences are
    among them).

    Parameters
    ----------
    per_sequence : list of numpy.ndarray
        Per sequence, its steps' relative-rule scores (:func:`kruskal_markov.structural.structural_score`).
    sizes : tuple of int
        Calibration sizes ``k`` tried.
    resamples, seed : int
        Resampled calibrations per size and their seed.
    level : float
        The calibration's coverage level.

    Returns
    -------
    dict
        ``{k: {"held_out": array, "all": array}}`` of the resampled coverages.
    """
    seqs = [np.asarray(x, dtype=np.float64) for x in per_sequence]
    if len(seqs) < 2:
        raise ValueError("need at least two sequences")
    every = np.concatenate(seqs)
    rng = np.random.default_rng(seed)
    out = {}
    for k in sizes:
        if not 0 < k < len(seqs):
            continue
        held, pool = np.empty(resamples), np.empty(resamples)
        for r in range(resamples):
            p = rng.permutation(len(seqs))
            d = conformal_quantile(np.concatenate([seqs[i] for i in p[:k]]), level)
            held[r] = np.mean(np.concatenate([seqs[i] for i in p[k:]]) <= d)
            pool[r] = np.mean(every <= d)
        out[k] = {"held_out": held, "all": pool}
    return out


def sequence_risk_delta(per_sequence: list[np.ndarray], alpha: float = 0.1) -> float:
    """The sequence-as-unit calibration (considered, not adopted: docs/uncertainty.md): the smallest delta
    with ``(sum_i L_i(delta) + 1) / (k + 1) <= alpha``, ``L_i`` the share of sequence i's steps outside the
    band (score above delta), ``k`` the number of sequences; ``inf`` if there is none (always below
    ``1 / alpha - 1`` sequences). Conformal risk control with a loss in [0, 1] per sequence (Angelopoulos
    et al., "Conformal risk control", ICLR 2024, Theorem 1), valid for exchangeable sequences.

    Parameters
    ----------
    per_sequence : list of numpy.ndarray
        Per sequence, its steps' relative-rule scores (``inf`` for a step no finite delta covers).
    alpha : float
        The tolerated mean share of steps outside the band.

    Returns
    -------
    float
        The delta, or ``inf``.
    """
    seqs = [np.asarray(x, dtype=np.float64) for x in per_sequence]
    if not seqs or any(len(x) == 0 for x in seqs):
        raise ValueError("need sequences with at least one step each")
    k = len(seqs)
    for d in np.unique(np.concatenate([[0.0], *[x[np.isfinite(x)] for x in seqs]])):
        if (sum(float(np.mean(x > d)) for x in seqs) + 1) / (k + 1) <= alpha:
            return float(d)
    return math.inf
