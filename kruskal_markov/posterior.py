"""Error bars of a sampled model: a Dirichlet posterior over every row, resampled.

A built model keeps, for every action ``a`` and stored entry of its matrix, the number of sampled
tilts that went that way (``model.extras["counts_<a>"]``, aligned with ``matrices[a].data``).
With a symmetric Dirichlet prior of concentration ``prior`` on the *observed* targets of a row,
the posterior of that row is ``Dirichlet(counts + prior)`` (Gelman et al., *Bayesian Data
Analysis*, 3rd ed., Sec. 3.4; for Markov chains: Noé, "Probability distributions of molecular
observables computed from Markov models", J. Chem. Phys. 128, 244103, 2008). Drawing every row
independently gives a model from the posterior; a band of any derived number (an entropy curve,
an expected convergence length) is its quantiles over such draws.

Rows without counts (imputed start rows, unexplored states) are kept as they are. A row sampled
once (the deterministic builder) has a one-point posterior: the band then says nothing about
snapping error, only about sampling error — which is zero for deterministic physics.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from kruskal_markov.model import ModelError, TransitionModel

__all__ = ["has_counts", "row_counts", "resample_model"]


def has_counts(model: TransitionModel) -> bool:
    """True if ``model`` carries sample counts for every action."""
    return all(f"counts_{a}" in model.extras for a in range(model.n_actions))


def row_counts(model: TransitionModel, action: int) -> np.ndarray:
    """Counts aligned with ``model.matrices[action].data`` (int64); ModelError if absent or misaligned."""
    key = f"counts_{action}"
    if key not in model.extras:
        raise ModelError(f"the model has no sample counts for action {model.actions[action]!r} "
                         "(only built models carry them)")
    c = np.asarray(model.extras[key], dtype=np.int64)
    if c.shape != (model.matrices[action].nnz,) or np.any(c < 0):
        raise ModelError(f"sample counts of action {model.actions[action]!r} do not match its matrix")
    return c


def resample_model(model: TransitionModel, rng, prior: float = 0.5) -> TransitionModel:
    """One draw from the Dirichlet posterior of every row (same sparsity, same initial and partition).

    Parameters
    ----------
    model : TransitionModel
        A built model with counts (:func:`has_counts`).
    rng : numpy.random.Generator or int
    prior : float
        Concentration added to every observed target (0.5: Jeffreys).
    Returns
    -------
    TransitionModel


    Examples
    --------
    >>> m = TransitionModel(["a"], [[[0.75, 0.25], [0.0, 1.0]]],
    ...                     extras={"counts_0": [3, 1, 2]})
    >>> r = resample_model(m, rng=1)
    >>> bool(abs(r.matrices[0][0].sum() - 1) < 1e-12), float(r.matrices[0][1, 1])
    (True, 1.0)
    """
    if not (np.isfinite(prior) and prior > 0):
        raise ValueError(f"prior must be a positive number, got {prior!r}")
    if not isinstance(rng, np.random.Generator):
        rng = np.random.default_rng(rng)
    mats = []
    for a, m in enumerate(model.matrices):
        c = row_counts(model, a)
        rows = np.repeat(np.arange(m.shape[0]), np.diff(m.indptr))
        total = np.bincount(rows, weights=c, minlength=m.shape[0])
        counted = total[rows] > 0
        g = np.where(c > 0, rng.gamma(np.where(c > 0, c + prior, 1.0)), 0.0)
        gsum = np.bincount(rows, weights=g, minlength=m.shape[0])
        data = np.array(m.data, dtype=np.float64)
        data[counted] = g[counted] / gsum[rows[counted]]
        mats.append(sp.csr_matrix((data, m.indices.copy(), m.indptr.copy()), shape=m.shape))
    return TransitionModel(model.actions, mats, initial=model.initial, partition=model.partition,
                           n_cells=model.n_cells, metadata=model.metadata, tol=max(model.tol, 1e-9),
                           extras=model.extras)
