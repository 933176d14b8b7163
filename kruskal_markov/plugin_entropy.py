"""The plug-in entropy estimate's own sampling behaviour: what ``m`` trials give on average, and how
much it spreads.

Direct simulation estimates a step's entropy by the plug-in estimate of its trials' report cells;
with few trials that estimate is biased low and noisy. A model's prediction is compared with it on
equal terms by :func:`expected_plugin_entropy` (the mean plug-in entropy of ``m`` draws from the
model's cell distribution: the bias matched), and the reference's noise is
:func:`bootstrap_entropy_sd` (the bootstrap standard deviation of the plug-in estimate of the trials'
labels). Both draw from a generator passed in (:mod:`analysis.validate` passes its stream).
"""
from __future__ import annotations

import numpy as np

from kruskal_markov.entropy import histogram_entropy_bits

__all__ = ["expected_plugin_entropy", "bootstrap_entropy_sd"]


def expected_plugin_entropy(q: np.ndarray, m: int, rng: np.random.Generator, draws: int = 200) -> float:
    """Mean plug-in entropy (bits) of ``m`` draws from the cell distribution ``q`` (Monte Carlo).

    Parameters
    ----------
    q : numpy.ndarray
        Cell probabilities (negative round-off is clipped, the rest renormalised).
    m : int
        Trials per estimate (0 or fewer: 0.0).
    rng : numpy.random.Generator
    draws : int
        Multinomial samples averaged.

    Returns
    -------
    float

    Examples
    --------
    >>> expected_plugin_entropy(np.array([0.5, 0.5]), 1, np.random.default_rng(0))    # one trial: one cell
    0.0
    """
    if m <= 0:
        return 0.0
    q = np.clip(q, 0.0, None)
    q = q / q.sum()
    samples = rng.multinomial(m, q, size=draws)
    return float(np.mean([histogram_entropy_bits(d) for d in samples]))


def bootstrap_entropy_sd(labels: np.ndarray, n_cells: int, rng: np.random.Generator, resamples: int = 200) -> float:
    """Bootstrap standard deviation (bits) of the plug-in entropy of the trials' cell ``labels``.

    Parameters
    ----------
    labels : numpy.ndarray of int
        Each trial's report cell.
    n_cells : int
        Number of cells.
    rng : numpy.random.Generator
    resamples : int
        Bootstrap resamples.

    Returns
    -------
    float
        0.0 for fewer than two trials.

    Examples
    --------
    >>> bootstrap_entropy_sd(np.zeros(30, dtype=np.int64), 4, np.random.default_rng(0))   # one cell: no spread
    0.0
    """
    m = len(labels)
    if m < 2:
        return 0.0
    hs = np.empty(resamples)
    for b in range(resamples):
        hs[b] = histogram_entropy_bits(np.bincount(labels[rng.integers(0, m, m)], minlength=n_cells))
    return float(hs.std(ddof=1))
