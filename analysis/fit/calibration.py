"""Calibration of a 1-D fit by direct simulation: the models' own bias measured and removed.

A fit's models are sampled, discretised builds; a log comes from the physics. On the key's planar
logs the fine local estimate (:func:`analysis.fit.model_error.patch_vertex`) errs by a few
thousandths, the same at 100 and at 1,000 trials: a bias of the models, which no resampling of the
log or of the criterion sees (docs/fit.md). With a direct simulator at thousands of tilts a second
the bias can be measured where it matters: ``K`` *calibration logs* are simulated at known
coefficients ``t_k`` spread around the estimate (the log's own tilt sequence and number of trials,
the fit's camera noise), each is fitted by the same estimator on the same models, and the line
``e = a + b t`` through the pairs (estimate, truth) is the estimator's calibration curve.

The log's estimate ``e0`` is then read back through the curve (*classical calibration*, the inverse
regression; Osborne 1991, "Statistical calibration: a review", Int. Stat. Rev. 59:309-336, sec.
3; Brown 1993, "Measurement, Regression, and Calibration", ch. 2): the calibrated estimate is
``(e0 - a) / b`` and its ``1 - alpha`` interval the coefficients ``mu`` whose predicted estimate is
within the prediction band of ``e0``::

    (e0 - a - b mu)^2 <= q^2 s^2 (1 + 1/K + (mu - tbar)^2 / Sxx),    q = t_{1 - alpha/2, K - 2}

(``s^2`` the residual variance of the line, ``Sxx`` the spread of the truths). The ``1`` is the
log's own scatter about the curve: a calibration log has as many trials as the log, so its
residual holds both the trials' noise and whatever of the models' error is not a smooth function of
the coefficient (a jagged bias widens ``s`` instead of passing unseen). The set is an interval when
``b^2 > q^2 s^2 / Sxx`` (the slope is significant at that level); otherwise the calibration cannot
separate coefficients and no interval is claimed.

What it assumes: the calibration logs come from the same physics as the log. For a log of another
physics the curve measures the models against the simulator, not against the tray; the goodness of
fit (:mod:`analysis.fit.goodness`) is the check of that.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import stats

__all__ = ["calibration_truths", "calibration_line", "calibrated_interval", "Calibration", "pair_calibration_truths",
           "calibration_plane", "calibrated_region", "PairCalibration"]


def calibration_truths(estimate: float, half_width: float, count: int, lo: float, hi: float) -> np.ndarray:
    """``count`` coefficients evenly spaced across ``estimate +- half_width``, shifted (not clipped)
    to stay inside ``[lo, hi]`` (every truth distinct)."""
    if count < 3:
        raise ValueError(f"calibration needs at least 3 logs, got {count}")
    if not half_width > 0:
        raise ValueError(f"calibration half-width must be positive, got {half_width!r}")
    a, b = estimate - half_width, estimate + half_width
    if a < lo:
        a, b = lo, lo + 2 * half_width
    if b > hi:
        a, b = max(lo, hi - 2 * half_width), hi
    return np.linspace(a, b, count)


def calibration_line(truths, estimates) -> dict:
    """Least-squares line ``estimate = a + b truth``: ``a``, ``b``, the residual sd ``s`` (``K - 2``
    degrees of freedom), ``tbar`` and ``sxx``."""
    t, e = np.asarray(truths, dtype=float), np.asarray(estimates, dtype=float)
    if t.shape != e.shape or t.ndim != 1 or len(t) < 3:
        raise ValueError("calibration needs at least 3 (truth, estimate) pairs of equal length")
    tbar = float(t.mean())
    sxx = float(np.sum((t - tbar) ** 2))
    if sxx <= 0:
        raise ValueError("calibration truths must not all be equal")
    b = float(np.sum((t - tbar) * (e - e.mean())) / sxx)
    a = float(e.mean() - b * tbar)
    dof = len(t) - 2
    rss = float(np.sum((e - a - b * t) ** 2))
    return {"a": a, "b": b, "s": math.sqrt(rss / dof) if dof else 0.0, "dof": dof, "tbar": tbar, "sxx": sxx,
            "n": len(t)}


def calibrated_interval(line: dict, e0: float, level: float = 0.9) -> tuple[float | None, list | None]:
    """The calibrated estimate ``(e0 - a) / b`` and the classical calibration interval at ``level``
    (module docstring); (None, None) for a flat line, an interval of None when the set is not a
    bounded interval (the slope is not significant beside the scatter)."""
    a, b, s, dof, tbar, sxx, n = (line[k] for k in ("a", "b", "s", "dof", "tbar", "sxx", "n"))
    if b == 0:
        return None, None
    est = (e0 - a) / b
    q = float(stats.t.ppf(0.5 + level / 2, dof))
    g = (q * s) ** 2
    A = b * b - g / sxx
    if A <= 0:
        return est, None
    d = e0 - a
    B = -2 * b * d + 2 * g * tbar / sxx
    C = d * d - g * (1 + 1 / n) - g * tbar * tbar / sxx
    disc = B * B - 4 * A * C
    if disc < 0:                      # cannot happen with A > 0 and the estimate inside; kept for safety
        return est, None
    r = math.sqrt(disc)
    return est, [(-B - r) / (2 * A), (-B + r) / (2 * A)]


class Calibration:
    """Outcome of a calibration: the pairs, the line, the calibrated estimate and interval.

    Attributes
    ----------
    truths, estimates : list of float
        The calibration logs' coefficients and their fitted estimates.
    line : dict
        :func:`calibration_line`.
    uncalibrated : float
        The log's own estimate before calibration.
    estimate : float or None
    interval : list of float or None
        The 90% classical calibration interval.
    seconds : float
        Wall time of the calibration (simulation and scoring).
    """

    def __init__(self, truths, estimates, uncalibrated, seconds=0.0, level=0.9):
        self.truths = [float(v) for v in truths]
        self.estimates = [float(v) for v in estimates]
        self.uncalibrated = float(uncalibrated)
        self.line = calibration_line(self.truths, self.estimates)
        self.estimate, self.interval = calibrated_interval(self.line, self.uncalibrated, level)
        self.seconds, self.level = float(seconds), level

    def to_dict(self) -> dict:
        return {"logs": len(self.truths), "truths": self.truths, "estimates": self.estimates,
                "intercept": self.line["a"], "slope": self.line["b"], "residual_sd": self.line["s"],
                "dof": self.line["dof"], "uncalibrated_estimate": self.uncalibrated, "estimate": self.estimate,
                "interval_90": self.interval, "seconds": round(self.seconds, 2),
                "note": None if self.interval is not None else
                "the calibration line's slope is not significant beside its scatter: no interval"}


# ----------------------------------------------------------------------------------------------
# the static/kinetic pair: a calibration plane and its confidence region
# ----------------------------------------------------------------------------------------------

def pair_calibration_truths(estimate, half, ranges: dict) -> np.ndarray:
    """The 3 x 3 design ``estimate + {-1, 0, 1} half`` (per axis: ``mu_s``, ``mu_k``), each axis shifted
    (not clipped) into its range, and ``mu_s`` lifted to ``mu_k`` where a point falls below the
    diagonal (a static coefficient below the kinetic one is not a friction law)."""
    cols = []
    for i, name in enumerate(("mu_s", "mu_k")):
        lo, hi = ranges[name]
        a, b = estimate[i] - half[i], estimate[i] + half[i]
        if a < lo:
            a, b = lo, min(hi, lo + 2 * half[i])
        if b > hi:
            a, b = max(lo, hi - 2 * half[i]), hi
        cols.append(np.linspace(a, b, 3))
    pts = np.array([(s, k) for s in cols[0] for k in cols[1]])
    pts[:, 0] = np.maximum(pts[:, 0], pts[:, 1])
    return pts


def calibration_plane(truths, estimates, resolution=(0.0, 0.0)) -> dict:
    """The least-squares plane ``e = a + t B`` of 2-D estimates on 2-D truths (``K >= 4`` pairs),
    with the residual covariance ``S`` (``K - 3`` degrees of freedom) plus the estimator's
    resolution term ``diag(resolution^2 / 12)`` (a rectangular error of each grid spacing, as in
    :mod:`analysis.fit.model_error`, which also keeps ``S`` invertible when calibration logs land
    on the same grid point)."""
    T, E = np.asarray(truths, dtype=float), np.asarray(estimates, dtype=float)
    if T.shape != E.shape or T.ndim != 2 or T.shape[1] != 2 or len(T) < 4:
        raise ValueError("a pair calibration needs at least 4 (truth, estimate) pairs of 2 coefficients")
    tbar, ebar = T.mean(axis=0), E.mean(axis=0)
    Tc, Ec = T - tbar, E - ebar
    txx = Tc.T @ Tc
    if np.linalg.matrix_rank(txx) < 2:
        raise ValueError("a pair calibration's truths must span both coefficients")
    B = np.linalg.solve(txx, Tc.T @ Ec)             # (2, 2): e = a + t @ B
    a = ebar - tbar @ B
    R = E - a - T @ B
    dof = len(T) - 3
    S = R.T @ R / dof + np.diag(np.square(np.asarray(resolution, dtype=float)) / 12.0)
    return {"a": a, "B": B, "S": S, "dof": dof, "tbar": tbar, "txx": txx, "n": len(T)}


def calibrated_region(plane: dict, e0, ranges: dict, level: float = 0.9, step: float = 0.0005) -> dict:
    """The coefficients ``t`` (on a ``step`` lattice over the ranges, ``mu_s >= mu_k``) whose predicted
    estimate ``a + t B`` is within the prediction region of the observed ``e0``:
    ``d' S^-1 d / (1 + h(t)) <= c``, ``d = e0 - a - t B``, ``h(t) = 1/K + (t - tbar)' Txx^-1 (t - tbar)``
    (the leverage; Brown 1982, "Multivariate calibration", JRSS B 44:287-321, sec. 2). The intervals
    are per coefficient (and for ``mu_s - mu_k``), so the cutoff is that of one linear function of
    the pair, ``c = F_level(1, nu)`` (``nu = K - 3``): the projection of the ellipsoid
    ``(t - t0)' A (t - t0) <= c`` onto one coordinate is ``t0_i +- sqrt(c (A^-1)_ii)``, the marginal
    interval at ``level`` (Scheffe 1959, "The Analysis of Variance", sec. 3.5, with one direction);
    the joint region of both would need ``2 nu / (nu - 1) F_level(2, nu - 1)``, wider.

    Returns ``estimate`` (the lattice point of smallest statistic), ``interval`` (per coefficient the
    region's projection, ``[lo, hi]``; None when the region is empty), ``open`` (per coefficient:
    the region reaches an end of its range, so the interval is bounded by the range, not the data),
    ``difference_interval`` (of ``mu_s - mu_k`` over the region) and ``cutoff``."""
    a, B, S, nu, tbar, txx, n = (plane[k] for k in ("a", "B", "S", "dof", "tbar", "txx", "n"))
    (slo, shi), (klo, khi) = ranges["mu_s"], ranges["mu_k"]
    s_ax = np.arange(slo, shi + step / 2, step)
    k_ax = np.arange(klo, khi + step / 2, step)
    ss, kk = np.meshgrid(s_ax, k_ax, indexing="ij")
    ok = ss >= kk - 1e-12
    t = np.column_stack([ss[ok], kk[ok]])
    d = np.asarray(e0, dtype=float) - a - t @ B
    tc = t - tbar
    h = 1.0 / n + np.einsum("ij,jk,ik->i", tc, np.linalg.inv(txx), tc)
    stat = np.einsum("ij,jk,ik->i", d, np.linalg.inv(S), d) / (1.0 + h)
    cutoff = float(stats.f.ppf(level, 1, nu)) if nu >= 1 else math.inf
    inside = stat <= cutoff
    best = t[int(np.argmin(stat))]
    out = {"estimate": [float(v) for v in best], "cutoff": cutoff, "interval": None, "open": None,
           "difference_interval": None}
    if inside.any():
        r = t[inside]
        out["interval"] = {name: [float(r[:, i].min()), float(r[:, i].max())] for i, name in enumerate(("mu_s", "mu_k"))}
        gap = r[:, 0] - r[:, 1]
        out["difference_interval"] = [float(gap.min()), float(gap.max())]
        out["open"] = {name: bool(r[:, i].min() <= rng[0] + step / 2 or r[:, i].max() >= rng[1] - step / 2)
                       for i, (name, rng) in enumerate((("mu_s", ranges["mu_s"]), ("mu_k", ranges["mu_k"])))}
    return out


class PairCalibration:
    """Outcome of a pair calibration (:func:`calibration_plane`, :func:`calibrated_region`)."""

    def __init__(self, truths, estimates, uncalibrated, ranges, resolution, seconds=0.0, level=0.9):
        self.truths = np.asarray(truths, dtype=float)
        self.estimates = np.asarray(estimates, dtype=float)
        self.uncalibrated = [float(v) for v in uncalibrated]
        self.plane = calibration_plane(self.truths, self.estimates, resolution)
        self.region = calibrated_region(self.plane, self.uncalibrated, ranges, level)
        self.seconds = float(seconds)

    def to_dict(self) -> dict:
        p, r = self.plane, self.region
        return {"logs": len(self.truths), "truths": self.truths.tolist(), "estimates": self.estimates.tolist(),
                "intercept": p["a"].tolist(), "slope_matrix": p["B"].tolist(), "residual_cov": p["S"].tolist(),
                "dof": p["dof"], "uncalibrated_estimate": self.uncalibrated, "estimate": r["estimate"],
                "interval_90": r["interval"], "difference_interval_90": r["difference_interval"], "open": r["open"],
                "cutoff": r["cutoff"],
                "seconds": round(self.seconds, 2),
                "note": _region_note(r)}


def _region_note(r: dict) -> str | None:
    if r["interval"] is None:
        return "no coefficient of the range predicts the log's estimate: the models cannot explain it"
    opened = [k for k, v in r["open"].items() if v]
    if opened:
        return (f"{' and '.join(opened)} not pinned by this log: the calibrated region reaches the range's end "
                "(the estimates of logs made at other values do not move with it beside their scatter)")
    return None
