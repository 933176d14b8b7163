"""``kruskal fit``: the tray's physics from a pose log (e.g. an overhead camera's).

The floor's friction coefficient (``--fit mu``, the default), optionally with the process noise
(``--fit mu,noise``), or the static/kinetic pair (``--fit mu_s,mu_k``, the coulomb contact), that explains a ``--poses`` log best: models at a grid of values across
``--range`` (cached builds), every trial's likelihood under each (the model as a hidden Markov model
of the camera's view), the estimate, a 90% interval, the criterion over the range, the goodness of
fit and the trials a log needs for a given precision. Method and measurements: docs/fit.md.
"""
from __future__ import annotations

import argparse

from analysis.commands import InputError
from analysis.commands._common import (
    add_contact,
    add_seed,
    check_positive,
    check_writable_file,
    parse_resolution,
    parse_sequence,
    scene_from_args,
    sequence_rng,
)
from analysis.commands._fit_design import add_design_arguments, run_design

_PAIR_RANGE_NOTE = "a paired --range LO_S/LO_K..HI_S/HI_K needs --fit mu_s,mu_k"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--poses", default=None, metavar="LOG.csv",
                        help="the log: columns trial,step,x_mm,y_mm,theta_rad[,status][,action]")
    parser.add_argument("--shape", default=None, help="the logged part (default allen-key)")
    parser.add_argument("--sequence", default=None,
                        help="the tilts of every trial (NE,S,... or random:N from --seed); "
                             "default: the log's action column")
    parser.add_argument("--fit", default="mu",
                        help="what to fit: mu (default), mu,noise or mu_s,mu_k (the static/kinetic pair)")
    parser.add_argument("--range", default="0.1..0.55", metavar="LO..HI",
                        help="friction range searched (default 0.1..0.55; below tan(tilt) for sliding); with "
                             "--fit mu_s,mu_k the range of both coefficients, or LO_S/LO_K..HI_S/HI_K each its own")
    parser.add_argument("--noise-range", default="0..0.5", metavar="LO..HI",
                        help="with --fit mu,noise: process noise range, mm = deg (default 0..0.5)")
    parser.add_argument("--points", type=int, default=10,
                        help="models across the friction range before refinement (default 10)")
    parser.add_argument("--noise-points", type=int, default=3, help="with --fit mu,noise: noise levels (default 3)")
    parser.add_argument("--pair-points", type=int, default=6,
                        help="with --fit mu_s,mu_k: grid points per coefficient (default 6: 21 models on the "
                             "triangle mu_s >= mu_k of a common range)")
    parser.add_argument("--refine", type=int, default=None,
                        help="refinement rounds: midpoints beside the best model (default 1; 2 with "
                             "--fit mu_s,mu_k)")
    parser.add_argument("--camera-noise", default=None, metavar="MM,DEG",
                        help="camera noise (standard deviation); default: estimated from the log")
    parser.add_argument("--criterion", choices=("likelihood", "histogram"), default="likelihood",
                        help="likelihood (hidden Markov model, default) or histogram (cell-histogram distance)")
    parser.add_argument("--bootstrap", type=int, default=400, help="bootstrap resamples of the trials (default 400)")
    parser.add_argument("--replicates", type=int, default=1,
                        help="--fit mu: extra builds (other build seeds) of the best model and its two neighbours, "
                             "measuring the models' own error for the interval (default 1; 0: from the "
                             "criterion's residual scatter alone)")
    parser.add_argument("--estimator", choices=("grid", "vertex", "local"), default=None,
                        help="--fit mu: the estimate is the best grid point (grid, the default without --local), "
                             "the vertex of a quadratic through its window (vertex) or through the fine local "
                             "patch (local, the default with --local; docs/fit.md)")
    parser.add_argument("--local", type=int, default=0, metavar="K",
                        help="--fit mu: K fine models each side of the best refined point (spacing h/(K+1)); "
                             "default 0 (none)")
    parser.add_argument("--calibrate", type=int, default=0, metavar="K",
                        help="--fit mu or mu_s,mu_k: K logs simulated directly across the estimate (the pair: a 3 x 3 design, "
                             "repeated to K), fitted by the same models; "
                             "the estimate and interval read back through their calibration line (docs/fit.md); "
                             "default 0 (none), at least 3")
    parser.add_argument("--calibrate-width", type=float, default=None, metavar="W",
                        help="half-width of the calibration logs' coefficients around the estimate (default half "
                             "the refined spacing)")
    parser.add_argument("--figure", metavar="PNG", help="write the criterion and goodness-of-fit figure here")
    parser.add_argument("--resolution", default="1,1", metavar="MM,DEG",
                        help="snapping tolerance of the grid's models (default 1,1; see docs/fit.md)")
    parser.add_argument("--start-samples", type=int, default=2000, help="start samples of each model (default 2000)")
    parser.add_argument("--recenter-rounds", type=int, default=1, help="recentring rounds of each model (default 1)")
    parser.add_argument("--build-seed", type=int, default=0, help="seed of the models' builds (default 0)")
    parser.add_argument("--grid", default="4x4x4", help="report grid AxBxG of the histograms (default 4x4x4)")
    parser.add_argument("--tilt-deg", type=float, default=None, help="tilt angle in degrees (default 30)")
    parser.add_argument("--scene", metavar="FILE", help="a scene file (.json/.toml); its friction is ignored")
    add_design_arguments(parser)
    add_contact(parser)
    add_seed(parser)
    parser.add_argument("--workers", type=int, default=None, help="worker processes of the builds")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS", help="a Dask distributed scheduler")
    parser.add_argument("--progress", action="store_true", help="progress bars on standard error")


def _float_range(text: str, option: str) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in text.split(".."))
    except ValueError:
        raise InputError(f"bad {option} {text!r}: expected LO..HI, e.g. 0..0.5") from None
    if not (0 <= lo <= hi):
        raise InputError(f"bad {option} {text!r}: need 0 <= LO <= HI")
    return lo, hi


def _settings(args):
    from analysis.fit import FitSettings
    from analysis.fit.core import FITS
    from analysis.friction_range import parse_friction_range

    params = tuple(p.strip().lower() for p in args.fit.split(","))
    if params not in FITS:
        raise InputError(f"bad --fit {args.fit!r}: expected mu, mu,noise or mu_s,mu_k")
    try:
        fr = parse_friction_range(args.range)
    except ValueError as exc:
        raise InputError(f"--range: {exc}") from None
    pair = params == ("mu_s", "mu_k")
    if fr.paired and not pair:
        raise InputError(_PAIR_RANGE_NOTE)
    check_positive(args.points, "--points")
    check_positive(args.noise_points, "--noise-points")
    if min(args.refine or 0, args.bootstrap, args.replicates, args.local) < 0:
        raise InputError("--refine, --bootstrap, --replicates and --local must be >= 0")
    estimator = args.estimator or ("local" if args.local > 0 else "grid")
    if estimator == "local" and args.local <= 0:
        raise InputError("--estimator local needs --local K with K >= 1 (the fine patch it fits)")
    camera = None
    if args.camera_noise is not None:
        camera = parse_resolution(args.camera_noise)
        if min(camera) <= 0:
            raise InputError(f"--camera-noise must be positive, got {args.camera_noise!r}")
    ranges = {"mu": (fr.lo[0], fr.hi[0]), "noise": _float_range(args.noise_range, "--noise-range"),
              "mu_s": (fr.lo[0], fr.hi[0]), "mu_k": (fr.lo[1], fr.hi[1])}
    points = {"mu": args.points, "noise": args.noise_points, "mu_s": args.pair_points, "mu_k": args.pair_points}
    if pair:
        _check_pair(args, fr)
    try:
        return FitSettings(params=params, ranges=ranges, points=points, refine=args.refine, camera=camera,
                           criterion=args.criterion, bootstrap=args.bootstrap, seed=args.seed,
                           replicates=args.replicates, estimator=estimator, local=args.local,
                           calibrate=args.calibrate, calibrate_width=args.calibrate_width)
    except ValueError as exc:
        raise InputError(f"--fit {args.fit}: {exc}") from None


def _check_pair(args, fr) -> None:
    """A pair fit's range and grid: one line naming what is wrong."""
    if args.pair_points < 2:
        raise InputError(f"--pair-points must be at least 2, got {args.pair_points}")
    if fr.lo == fr.hi:
        raise InputError(f"--range {args.range!r}: --fit mu_s,mu_k needs a range of positive width")
    if fr.lo[1] <= 0:
        raise InputError(f"--range {args.range!r}: the kinetic coefficient of a pair must be positive "
                         "(LO > 0)")


def run(args: argparse.Namespace) -> dict:
    from analysis.fit import fit_log, read_fit_log
    from transition_builder.builder import BuildSettings

    if not args.design and args.poses is None:
        raise InputError("kruskal fit needs --poses LOG.csv (or --design, to plan the log)")
    if args.design and args.poses is not None:
        raise InputError("--design plans a log before it exists: give no --poses")
    settings = _settings(args)
    check_writable_file(args.figure, "--figure")
    if args.workers is not None:
        check_positive(args.workers, "--workers")
    check_positive(args.start_samples, "--start-samples")
    scene = scene_from_args(argparse.Namespace(**{**vars(args), "friction": None}))
    if settings.params == ("mu_s", "mu_k") and scene.settings.contact != "coulomb":
        raise InputError(f"--fit mu_s,mu_k needs the coulomb contact: the {scene.settings.contact} contact has "
                         "one Bullet coefficient, static and kinetic alike")
    mm, deg = parse_resolution(args.resolution)
    bs = BuildSettings(tol_mm=mm, tol_deg=deg, recenter_rounds=args.recenter_rounds,
                       start_samples=args.start_samples, seed=args.build_seed, grid=args.grid)
    if args.design:
        return run_design(args, scene, bs)
    sequence = None
    if args.sequence is not None:
        sequence = parse_sequence(args.sequence, scene.actions, sequence_rng(args.seed))
    log = read_fit_log(args.poses, scene.actions, (scene.tray_x_mm, scene.tray_y_mm), sequence)
    result = fit_log(scene, log, settings, build_settings=bs, workers=args.workers, scheduler=args.scheduler,
                     progress=True if args.progress else None, grid=args.grid)
    out = result.to_dict()
    out.update({"shape": scene.shape.name, "contact": scene.settings.contact, "engine": scene.settings.engine, "range": args.range,
                "tilts_from": log.source, "fit": list(settings.params)})
    seq = log.common_sequence()
    if seq is not None:
        out["sequence"] = [scene.actions[a] for a in seq]
    if args.figure:
        from analysis.fit.figure import fit_figure
        out["figure"] = fit_figure(out, args.figure)
    return out


def format_text(result: dict) -> str:
    """A short human summary: the estimate, its interval, the criterion over the range (with
    ``--design``: the candidates' predicted widths and the recommendation)."""
    if "candidates" in result:
        return _design_text(result)
    lines = []
    for name, value in result["estimate"].items():
        iv = (result["interval_90"] or {}).get(name)
        tail = "best at the edge of the range: no interval" if result["at_edge"] else (
            f"90% interval {iv[0]:.4g} .. {iv[1]:.4g}" if iv else "no interval")
        lines.append(f"{name} = {value:.4g}   {tail}")
    pair = result.get("pair")
    if pair and pair["difference_interval_90"]:
        d = pair["difference_interval_90"]
        single = ("" if pair["best_single_mu"] is None else
                  f"; best single coefficient {pair['best_single_mu']:.4g} "
                  f"({pair['criterion_gain_over_single']:.1f} below the pair)")
        lines.append(f"mu_s - mu_k: 90% interval {d[0]:.4g} .. {d[1]:.4g}{single}")
    test = (result.get("goodness_of_fit") or {}).get("test") or {}
    if test.get("verdict"):
        lines.append(f"goodness of fit: {test['verdict']} (histogram distance {test['log']:.4f}; logs of this size "
                     f"from {'a sibling build of ' if test.get('reference') == 'sibling build' else ''}"
                     f"the best model: median {test['model_median']:.4f}, 95% {test['model_95']:.4f}; "
                     f"p = {test['p_value']:.3f})")
    cam = result["camera_noise"]
    how = "given" if not cam["estimated"] else ("estimated" if cam.get("identifiable", True) else
                                                 "not identifiable: at or below the models' tolerance")
    lines.append(f"camera noise {cam['mm']:g} mm / {cam['deg']:g} deg ({how});"
                 f" {result['trials']} trials, {result['tilts']} tilts, {result['observations']} observations")
    names = list(result["estimate"])
    lines.append("  ".join(f"{n:>6}" for n in names) + "      loglik  hist_dist")
    for row in result["criterion"]:
        lines.append("  ".join(f"{row[n]:6.3f}" for n in names) + f"  {row['loglik']:10.1f}  {row['histogram_distance']:9.4f}")
    needed = result["trials_needed"]["half_width_90"]
    if needed:
        lines.append("trials for a 90% half-width of " + ", ".join(
            f"{k}: {'unreachable (models / grid)' if v is None else format(v, ',')}" for k, v in needed.items()))
    if result["trials_needed"].get("dominated_by"):
        lines.append(f"the interval is dominated by: {result['trials_needed']['dominated_by']} "
                     f"({result['trials_needed']['note']})")
    lines.append(f"seconds: {result['seconds']:.1f}")
    return "\n".join(lines)


def _design_text(result: dict) -> str:
    lines = [f"design at mu = {', '.join(f'{v:g}' for v in result['at'])} (smallest information over them, "
             f"from models at +-{result['step']:g}), "
             f"{result['trials_budget']} trials:"]
    for c in result["candidates"]:
        w = c["predicted_width_90"]["mu"]
        lines.append(f"  {'designed' if c['designed'] else 'random  '}  width {'-' if w is None else f'{w:.4f}'}"
                     f"  {','.join(c['sequence'][:8])}...")
    r = result["recommended"]
    lines.append(f"recommended: {'the designed' if r['designed'] else 'a random'} sequence, {r['trials']} trials "
                 f"for a 90% width of {r['target_width_90']:g} ({result['note']})")
    lines.append(f"seconds: {result['seconds']:.1f}")
    return "\n".join(lines)
