"""The fit: the parameters whose model explains a pose log best, with a 90% interval.

Models are built at a grid of parameter values across the range (ordinary cached builds,
:func:`transition_builder.cache.cached_build`), each trial's log-likelihood is computed under
every one (:mod:`analysis.fit.hmm`), and the grid is refined around the best point. The estimate
is the vertex of a quadratic through the log-likelihood at the best grid point and its neighbours
(each model is its own sampled build, so the curve between points is smoothed, not interpolated).
The 90% interval is the 5-95% range of the same estimate on resamples that carry both the log's
error (the trials drawn with replacement; trials are independent, Efron & Tibshirani 1993, ch. 13;
cheap because every trial's likelihood under every model is known) and the models' own (replicate
builds, the criterion's residual scatter and the grid's resolution, :mod:`analysis.fit.model_error`):
a physics log comes from none of the models, and their error does not shrink with more trials. The
tempered profile-likelihood interval is reported beside it. A best grid point
at an end of the range is reported as such (``at_edge``), without an interval.

The likelihood-free baseline, the report-cell histogram distance (:mod:`analysis.fit.histograms`),
is computed at every grid point too (``criterion="histogram"`` fits on it).

Parameters are named (``mu``; ``noise``, the process noise ``pose:S,S`` of the build): a second one
makes the grid a product and the estimate its best point. The static/kinetic pair (``mu_s``,
``mu_k``; :mod:`analysis.fit.pair`) is fitted on the triangle ``mu_s >= mu_k`` of its 2-D grid,
refined around the best point, with a quadratic surface's constrained maximum as the estimate.
"""
from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from analysis.fit.calibration import Calibration, PairCalibration, calibration_truths, pair_calibration_truths
from analysis.fit.goodness import goodness_of_fit
from analysis.fit.histograms import entropy_band, histogram_distance, log_histograms, predicted_histograms
from analysis.fit.hmm import EmissionSettings, model_tolerance, trial_loglik
from analysis.fit.model_error import (
    ESTIMATORS,
    model_error,
    patch_vertex,
    replicate_indices,
    resample_vertices,
    trials_needed,
    weighted_vertex,
)
from analysis.fit.pair import PAIR, pair_axes, pair_grid, pair_refinement, pair_summary
from analysis.streams import salted_rng

__all__ = ["FitSettings", "FitResult", "PARAMETERS", "FITS", "fit_log", "CAMERA_CANDIDATES"]

#: camera noise candidates (mm = deg) tried when the camera noise is estimated from the data.
CAMERA_CANDIDATES = (0.1, 0.25, 0.5, 1.0, 2.0)
#: chi-square(1) 90% quantile / 2: the profile-likelihood drop of a 90% interval.
_PROFILE_DROP = 1.3528


def _set_mu(scene, settings, value):
    from transition_builder.friction import parse_friction
    return replace(scene, friction=parse_friction(float(value))), settings


def _set_noise(scene, settings, value):
    spec = "none" if value <= 0 else f"pose:{value:g},{value:g}"
    return scene, replace(settings, noise=spec)


def _set_pair(scene, mu_s, mu_k):
    from transition_builder.friction import parse_friction
    return replace(scene, friction=parse_friction(f"{mu_s:.10g}/{mu_k:.10g}"))


#: parameter name -> function (scene, build settings, value) -> (scene, build settings); the pair
#: ``mu_s``, ``mu_k`` (:data:`analysis.fit.pair.PAIR`) is set together (``parse_friction("S/K")``).
PARAMETERS = {"mu": _set_mu, "noise": _set_noise}
#: the parameter sets ``kruskal fit --fit`` takes.
FITS = (("mu",), ("mu", "noise"), PAIR)


@dataclass(frozen=True)
class FitSettings:
    """What to fit and how.

    Attributes
    ----------
    params : tuple of str
        One of :data:`FITS`: ``("mu",)``, ``("mu", "noise")`` or ``("mu_s", "mu_k")``.
    ranges : dict
        Parameter name -> (lo, hi).
    points : dict
        Parameter name -> number of grid points across its range (the pair: per axis, >= 2).
    refine : int, optional
        Refinement rounds (``mu`` and the pair): each halves the spacing around the best point.
        Default 1, and 2 for the pair (one round fewer doubles its estimate's error on the
        synthetic family, docs/fit.md).
    camera : tuple or None
        Camera noise (mm, deg); None estimates it from the data (:data:`CAMERA_CANDIDATES`).
    criterion : str
        ``"likelihood"`` (the hidden Markov model) or ``"histogram"`` (the cell-histogram distance).
    bootstrap : int
        Bootstrap resamples of the trials for the interval.
    seed : int
        Seed of the bootstrap and of the goodness-of-fit band.
    outlier : float
        Share of observations allowed from anywhere in the tray (:class:`EmissionSettings`).
    replicates : int
        ``--fit mu``: extra builds (build seed + r, r = 1..replicates) of the best grid point and its
        two neighbours, which measure the models' own error (:mod:`analysis.fit.model_error`);
        0 measures it from the residual scatter of the criterion alone.
    estimator : str
        ``--fit mu`` with the likelihood: ``"grid"`` (default, version 3: the best grid point) or
        ``"vertex"`` (version 2: the vertex of the weighted quadratic through the best point's
        window); :data:`analysis.fit.model_error.ESTIMATORS`, docs/fit.md; ``"local"``: the vertex
        of the quadratic through the fine local patch (``local``), clipped to it.
    local : int
        ``--fit mu``: after refinement, ``local`` models each side of the best point at the spacing
        ``h / (local + 1)`` (``h`` the refined spacing there): a fine local patch of ``2 local + 3``
        models across ``best +- h`` (docs/fit.md, "Finer than the grid"). 0: none.
    gof_draws : int
        Logs simulated from the best model for the goodness of fit (:mod:`analysis.fit.goodness`).
    gof_sibling : bool
        Draw the goodness of fit's reference logs from a second build of the best point (build seed
        + 1; one build more unless it is a replicate already), not from the model itself.
    calibrate : int
        ``--fit mu`` with the likelihood: ``calibrate`` logs simulated directly (the log's sequence and
        trials, the fit's camera noise) at coefficients across the estimate +- ``calibrate_width``,
        each fitted by the same estimator on the same models; the estimate and the 90% interval are
        read back through the calibration line (:mod:`analysis.fit.calibration`). 0: none.
    calibrate_width : float or None
        Half-width of the calibration's coefficients (None: half the spacing beside the best point
        before the local patch, 0.0125 with the default grid and one refinement).
    """

    params: tuple = ("mu",)
    ranges: dict = field(default_factory=lambda: {"mu": (0.1, 0.55), "noise": (0.0, 0.5),
                                                  "mu_s": (0.1, 0.55), "mu_k": (0.1, 0.55)})
    points: dict = field(default_factory=lambda: {"mu": 10, "noise": 3, "mu_s": 6, "mu_k": 6})
    refine: int | None = None
    camera: tuple | None = None
    criterion: str = "likelihood"
    bootstrap: int = 400
    seed: int = 0
    outlier: float = 1e-3
    replicates: int = 1
    estimator: str = "grid"
    local: int = 0
    gof_draws: int = 200
    gof_sibling: bool = True
    calibrate: int = 0
    calibrate_width: float | None = None

    def __post_init__(self):
        if tuple(self.params) not in FITS:
            raise ValueError(f"unknown fit {','.join(self.params)!r}; known: "
                             + "; ".join(",".join(f) for f in FITS))
        for p in self.params:
            lo, hi = self.ranges[p]
            if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
                raise ValueError(f"bad range {lo}..{hi} of {p}")
        if self.refine is None:
            object.__setattr__(self, "refine", 2 if tuple(self.params) == PAIR else 1)
        if tuple(self.params) == PAIR:
            (slo, shi), (klo, khi) = self.ranges["mu_s"], self.ranges["mu_k"]
            if klo <= 0 or shi < khi or slo < klo or (slo == shi and klo == khi):
                raise ValueError(f"bad pair range {slo:g}/{klo:g}..{shi:g}/{khi:g}: need 0 < LO_K, "
                                 "LO_K <= LO_S, HI_K <= HI_S and a range of positive width")
            if min(self.points["mu_s"], self.points["mu_k"]) < 2:
                raise ValueError("a pair fit needs at least 2 grid points per axis")
        if self.local < 0:
            raise ValueError(f"local must be >= 0, got {self.local}")
        if self.calibrate and (self.calibrate < 3 or tuple(self.params) not in (("mu",), PAIR)
                               or self.criterion != "likelihood"):
            raise ValueError(f"calibrate takes 0 or at least 3 logs, with --fit mu or mu_s,mu_k and the likelihood; got "
                             f"{self.calibrate} with --fit {','.join(self.params)} and the {self.criterion}")
        if self.calibrate_width is not None and not (math.isfinite(self.calibrate_width) and self.calibrate_width > 0):
            raise ValueError(f"calibrate width must be a positive number, got {self.calibrate_width!r}")
        if self.estimator not in ESTIMATORS:
            raise ValueError(f"unknown estimator {self.estimator!r}: {' or '.join(ESTIMATORS)}")
        if self.criterion not in ("likelihood", "histogram"):
            raise ValueError(f"unknown criterion {self.criterion!r}: likelihood or histogram")


@dataclass(frozen=True)
class FitResult:
    """Outcome of :func:`fit_log` (``to_dict`` gives the ``kruskal fit`` JSON keys)."""

    estimate: dict
    interval_90: dict
    interval_90_profile: dict
    at_edge: bool
    criterion: list
    criterion_name: str
    camera_noise: dict
    trials: int
    tilts: int
    observations: int
    trials_needed: dict
    goodness: dict
    models: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"estimate": self.estimate, "interval_90": self.interval_90,
                "interval_90_profile": self.interval_90_profile, "at_edge": self.at_edge,
                "criterion": self.criterion, "criterion_name": self.criterion_name,
                "camera_noise": self.camera_noise, "trials": self.trials, "tilts": self.tilts,
                "observations": self.observations, "trials_needed": self.trials_needed,
                "goodness_of_fit": self.goodness, "models": self.models, **self.extra}


class _Grid:
    """Grid points, their models, every trial's log-likelihood and the histogram distance."""

    def __init__(self, build, log, grid, cams):
        self.build, self.log, self.grid, self.cams = build, log, grid, cams
        self.points: list[tuple] = []
        self.ll: dict = {}                  # point -> (n_cams, T)
        self.dist: dict = {}
        self.paths: dict = {}
        self.rep: dict = {}                 # point -> list of (n_cams, T), the replicate builds
        self.patch: tuple | None = None     # (lo, hi) of the fine local patch (FitSettings.local)
        self.simulate = None                # (value, trials, sequence, emission, k) -> FitLog (calibration)
        self.sequence = None                # the log's one tilt sequence (calibration)
        self.counts = log_histograms(log, grid)

    def add(self, point: tuple) -> None:
        point = tuple(round(float(v), 10) for v in point)
        if point in self.ll:
            return
        model, path = self.build(point)
        self.paths[point] = path
        self.ll[point] = np.stack([trial_loglik(model, self.log, em, self.grid) for em in self.cams])
        self.dist[point] = histogram_distance(model, self.log, self.grid, self.counts)
        self.points.append(point)

    def add_replicates(self, point: tuple, count: int) -> None:
        """Build ``point`` ``count`` more times (build seeds + 1 .. + count) and score each build."""
        have = self.rep.setdefault(point, [])
        for r in range(len(have) + 1, count + 1):
            model, path = self.build(point, replicate=r)
            self.paths[(point, r)] = path
            have.append(np.stack([trial_loglik(model, self.log, em, self.grid) for em in self.cams]))

    def mean_ll(self, point: tuple, cam: int) -> np.ndarray:
        """Every trial's log-likelihood at ``point``, the mean over its builds."""
        return np.mean([self.ll[point][cam]] + [r[cam] for r in self.rep.get(point, [])], axis=0)

    def sorted_points(self) -> list[tuple]:
        return sorted(self.points)


def _profile_interval(x, y, j) -> list | None:
    """Values where the quadratic through the best point's window stays within the 90% drop."""
    lo, hi = max(0, j - 2), min(len(x), j + 3)
    xs, ys = x[lo:hi], y[lo:hi]
    if len(xs) < 3:
        return None
    a, b, c = np.polyfit(xs - x[j], ys - y[j], 2)
    if a >= 0:
        return None
    v = -b / (2 * a)
    top = c - b * b / (4 * a)
    half = math.sqrt(_PROFILE_DROP / -a)
    return [float(x[j] + v - half), float(x[j] + v + half)] if math.isfinite(top) else None


def _criterion_values(g: _Grid, pts, cam: int, criterion: str, rows=None) -> np.ndarray:
    if criterion == "histogram":
        return -np.array([g.dist[p] for p in pts])
    if rows is None:
        return np.array([g.ll[p][cam].sum() for p in pts])
    return np.array([g.ll[p][cam][rows].sum() for p in pts])


def _best_camera(g: _Grid) -> int:
    best = [max(g.ll[p][c].sum() for p in g.points) for c in range(len(g.cams))]
    return int(np.argmax(best))


def fit_log(scene, log, settings: FitSettings | None = None, *, build_settings=None, build=None,
            workers=None, scheduler=None, progress=None, grid="4x4x4", simulate=None) -> FitResult:
    """Fit the parameters of ``settings`` to a pose log.

    Parameters
    ----------
    scene : transition_builder.scene.Scene
        The tray, the part, the tilt and the contact (friction is what is fitted).
    log : FitLog
        The log (:func:`analysis.fit.log.read_fit_log`).
    settings : FitSettings, optional
    build_settings : transition_builder.builder.BuildSettings, optional
        Settings of the grid's builds (default: ``BuildSettings.compared()``, the report's compared
        resolution).
    build : callable, optional
        ``build(scene, build_settings) -> (model, name)``; default cached builds, named by their
        cache keys (:func:`transition_builder.cache.cache_key`), as ``FitResult.models`` lists them.
    workers, scheduler, progress
        Passed to the builds.
    grid : str
        Report grid of the histograms and of the goodness of fit.
    simulate : callable, optional
        ``simulate(value, trials, sequence, emission, k) -> FitLog``: calibration log ``k`` at the
        coefficient ``value`` (``FitSettings.calibrate``); default direct simulation of the scene
        (:func:`simulated_log`), process noise of ``build_settings`` included.

    Returns
    -------
    FitResult
    """
    from analysis.montecarlo import report_grid_for
    from transition_builder.builder import BuildSettings

    s = settings or FitSettings()
    bs = build_settings or BuildSettings.compared()
    rgrid = report_grid_for(scene, grid)
    if build is None:
        def build(sc, st):
            from transition_builder.cache import cache_key, cached_build
            res, path, _ = cached_build(sc, st, workers=workers, scheduler=scheduler, progress=progress)
            return res.model, cache_key(path)

    def build_point(point, replicate=0):
        sc, st = scene, (bs if not replicate else replace(bs, seed=bs.seed + replicate))
        if tuple(s.params) == PAIR:
            return build(_set_pair(sc, *point), st)
        for name, v in zip(s.params, point):
            sc, st = PARAMETERS[name](sc, st, v)
        return build(sc, st)

    cams = ([EmissionSettings(*s.camera, outlier=s.outlier)] if s.camera is not None
            else [EmissionSettings(c, c, outlier=s.outlier) for c in CAMERA_CANDIDATES])
    sequence = _calibration_sequence(log) if s.calibrate else None
    g = _Grid(build_point, log, rgrid, cams)
    if s.calibrate:
        g.sequence = sequence
        g.simulate = simulate or functools.partial(simulated_log, scene, bs, s, workers=workers, scheduler=scheduler)
    out, pts, cam = (_fit_pair if tuple(s.params) == PAIR else _fit_grid)(g, s)
    best_point = min(pts, key=lambda p: sum((a - b) ** 2 for a, b in zip(p, out["estimate_tuple"])))
    model, _ = build_point(best_point)
    pred = predicted_histograms(model, log)
    band = entropy_band(pred, g.counts, salted_rng(s.seed, "fit", 1))
    sibling, sibling_name = build_point(best_point, replicate=1) if s.gof_sibling else (None, None)
    test = goodness_of_fit(model, log, rgrid, g.counts, salted_rng(s.seed, "fit", 2), s.gof_draws, sibling)
    test["sibling_model"] = sibling_name
    crit = []
    for p in pts:
        row = {name: v for name, v in zip(s.params, p)}
        row["loglik"] = float(g.ll[p][cam].sum())
        row["histogram_distance"] = g.dist[p]
        crit.append(row)
    cam_used = cams[cam]
    extra = {k: out[k] for k in ("pair", "model_error", "interval_90_trials_only", "calibration") if k in out}
    extra["misreads"] = {"outside_tray": log.outside_tray, "outlier_share": s.outlier}
    return FitResult(
        estimate=out["estimate"], interval_90=out["interval"], interval_90_profile=out["profile"],
        at_edge=out["at_edge"], criterion=crit, criterion_name=s.criterion,
        camera_noise=_camera_report(cam_used, s.camera is None, model),
        trials=log.trials, tilts=log.tilts, observations=log.n_observations,
        trials_needed=out["trials_needed"],
        goodness={"model_point": dict(zip(s.params, best_point)), "entropy": band,
                  "log_histograms": g.counts.tolist(), "model_histograms": pred.tolist(),
                  "verdict": test["verdict"], "test": test},
        models=_model_paths(g, pts), extra=extra)


def _model_paths(g: _Grid, pts) -> dict:
    """Point label -> the model's name (its cache key); a replicate build is labelled ``mu#r``."""
    out = {",".join(f"{v:g}" for v in p): g.paths[p] for p in pts}
    for p, reps in g.rep.items():
        for r in range(1, len(reps) + 1):
            out[",".join(f"{v:g}" for v in p) + f"#{r}"] = g.paths[(p, r)]
    return out


def _camera_report(em: EmissionSettings, estimated: bool, model) -> dict:
    """The camera noise used; when estimated, whether the log can tell it: the emission's sigma is
    ``hypot(camera, tolerance)`` (:mod:`analysis.fit.hmm`), so below the models' snapping tolerance
    the camera's share of the blur is small (at most 1 - 1/sqrt(2) = 29% of it) and confounded with
    how well a model's states stand for the physics' rest poses."""
    tol_mm, tol_deg = model_tolerance(model)
    out = {"mm": em.sigma_mm, "deg": em.sigma_deg, "estimated": estimated,
           "model_tolerance": {"mm": tol_mm, "deg": tol_deg}}
    if estimated:
        ident = em.sigma_mm > tol_mm or em.sigma_deg > tol_deg
        out["identifiable"] = bool(ident)
        if not ident:
            out["note"] = (f"not identifiable: the likelihood's best candidate lies at or below the models' "
                           f"tolerance ({tol_mm:g} mm / {tol_deg:g} deg), where the camera's blur is swamped "
                           f"by the models' own; the log says only that the camera noise is not much above it")
    return out


def _refine(g: _Grid, s: FitSettings, axis: np.ndarray) -> None:
    step = float(axis[1] - axis[0]) if len(axis) > 1 else 0.0
    cam = None
    for _ in range(s.refine):
        if step <= 0:
            return
        cam = _best_camera(g) if s.criterion == "likelihood" else 0
        pts = g.sorted_points()
        y = _criterion_values(g, pts, cam, s.criterion)
        j = int(np.argmax(y))
        step /= 2
        for v in (pts[j][0] - step, pts[j][0] + step):
            if s.ranges[s.params[0]][0] - 1e-12 <= v <= s.ranges[s.params[0]][1] + 1e-12:
                g.add((v,))


def _local_patch(g: _Grid, s: FitSettings) -> None:
    """``s.local`` fine models each side of the best point, at ``h / (local + 1)`` (``h``: the spacing
    beside it), inside the range; when the best fine model is not the patch's centre the patch is
    re-centred on it (up to 3 times), so that the quadratic has both flanks. Records the patch
    ``best +- h`` (none at an edge of the range)."""
    if s.local <= 0 or len(g.points) < 3:
        return
    x = np.array([p[0] for p in g.sorted_points()])
    j = _best_index(g, s)
    if j == 0 or j == len(x) - 1:
        return
    h = float(min(x[j] - x[j - 1], x[j + 1] - x[j]))
    step = h / (s.local + 1)
    lo_r, hi_r = s.ranges[s.params[0]]
    centre = float(x[j])
    for _ in range(4):
        for k in range(1, s.local + 2):
            for v in (centre - k * step, centre + k * step):
                if lo_r - 1e-12 <= v <= hi_r + 1e-12:
                    g.add((v,))
        g.patch = (max(lo_r, centre - h), min(hi_r, centre + h))
        pts = g.sorted_points()
        inside = [i for i, p in enumerate(pts) if g.patch[0] - 1e-9 <= p[0] <= g.patch[1] + 1e-9]
        y = _criterion_values(g, [pts[i] for i in inside], _camera(g, s), s.criterion)
        best = float(pts[inside[int(np.argmax(y))]][0])
        if abs(best - centre) < step / 2:
            return
        centre = best


def _camera(g: _Grid, s: FitSettings) -> int:
    return _best_camera(g) if s.criterion == "likelihood" else 0


def _best_index(g: _Grid, s: FitSettings) -> int:
    """Index of the best point among the sorted points."""
    return int(np.argmax(_criterion_values(g, g.sorted_points(), _camera(g, s), s.criterion)))


def _fit_grid(g: _Grid, s: FitSettings):
    """``mu`` (refined) or the product grid of ``mu,noise``: (summary, points, camera index)."""
    axes = [np.linspace(*s.ranges[p], s.points[p]) if s.points[p] > 1 else np.array([np.mean(s.ranges[p])])
            for p in s.params]
    for point in np.array(np.meshgrid(*axes, indexing="ij")).reshape(len(axes), -1).T:
        g.add(tuple(point))
    if len(s.params) == 1:
        _refine(g, s, axes[0])
        _local_patch(g, s)
    cam = _best_camera(g) if s.criterion == "likelihood" else 0
    pts = g.sorted_points()
    if len(s.params) == 1 and s.criterion == "likelihood" and s.replicates > 0 and len(pts) >= 3:
        j = int(np.argmax(_criterion_values(g, pts, cam, s.criterion)))
        if 0 < j < len(pts) - 1:                  # at an edge there is no interval to widen
            for k in replicate_indices(len(pts), j):
                g.add_replicates(pts[k], s.replicates)
            cam = _best_camera(g)
    return (_summary_1d if len(s.params) == 1 else _summary_nd)(g, s, pts, cam, axes), pts, cam


def _fit_pair(g: _Grid, s: FitSettings):
    """The static/kinetic pair on its triangle, refined (:mod:`analysis.fit.pair`)."""
    for point in pair_grid(*pair_axes(s.ranges, s.points)):
        g.add(point)
    steps = _refine_pair(g, s, pair_axes(s.ranges, s.points))
    cam = _best_camera(g) if s.criterion == "likelihood" else 0
    pts = g.sorted_points()
    y = _criterion_values(g, pts, cam, s.criterion)
    L = np.stack([g.ll[p][cam] for p in pts], axis=1) if s.criterion == "likelihood" else None
    out = pair_summary(np.array(pts), y, L, s.ranges, steps, s.bootstrap,
                       salted_rng(s.seed, "fit"))
    if s.calibrate:
        cal = _calibrate_pair(g, s, pts, cam, steps, out["estimate_tuple"])
        d = {**cal.to_dict(), "uncalibrated_interval_90": out["interval"]}
        out["calibration"] = d
        out["estimate"] = {n: round(v, 6) for n, v in zip(PAIR, d["estimate"])}
        out["estimate_tuple"] = tuple(d["estimate"])
        out["interval"] = None if out["at_edge"] else d["interval_90"]
        out["profile"] = None
    return out, pts, cam


def _calibrate_pair(g: _Grid, s: FitSettings, pts, cam: int, steps, e0) -> PairCalibration:
    """The pair's calibration: the 3 x 3 design around the estimate at twice the finest spacing
    (repeated ``ceil(calibrate / 9)`` times with other logs), each log fitted on the fit's final grid
    by :func:`analysis.fit.pair.pair_estimate`, the plane through them and its region
    (:mod:`analysis.fit.calibration`)."""
    from analysis.fit.pair import pair_estimate

    t0 = time.perf_counter()
    design = pair_calibration_truths(e0, 2 * np.asarray(steps, dtype=float), s.ranges)
    truths = np.concatenate([design] * int(math.ceil(s.calibrate / len(design))))
    em = g.cams[cam]
    logs = [g.simulate(tuple(float(v) for v in t), g.log.trials, g.sequence, em, k) for k, t in enumerate(truths)]
    P = np.array(pts)
    ests = [pair_estimate(P, row, np.asarray(steps, dtype=float))[0] for row in _score_logs(g, pts, logs, em)]
    return PairCalibration(truths, ests, e0, {n: s.ranges[n] for n in PAIR}, steps, time.perf_counter() - t0)


def _refine_pair(g: _Grid, s: FitSettings, axes) -> np.ndarray:
    """Refinement rounds of the pair: halve the spacing, add the best point's eight neighbours; then,
    when the best point moved to the edge of the refined patch, complete its neighbourhood at the
    finest spacing (up to 3 times), so that the estimate's surface is fitted on both sides of it.
    Returns the finest spacing per axis."""
    def best():
        cam = _best_camera(g) if s.criterion == "likelihood" else 0
        pts = g.sorted_points()
        return pts[int(np.argmax(_criterion_values(g, pts, cam, s.criterion)))]

    steps = np.array([ax[1] - ax[0] for ax in axes], dtype=float)
    for _ in range(s.refine):
        steps = steps / 2
        for point in pair_refinement(best(), tuple(steps), s.ranges):
            g.add(point)
    for _ in range(3 if s.refine else 0):   # the final best point gets its whole finest neighbourhood
        b = best()
        for point in pair_refinement(b, tuple(steps), s.ranges):
            g.add(point)
        if best() == b:
            break
    return steps


def _summary_1d(g: _Grid, s: FitSettings, pts, cam, axes) -> dict:
    """Estimate, intervals and trials needed of a 1-D fit, the models' own error included
    (:mod:`analysis.fit.model_error`)."""
    name = s.params[0]
    x = np.array([p[0] for p in pts])
    lo, hi = s.ranges[name]
    if s.criterion != "likelihood":
        y = _criterion_values(g, pts, cam, s.criterion)
        j = int(np.argmax(y))
        return _summary_1d_out(name, weighted_vertex(x, y, np.ones(len(x)), j),
                               bool(len(x) > 1 and (x[j] <= lo + 1e-9 or x[j] >= hi - 1e-9)), None, None, {}, None)
    n = np.array([1.0 + len(g.rep.get(p, [])) for p in pts])
    L = np.stack([g.mean_ll(p, cam) for p in pts], axis=1)              # (T, points)
    y = L.sum(axis=0)
    j = int(np.argmax(y))
    estimator = ESTIMATORS[s.estimator]
    if s.estimator == "local":
        lo_p, hi_p = g.patch or (None, None)
        estimator = functools.partial(patch_vertex, lo=lo_p, hi=hi_p)
    est = estimator(x, y, n, j)
    at_edge = bool(len(x) > 1 and (x[j] <= lo + 1e-9 or x[j] >= hi - 1e-9))
    if at_edge or len(x) < 3 or g.log.trials < 2:     # fewer models cannot show a curve: no interval
        return _summary_1d_out(name, est, at_edge, None, None, {}, None)
    diffs = [float(g.ll[p][cam].sum() - r[cam].sum()) for p in pts for r in g.rep.get(p, [])]
    h = float(min(np.diff(x)[max(0, j - 1):j + 1]))        # the finest spacing beside the best point
    err = model_error(x, y, n, j, diffs, resolution=h,
                      window=g.patch if s.estimator == "local" else None)
    rng = salted_rng(s.seed, "fit")
    B = max(s.bootstrap, 2)
    both = resample_vertices(x, L, n, err, rng, B, estimator=estimator)
    only_trials = resample_vertices(x, L, n, err, rng, B, model=False, estimator=estimator)
    only_model = resample_vertices(x, L, n, err, rng, B, trials=False, estimator=estimator)
    sd_t, sd_m, sd = (float(v.std(ddof=1)) for v in (only_trials, only_model, both))
    interval = [float(v) for v in np.quantile(both, [0.05, 0.95])]
    profile = [est - 1.6448536 * sd, est + 1.6448536 * sd]
    me = err.to_dict()
    me.update({"local_patch": list(g.patch) if g.patch else None,
               "replicated_points": [p[0] for p in pts if p in g.rep], "replicates": s.replicates,
               "sd_estimate": sd, "sd_estimate_trials": sd_t, "sd_estimate_model": sd_m,
               "untempered_profile_90": _profile_interval(x, y, j)})
    if err.var is None:
        me["note"] = "the models' error is not measured (no replicate build and a 3-point window)"
    need = trials_needed(g.log.trials, sd_t, sd_m, sd_resolution=h / math.sqrt(12.0))
    trials_only = [float(v) for v in np.quantile(only_trials, [0.05, 0.95])]
    if not s.calibrate:
        return _summary_1d_out(name, est, at_edge, interval, profile, need, me, trials_only)
    cal = _calibrate(g, s, pts, cam, estimator)
    out = _summary_1d_out(name, est if cal.estimate is None else cal.estimate, at_edge, cal.interval, profile, need,
                          me, trials_only)
    out["calibration"] = {**cal.to_dict(), "uncalibrated_interval_90": interval}
    return out


def _calibrate(g: _Grid, s: FitSettings, pts, cam: int, estimator) -> Calibration:
    """Calibration logs simulated across the estimate, each fitted by ``estimator`` on the same models
    (the local patch's with ``--local``; first builds only, as the log's own estimate is recomputed
    here), the line through them (:mod:`analysis.fit.calibration`)."""
    t0 = time.perf_counter()
    use = [p for p in pts if g.patch is None or s.estimator != "local"
           or g.patch[0] - 1e-9 <= p[0] <= g.patch[1] + 1e-9]
    xs = np.array([p[0] for p in use])
    ones = np.ones(len(use))

    def estimate(y):
        return float(estimator(xs, y, ones, int(np.argmax(y))))

    e0 = estimate(np.array([g.ll[p][cam].sum() for p in use]))
    if s.calibrate_width is not None:
        half = s.calibrate_width
    elif g.patch is not None and s.estimator == "local":
        half = (g.patch[1] - g.patch[0]) / 4
    else:
        j = int(np.argmin(np.abs(xs - e0)))
        half = float(min(np.diff(xs)[max(0, j - 1):j + 1])) / 2
    truths = calibration_truths(e0, half, s.calibrate, *s.ranges[s.params[0]])
    em = g.cams[cam]
    logs = [g.simulate(float(t), g.log.trials, g.sequence, em, k) for k, t in enumerate(truths)]
    return Calibration(truths, [estimate(row) for row in _score_logs(g, use, logs, em)], e0, time.perf_counter() - t0)


def _calibration_sequence(log) -> np.ndarray:
    """The one tilt sequence every trial of ``log`` follows (calibration logs repeat it); one line when
    there is none."""
    seq = log.common_sequence()
    if seq is None or (seq < 0).any():
        raise ValueError("--calibrate needs every trial of the log to follow one tilt sequence")
    return seq


def _score_logs(g: _Grid, points, logs, em) -> np.ndarray:
    """``(len(logs), len(points))``: each log's log-likelihood under each point's model (first builds,
    read back from the cache), one model at a time."""
    scores = np.zeros((len(logs), len(points)))
    for i, p in enumerate(points):
        model, _ = g.build(p)
        for k, lg in enumerate(logs):
            scores[k, i] = trial_loglik(model, lg, em, g.grid).sum()
    return scores


def simulated_log(scene, build_settings, settings: FitSettings, value: float, trials: int, sequence, em, k: int, *,
                  workers=None, scheduler=None):
    """Calibration log ``k``: ``trials`` trials of ``sequence`` simulated directly at the coefficient
    ``value`` (start poses and process noise from stream ``[seed, fit, 4, k]``, the build settings'
    process noise), Gaussian camera noise of ``em`` (stream ``[seed, fit, 5, k]``); faults and poses
    outside the tray are missed observations, as :func:`analysis.fit.log.read_fit_log` reads them."""
    from analysis.fit.log import FitLog, add_camera_noise_to, outside_tray
    from transition_builder.tilting import run_direct

    if tuple(settings.params) == PAIR:
        sc, st = _set_pair(scene, *value), build_settings
    else:
        sc, st = PARAMETERS[settings.params[0]](scene, build_settings, value)
    seed = int(salted_rng(settings.seed, "fit", 4, k).integers(0, 2 ** 31))
    res = run_direct(sc, [int(a) for a in sequence], trials, seed=seed, workers=workers, scheduler=scheduler,
                     noise=st.noise)
    obs = add_camera_noise_to(res.poses, em.sigma_mm, em.sigma_deg, salted_rng(settings.seed, "fit", 5, k))
    outside = outside_tray(obs, (scene.tray_x_mm, scene.tray_y_mm))
    obs[outside] = np.nan
    L = len(sequence)
    return FitLog(obs=obs, actions=np.tile(np.asarray(sequence, dtype=np.int64), (trials, 1)),
                  length=np.full(trials, L, dtype=np.int64), trial_ids=np.arange(trials, dtype=np.int64),
                  action_names=tuple(scene.actions), source="simulation", outside_tray=int(outside.sum()))


def _summary_1d_out(name, est, at_edge, interval, profile, needed, me, trials_only=None) -> dict:
    out = {"estimate": {name: round(est, 6)}, "estimate_tuple": (est,),
           "interval": None if interval is None else {name: interval},
           "profile": None if profile is None else {name: profile}, "at_edge": at_edge,
           "trials_needed": needed or {"half_width_90": {}, "bootstrap_sd": None}}
    if me is not None:
        out["model_error"] = me
        out["interval_90_trials_only"] = {name: trials_only}
    return out


def _summary_nd(g: _Grid, s: FitSettings, pts, cam, axes) -> dict:
    y = _criterion_values(g, pts, cam, s.criterion)
    j = int(np.argmax(y))
    best = pts[j]
    at_edge = any(len(ax) > 1 and (v <= ax[0] + 1e-9 or v >= ax[-1] - 1e-9) for v, ax in zip(best, axes))
    rng = salted_rng(s.seed, "fit")
    T = g.log.trials
    interval = None
    if s.criterion == "likelihood" and not at_edge and T > 1:
        L = np.stack([g.ll[p][cam] for p in pts], axis=1)
        picks = np.array([pts[int(np.argmax(L[rng.integers(0, T, T)].sum(axis=0)))] for _ in range(s.bootstrap)])
        interval = {name: [float(v) for v in np.quantile(picks[:, i], [0.05, 0.95])]
                    for i, name in enumerate(s.params)}
    return {"estimate": {n: float(v) for n, v in zip(s.params, best)}, "estimate_tuple": best,
            "interval": interval, "profile": None, "at_edge": bool(at_edge),
            "trials_needed": {"half_width_90": {}, "bootstrap_sd": None}}
