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

__all__ = ["calibration_truths", "calibration_line", "calibrated_interval", "Calibration"]


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
