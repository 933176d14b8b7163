"""The models' own error in a 1-D fit's criterion, and the interval that carries it.

Each grid model is a separately sampled, discretised build, and a physical log does not come from
any of them: the log-likelihood at a grid point is the model family's curve plus a build error
that does not shrink with more trials (on the key's 500 x 50 logs, tens of thousands of nats
between neighbouring models; docs/fit.md). A bootstrap of the trials sees only the log's sampling
noise, so its interval is far too narrow there. This module measures the build error and
propagates it into the estimate:

- **Measured directly**: the best grid point and its two neighbours are built a second time with
  another build seed (``replicates``); the difference of the two builds' log-likelihoods at one
  coefficient has variance ``2 sigma^2`` (one degree of freedom per replicated point).
- **Residual scatter**: the residuals of the weighted quadratic through the estimate's window
  (best point and up to two neighbours each side) estimate ``sigma^2`` plus the curve's departure
  from a quadratic, with ``n - 3`` degrees of freedom; both are errors of the vertex.
- The residual variance is the one carried (the replicate variance only when it is the larger):
  the residuals contain the builds' error and the curve's misfit, and on the key's logs the misfit
  dominates (replicate sd 1,300-2,700 nats against residual sd 7,000-32,000, docs/fit.md), so
  pooling the two would understate the vertex's error (a first version did, and its interval
  covered 5 of 10 validation logs). Replicated points enter the estimate as the mean of their
  builds (variance ``sigma^2 / n``; weighted least squares).
- **The grid's resolution**: a misspecified likelihood peaks at the model that matches the log
  best, and the vertex between grid points is pulled towards it (on the key's logs by up to about
  half the finest spacing ``h``). The vertex's location within ``h`` is therefore not known better
  than the resolution of a quantised reading, a rectangular error of half-width ``h / 2``
  (standard uncertainty ``h / sqrt(12)``; JCGM 100:2008, "Guide to the expression of uncertainty
  in measurement", F.2.2.1), added to every resample. It shrinks with finer refinement, not with
  more trials.
- **Propagation**: a parametric bootstrap of the criterion curve (Efron & Tibshirani 1993, ch. 6
  and 13): each resample draws the trials with replacement (the sampling term), draws a variance
  ``sigma*^2 = sigma^2 nu / chi2_nu`` (the scaled-inverse-chi-square posterior of a normal variance
  estimated with ``nu`` degrees of freedom, Gelman et al. 2013, "Bayesian Data Analysis", 3rd ed.,
  sec. 3.2, so that a variance measured from few builds widens the interval rather than being
  taken as exact) and adds independent ``N(0, sigma*^2 / n_i)`` to each point's criterion, then
  takes the same vertex plus a ``U(-h/2, h/2)`` resolution draw. The 5-95% range is the 90%
  interval.
- **The profile interval** is the tempered (curvature-adjusted) likelihood's: the log-likelihood
  divided by the factor that makes its curvature match the estimate's total variance (Chandler &
  Bate 2007, "Inference for clustered data using the independence loglikelihood", Biometrika
  94(1):167-183; Pauli, Racugno & Ventura 2011, "Bayesian composite marginal likelihoods",
  Statistica Sinica 21:149-164), i.e. the vertex +- 1.645 total standard deviations.

Split variances (``sd_trials``: trials resampled, no build noise; ``sd_model``: build noise only)
make the trials a log needs honest: the model term does not shrink with more trials.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["ModelError", "weighted_vertex", "best_point", "patch_vertex", "ESTIMATORS", "replicate_indices", "model_error",
           "resample_vertices", "trials_needed"]

#: z of a two-sided 90% interval.
_Z90 = 1.6448536


def weighted_vertex(x: np.ndarray, y: np.ndarray, n: np.ndarray, j: int) -> float:
    """The maximum of the quadratic fitted (weights ``n``: builds per point) through point ``j`` and up
    to two neighbours each side of sorted ``x``; ``x[j]`` when not concave or the vertex leaves the
    window."""
    lo, hi = max(0, j - 2), min(len(x), j + 3)
    xs, ys, ws = x[lo:hi], y[lo:hi], np.sqrt(n[lo:hi])
    if len(xs) >= 3:
        a, b, _ = np.polyfit(xs - x[j], ys - y[j], 2, w=ws)
        if a < 0:
            v = x[j] - b / (2 * a)
            if xs[0] <= v <= xs[-1]:
                return float(v)
    return float(x[j])


def best_point(x: np.ndarray, y: np.ndarray, n: np.ndarray, j: int) -> float:
    """The best grid point ``x[j]`` itself (``y`` and ``n`` unused: the signature of
    :func:`weighted_vertex`).

    The default estimate since version 3 (docs/fit.md, "Version 3: the best grid point"): the
    physics logs' likelihood is misspecified and falls off cliffs of 10^4-10^5 nats between
    neighbouring models, so a quadratic through the best point's window is pulled away from it
    (by up to 0.034 on the spent validation logs) while the best model itself erred by at most
    0.017. Its error within the spacing is carried by the resolution term (``U(-h/2, h/2)``).
    """
    return float(x[j])


def patch_vertex(x: np.ndarray, y: np.ndarray, n: np.ndarray, j: int, *, lo: float | None = None,
                 hi: float | None = None) -> float:
    """The maximum of the least-squares quadratic (weights ``sqrt(n)``) through every point of the fine
    local patch ``lo <= x <= hi``, clipped to the patch; the patch's best point when not concave.

    The estimate of a fit with a fine local grid (``FitSettings.local``, docs/fit.md "Finer than the
    grid"): each fine model is its own build, so the criterion between neighbouring fine models
    carries the builds' scatter as well as the curve; a quadratic through the whole patch (2K + 3
    models) averages that scatter rather than following it. Without a patch (``lo`` None) this is
    :func:`best_point`.
    """
    if lo is None or hi is None:
        return best_point(x, y, n, j)
    inside = (x >= lo - 1e-12) & (x <= hi + 1e-12)
    xs, ys, ws = x[inside], y[inside], np.sqrt(n[inside])
    k = int(np.argmax(ys)) if len(ys) else None
    if k is None:
        return best_point(x, y, n, j)
    if len(xs) >= 3:
        c = 0.5 * (lo + hi)
        a, b, _ = np.polyfit(xs - c, ys - ys[k], 2, w=ws)
        if a < 0:
            return float(np.clip(c - b / (2 * a), lo, hi))
    return float(xs[k])


#: ``FitSettings.estimator`` -> the 1-D likelihood fit's estimate from the criterion curve (``local``
#: takes the fine patch's bounds as keywords, :func:`patch_vertex`).
ESTIMATORS = {"grid": best_point, "vertex": weighted_vertex, "local": patch_vertex}


def replicate_indices(n_points: int, j: int) -> list[int]:
    """The grid points built a second time: the best ``j`` and its neighbours that exist."""
    return [k for k in (j - 1, j, j + 1) if 0 <= k < n_points]


class ModelError:
    """The build-error variance of the criterion (nats^2) carried into the interval, and its degrees
    of freedom.

    Attributes
    ----------
    var : float or None
        The larger of the residual and the replicate variance (None when nothing measured it: no
        replicate and a 3-point window).
    dof : int
    replicate_sd : float or None
        From the replicated builds alone (``sqrt(mean(d^2) / 2)``).
    residual_sd : float or None
        From the window's residuals alone.
    differences : list of float
        Log-likelihood of the first build minus the replicate's, per replicated point.
    """

    def __init__(self, var, dof, replicate_sd, residual_sd, differences, resolution=0.0):
        self.var, self.dof, self.resolution = var, dof, resolution
        self.replicate_sd, self.residual_sd, self.differences = replicate_sd, residual_sd, differences

    def to_dict(self) -> dict:
        return {"sd_loglik": None if self.var is None else math.sqrt(self.var), "dof": self.dof,
                "replicate_sd_loglik": self.replicate_sd, "residual_sd_loglik": self.residual_sd,
                "replicate_differences": self.differences, "resolution": self.resolution,
                "resolution_sd": self.resolution / math.sqrt(12.0)}


def model_error(x: np.ndarray, y: np.ndarray, n: np.ndarray, j: int, differences, resolution=0.0,
                window=None) -> ModelError:
    """The replicate differences' and the window's weighted residuals' variances, the larger carried
    (see the module); ``resolution`` is the finest grid spacing at the best point (0: none);
    ``window`` ``(lo, hi)``: the residuals of the quadratic through every point inside it (the fine
    local patch, :func:`patch_vertex`) instead of the best point's five."""
    d = np.asarray(differences, dtype=float)
    ss_rep, dof_rep = float(np.sum(d ** 2) / 2), len(d)
    if window is not None:
        sel = (x >= window[0] - 1e-12) & (x <= window[1] + 1e-12)
        xs, ys, ns = x[sel], y[sel], n[sel]
    else:
        lo, hi = max(0, j - 2), min(len(x), j + 3)
        xs, ys, ns = x[lo:hi], y[lo:hi], n[lo:hi]
    ss_res, dof_res = 0.0, max(0, len(xs) - 3)
    if dof_res:
        coef = np.polyfit(xs - x[j], ys, 2, w=np.sqrt(ns))
        ss_res = float(np.sum(ns * (ys - np.polyval(coef, xs - x[j])) ** 2))
    cands = [(ss / k, k) for ss, k in ((ss_res, dof_res), (ss_rep, dof_rep)) if k]
    var, dof = max(cands) if cands else (None, 0)
    return ModelError(var=var, dof=dof,
                      replicate_sd=math.sqrt(ss_rep / dof_rep) if dof_rep else None,
                      residual_sd=math.sqrt(ss_res / dof_res) if dof_res else None,
                      differences=[float(v) for v in d], resolution=float(resolution))


def resample_vertices(x, L, n, err: ModelError, rng, count: int, *, trials=True, model=True,
                      estimator=weighted_vertex) -> np.ndarray:
    """The estimate (``estimator``, default the vertex) over ``count`` parametric-bootstrap
    resamples of the criterion curve.

    Parameters
    ----------
    x : array (P,)
        Sorted grid points.
    L : array (T, P)
        Every trial's log-likelihood (the mean over a point's builds).
    n : array (P,)
        Builds per point.
    err : ModelError
    rng : numpy.random.Generator
    count : int
    trials, model : bool
        Resample the trials; add the build error (when measured) and the grid's resolution.
    estimator : callable
        ``(x, y, n, j) -> estimate`` (:data:`ESTIMATORS`), applied to every resample.
    """
    T = L.shape[0]
    noise = model and err.var is not None and err.var > 0
    out = np.empty(count)
    total = L.sum(axis=0)
    for b in range(count):
        y = L[rng.integers(0, T, T)].sum(axis=0) if trials else total.copy()
        if noise:
            var = err.var * err.dof / rng.chisquare(err.dof)
            y = y + rng.normal(0.0, 1.0, len(x)) * np.sqrt(var / n)
        out[b] = estimator(x, y, n, int(np.argmax(y)))
    if model and err.resolution > 0:
        out += rng.uniform(-err.resolution / 2, err.resolution / 2, count)
    return out


def trials_needed(T: int, sd_trials: float, sd_model: float, halves=(0.01, 0.02, 0.05),
                  sd_resolution: float = 0.0) -> dict:
    """Trials for a 90% half-width ``h``: ``T sd_trials^2 / ((h / z)^2 - sd_model^2)``, None where the
    model term alone exceeds ``h / z`` (more trials cannot reach it); the dominating term.
    ``sd_model`` is the whole term that does not shrink with trials (builds and grid resolution);
    ``sd_resolution`` the resolution's share of it, to name the dominating term."""
    needed = {}
    for h in halves:
        room = (h / _Z90) ** 2 - sd_model ** 2
        if room <= 0:
            needed[f"{h:g}"] = None
        else:
            needed[f"{h:g}"] = max(1, int(math.ceil(T * sd_trials ** 2 / room))) if sd_trials > 0 else 1
    sd_builds = math.sqrt(max(sd_model ** 2 - sd_resolution ** 2, 0.0))
    terms = {"trials": sd_trials, "model": sd_builds, "grid resolution": sd_resolution}
    dom = max(terms, key=terms.get)
    note = {"model": "the models' own error (the criterion's scatter between builds) dominates: more trials do "
                     "not help; better builds (finer resolution, more start samples) do",
            "grid resolution": "the grid's spacing dominates: more trials do not help; a finer grid "
                               "(--refine, --points) does",
            "trials": "the log's sampling noise dominates: more trials shrink the interval"}[dom]
    return {"half_width_90": needed, "bootstrap_sd": sd_trials, "model_sd": sd_model, "resolution_sd": sd_resolution,
            "dominated_by": dom, "note": note}
