"""The static/kinetic friction pair (``kruskal fit --fit mu_s,mu_k``): its grid, estimate and intervals.

The pair is fitted on a 2-D grid: ``K`` points per axis across each coefficient's range (one
``--range LO..HI`` for both, or ``LO_S/LO_K..HI_S/HI_K`` for each its own), kept where
``mu_s >= mu_k`` (a static coefficient below the kinetic one is not a friction law;
:func:`transition_builder.friction.parse_friction` refuses it), so a common range gives the
triangle of ``K (K + 1) / 2`` models. Each refinement round halves the spacing and adds the eight
neighbours of the best point that stay in the ranges and the triangle.

The estimate generalises the single coefficient's quadratic vertex: a quadratic surface is fitted
by least squares to the criterion at the points within one finest spacing (per axis, Chebyshev)
of the best point (its 3 x 3 neighbourhood after refinement; twice or four times that when it holds
fewer than the quadratic's six points), and its maximum under the constraint ``mu_s >= mu_k`` is taken: the vertex when
the surface is concave and the vertex is feasible, else the maximum along the diagonal
``mu_s = mu_k`` (for a concave quadratic the constrained maximum over a half-plane lies on its
boundary line), clipped to the window; the best point itself when the surface is not concave, has
too few points or its maximum leaves the window. The 90% interval of each coefficient is the 5-95%
range of the same estimate over bootstrap resamples of the trials (Efron & Tibshirani 1993,
ch. 13); the profile-likelihood interval of each (the drop 1.353 of chi-square(1) at 90%, the
profile of a quadratic being ``top - (x_i - v_i)^2 / (2 (-H^-1)_ii)``, Pawitan 2001, sec. 3.4) is
reported beside it when the vertex is feasible. A single-coefficient log lies on the diagonal: the
pair's answer says so (``on_diagonal``, the bootstrap interval of ``mu_s - mu_k`` and the
log-likelihood the pair gains over the best single coefficient).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["PAIR", "pair_axes", "pair_grid", "pair_refinement", "pair_estimate", "pair_summary"]

#: the parameter names of the pair, in grid order.
PAIR = ("mu_s", "mu_k")
_EPS = 1e-9
_PROFILE_DROP = 1.3528           # chi-square(1) 90% quantile / 2


def pair_axes(ranges: dict, points: dict) -> tuple[np.ndarray, np.ndarray]:
    """The two axes (``mu_s``, ``mu_k``): ``points[name]`` evenly spaced values across each range."""
    if min(points[name] for name in PAIR) < 2:
        raise ValueError(f"a pair grid needs at least 2 points per axis, got {points}")
    return tuple(np.linspace(*ranges[name], points[name]) for name in PAIR)


def pair_grid(s_axis: np.ndarray, k_axis: np.ndarray) -> list[tuple]:
    """Grid points ``(mu_s, mu_k)`` of the product of the axes with ``mu_s >= mu_k``."""
    return [_point(s, k) for s in s_axis for k in k_axis if s >= k - _EPS]


def _point(s: float, k: float) -> tuple:
    """A grid point rounded to 10 decimals (the grid's key), ``mu_s`` lifted to ``mu_k`` when round-off
    put it below (a point on the diagonal is the single coefficient)."""
    s, k = round(float(s), 10), round(float(k), 10)
    return (max(s, k), k)


def pair_refinement(best: tuple, steps: tuple, ranges: dict) -> list[tuple]:
    """The eight neighbours of ``best`` at ``steps`` (per axis) inside the ranges and the triangle."""
    out = []
    (slo, shi), (klo, khi) = ranges[PAIR[0]], ranges[PAIR[1]]
    for ds in (-1, 0, 1):
        for dk in (-1, 0, 1):
            if ds == dk == 0:
                continue
            s, k = best[0] + ds * steps[0], best[1] + dk * steps[1]
            if slo - _EPS <= s <= shi + _EPS and klo - _EPS <= k <= khi + _EPS and s >= k - _EPS:
                out.append(_point(min(max(s, slo), shi), min(max(k, klo), khi)))
    return out


def _surface(P: np.ndarray, y: np.ndarray, j: int, half: np.ndarray):
    """Least-squares quadratic through the points within ``half`` (per axis) of point ``j``, in
    units of ``half`` around it: (gradient b, Hessian H, window mask) or None when underdetermined."""
    d = (P - P[j]) / half
    win = np.all(np.abs(d) <= 1 + 1e-9, axis=1)
    if win.sum() < 6:
        return None
    u, v = d[win, 0], d[win, 1]
    X = np.column_stack([np.ones_like(u), u, v, u * u, u * v, v * v])
    coef, _, rank, _ = np.linalg.lstsq(X, y[win] - y[j], rcond=None)
    if rank < 6:
        return None
    _, b1, b2, a11, a12, a22 = coef
    return np.array([b1, b2]), np.array([[2 * a11, a12], [a12, 2 * a22]]), win


def surface_residual(P: np.ndarray, y: np.ndarray, half: np.ndarray) -> tuple[float | None, int]:
    """The residual variance of the estimate's quadratic surface (the window :func:`pair_estimate`
    uses, around the best point) and its degrees of freedom (window points - 6); (None, 0) when the
    window holds no spare point. The models' own error in the criterion (each is a sampled build,
    and a physics log comes from none of them) shows as this scatter (:mod:`analysis.fit.model_error`)."""
    j = int(np.argmax(y))
    for scale in (1, 2, 4):
        d = (P - P[j]) / (half * scale)
        win = np.all(np.abs(d) <= 1 + 1e-9, axis=1)
        if win.sum() < 6:
            continue
        u, v = d[win, 0], d[win, 1]
        X = np.column_stack([np.ones_like(u), u, v, u * u, u * v, v * v])
        coef, _, rank, _ = np.linalg.lstsq(X, y[win], rcond=None)
        dof = int(win.sum()) - 6
        if rank < 6 or dof < 1:
            return None, 0
        return float(np.sum((y[win] - X @ coef) ** 2) / dof), dof
    return None, 0


def pair_estimate(P: np.ndarray, y: np.ndarray, half: np.ndarray) -> tuple[np.ndarray, dict]:
    """The constrained maximum of the local quadratic surface (module docstring).

    Parameters
    ----------
    P : ndarray, shape (n, 2)
        Grid points (``mu_s``, ``mu_k``).
    y : ndarray, shape (n,)
        The criterion (larger is better).
    half : ndarray, shape (2,)
        Half-width of the window per axis (widened up to 4 times when it holds too few points).

    Returns
    -------
    estimate : ndarray, shape (2,)
    info : dict
        ``best`` (index of the best point), ``vertex_feasible`` (bool), ``cov`` (``-H^-1`` in the
        coefficients' units, or None when the surface is not concave).
    """
    j = int(np.argmax(y))
    info = {"best": j, "vertex_feasible": False, "cov": None}
    fit = None
    for scale in (1, 2, 4):                 # widen the window until it holds a quadratic's 6 points
        fit = _surface(P, y, j, half * scale)
        if fit is not None:
            half = half * scale
            break
    if fit is None:
        return P[j].copy(), info
    b, H, win = fit
    if not np.all(np.linalg.eigvalsh(H) < 0):
        return P[j].copy(), info
    lo, hi = (P[win] - P[j]).min(axis=0) / half, (P[win] - P[j]).max(axis=0) / half
    v = -np.linalg.solve(H, b)                       # window units
    est = P[j] + v * half
    if est[0] >= est[1] - _EPS:
        if np.all(v >= lo - 1e-9) and np.all(v <= hi + 1e-9):
            info["vertex_feasible"] = True
            info["cov"] = -np.linalg.inv(H) * np.outer(half, half)
            return est, info
        return P[j].copy(), info
    # the maximum on the diagonal s = k: s = P[j,0] + u*hs, k = P[j,1] + w*hk with the two equal
    e = P[j, 1] - P[j, 0]
    direction = np.array([1.0 / half[0], 1.0 / half[1]])        # window units per unit of mu along it
    offset = np.array([0.0, -e / half[1]])                      # the diagonal's point at mu = P[j,0]
    A = 0.5 * direction @ H @ direction
    B = b @ direction + direction @ H @ offset
    t = -B / (2 * A)                                            # A < 0: H is negative definite
    t_lo = max((lo - offset) / direction)
    t_hi = min((hi - offset) / direction)
    if t_lo > t_hi:
        return P[j].copy(), info
    t = min(max(t, t_lo), t_hi)
    mu = P[j, 0] + t
    return np.array([mu, mu]), info


def _resampled(L: np.ndarray, var, dof: int, rng: np.random.Generator) -> np.ndarray:
    """One resample of the criterion: the trials drawn with replacement, plus, when the surface's
    residual variance is known, independent normal errors of a variance drawn from its
    scaled-inverse-chi-square posterior (as :func:`analysis.fit.model_error.resample_vertices`)."""
    T = L.shape[0]
    y = L[rng.integers(0, T, T)].sum(axis=0)
    if var:
        y = y + rng.normal(0.0, 1.0, len(y)) * math.sqrt(var * dof / rng.chisquare(dof))
    return y


def pair_summary(P: np.ndarray, y: np.ndarray, L: np.ndarray | None, ranges: dict, half: np.ndarray,
                 bootstrap: int, rng: np.random.Generator) -> dict:
    """Estimate, intervals, edge flag and the pair's own answers of a fitted grid.

    Parameters
    ----------
    P : ndarray, shape (n, 2)
        Grid points (``mu_s``, ``mu_k``).
    y : ndarray, shape (n,)
        The criterion at each point (larger is better).
    L : ndarray, shape (T, n), or None
        Every trial's log-likelihood under each point's model (None: no bootstrap, e.g. the
        histogram criterion).
    ranges : dict
        ``mu_s`` and ``mu_k`` -> (lo, hi).
    half : ndarray, shape (2,)
        Half-width of the estimate's window per axis (the finest spacing).
    bootstrap : int
        Resamples of the trials.
    rng : numpy.random.Generator

    Returns
    -------
    dict
        ``estimate``, ``estimate_tuple``, ``interval``, ``profile``, ``at_edge``, ``trials_needed``
        (the keys of the single coefficient's summary) and ``pair``.
    """
    est, info = pair_estimate(P, y, half)
    best = P[info["best"]]
    at_edge = any(best[i] <= ranges[n][0] + _EPS or best[i] >= ranges[n][1] - _EPS
                  for i, n in enumerate(PAIR) if ranges[n][1] > ranges[n][0])
    boots = np.empty((0, 2))
    var, dof = surface_residual(P, y, half) if L is not None else (None, 0)
    if L is not None and L.shape[0] > 1 and bootstrap > 0:
        T = L.shape[0]
        boots = np.array([pair_estimate(P, _resampled(L, var, dof, rng), half)[0] for _ in range(bootstrap)])
    interval = profile = None
    needed, sds, diff_iv, corr = {}, {}, None, None
    if not at_edge and len(boots) > 1:
        interval = {n: [float(v) for v in np.quantile(boots[:, i], [0.05, 0.95])] for i, n in enumerate(PAIR)}
        diff_iv = [float(v) for v in np.quantile(boots[:, 0] - boots[:, 1], [0.05, 0.95])]
        T = L.shape[0]
        for i, n in enumerate(PAIR):
            sd = float(boots[:, i].std(ddof=1))
            sds[n] = sd
            needed[n] = {f"{h:g}": int(math.ceil(T * (1.645 * sd / h) ** 2)) if sd > 0 else 1
                         for h in (0.01, 0.02, 0.05)}
        if boots[:, 0].std() > 0 and boots[:, 1].std() > 0:
            corr = float(np.corrcoef(boots[:, 0], boots[:, 1])[0, 1])
    if not at_edge and L is not None and info["vertex_feasible"]:
        half_w = np.sqrt(2 * _PROFILE_DROP * np.diag(info["cov"]))
        profile = {n: [float(est[i] - half_w[i]), float(est[i] + half_w[i])] for i, n in enumerate(PAIR)}
    worst = max(sds, key=sds.get) if sds else None
    diag = np.abs(P[:, 0] - P[:, 1]) <= _EPS
    single = int(np.flatnonzero(diag)[np.argmax(y[diag])]) if diag.any() else None
    pair = {"on_diagonal": bool(abs(est[0] - est[1]) <= _EPS),
            "difference_interval_90": diff_iv,
            "bootstrap_correlation": corr,
            "best_single_mu": None if single is None else float(P[single, 1]),
            "criterion_gain_over_single": None if single is None else float(y.max() - y[single])}
    model_error = {"residual_sd_loglik": None if var is None else math.sqrt(var), "dof": dof,
                   "note": "the surface's residual scatter, added to every resample (no replicate builds)"}
    return {"model_error": model_error, "estimate": {n: round(float(est[i]), 6) for i, n in enumerate(PAIR)},
            "estimate_tuple": tuple(float(v) for v in est), "interval": interval, "profile": profile,
            "at_edge": bool(at_edge),
            "trials_needed": {"half_width_90": needed.get(worst, {}),
                              "bootstrap_sd": sds.get(worst),
                              "per_parameter": {n: {"half_width_90": needed[n], "bootstrap_sd": sds[n]}
                                                for n in sds}},
            "pair": pair}
