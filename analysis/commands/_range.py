"""``--friction LO..HI`` on ``plan``, ``ensemble``, ``convergence`` and ``rank``: answers over a range.

Models of ``--shape`` are built at ``--range-points`` coefficients across the range (cached; the fit's
grid settings by default, so a fitted interval's models are reused) and the command runs on each;
its JSON keeps the keys of the middle point and adds ``friction_range``: every answer as
``[min, max]`` over the points (:func:`analysis.friction_range.answers_over_range`). ``plan`` instead
searches one word valid under all the models (the robust plan) and, with ``--check-trials M``,
replays it by direct simulation halfway between the points; ``rank`` adds each part's rank range
and the pairwise orders that hold over the whole interval.
"""
from __future__ import annotations

import argparse

from analysis.commands import InputError


def add_range_options(parser: argparse.ArgumentParser, *, friction: bool = True, shape: bool = True,
                      check: bool = False) -> None:
    """The range options (``--friction`` and ``--shape`` where the command has none of its own)."""
    if friction:
        parser.add_argument("--friction", default=None, metavar="LO..HI",
                            help="answer over models of --shape across this friction range (see docs/fit.md)")
    if shape:
        parser.add_argument("--shape", default=None, help="with --friction LO..HI: the part (default allen-key)")
    from analysis.commands._common import add_engine
    add_engine(parser)
    parser.add_argument("--range-points", type=int, default=5,
                        help="with --friction LO..HI: models across the range (default 5)")
    parser.add_argument("--range-resolution", default="1,1", metavar="MM,DEG",
                        help="with --friction LO..HI: snapping tolerance of the range's models (default 1,1)")
    if check:
        parser.add_argument("--check-trials", type=int, default=0, metavar="M",
                            help="with --friction LO..HI: replay the plan by direct simulation of M trials "
                                 "halfway between the range's points (or at --check-at)")
        parser.add_argument("--check-at", default=None, metavar="MU[,MU...]",
                            help="with --check-trials: replay at these coefficients instead (coefficient i "
                                 "draws its starts with --seed + i)")
        parser.add_argument("--seed", type=int, default=0,
                            help="with --check-trials: seed of the replay's start poses (default 0)")
        parser.add_argument("--workers", type=int, default=None,
                            help="with --friction LO..HI: worker processes of the builds and the replay "
                                 "(default: all cores)")


def is_range(args) -> bool:
    from analysis.friction_range import is_friction_range
    return is_friction_range(getattr(args, "friction", None))


def _range(args):
    from analysis.friction_range import parse_friction_range
    try:
        fr = parse_friction_range(args.friction)
    except ValueError as exc:
        raise InputError(f"--friction: {exc}") from None
    if args.range_points < 2:
        raise InputError(f"--range-points must be at least 2, got {args.range_points}")
    return fr


def range_models(args):
    """(range, [(spec, model, path), ...]) of the command's ``--friction LO..HI`` and ``--shape``."""
    from analysis.commands._common import parse_resolution, physics_changes
    from analysis.friction_range import models_over_range
    from transition_builder.builder import BuildSettings
    from transition_builder.scene import scene_from_options

    if getattr(args, "model", None) or getattr(args, "automaton", None):
        raise InputError("--friction LO..HI builds its own models: drop --model/--automaton")
    fr = _range(args)
    mm, deg = parse_resolution(args.range_resolution)
    physics = physics_changes(args)           # --engine (the ranges have no --contact)
    try:
        scene = scene_from_options(args.shape or "allen-key", **physics)
    except ValueError as exc:
        raise InputError(f"--shape: {exc}") from None
    bs = BuildSettings.compared(tol_mm=mm, tol_deg=deg)
    return fr, scene, models_over_range(scene, fr, args.range_points, bs, workers=getattr(args, "workers", None))


def run_over_range(args, run_one) -> dict:
    """Run a single-model command at every point of the range; the middle point's keys plus
    ``friction_range``: every answer's range, and ``at_points`` (each point's single numbers, so
    that a range's ends can be told apart)."""
    from analysis.friction_range import answers_over_range

    fr, _, models = range_models(args)
    outs = [run_one(argparse.Namespace(**{**vars(args), "model": path, "friction": None}))
            for _, _, path in models]
    out = dict(outs[len(outs) // 2])
    out["friction_range"] = {**answers_over_range([s for s, _, _ in models], outs), "interval": str(fr),
                             "models": [p for _, _, p in models], "middle": models[len(models) // 2][0],
                             "at_points": {s: _numbers(o) or {} for (s, _, _), o in zip(models, outs)}}
    return out


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _numbers(v):
    """The single numbers and flags of an answer, nested dictionaries kept (``convergence``'s
    ``expected_length`` is one) and intervals (lists of at most two numbers) kept; curves, nulls
    and everything else dropped; None when nothing is left.

    >>> _numbers({"a": 1, "b": {"mc": 2.5, "ci95": [2, 3], "curve": [1, 2, 3]}, "c": "x", "d": {"e": None},
    ...           "infinite": False})
    {'a': 1, 'b': {'mc': 2.5, 'ci95': [2, 3]}, 'infinite': False}
    """
    if _is_number(v) or isinstance(v, bool):
        return v
    if isinstance(v, dict):
        kept = {k: x for k, x in ((k, _numbers(x)) for k, x in v.items()) if x is not None}
        return kept or None
    if isinstance(v, (list, tuple)) and 0 < len(v) <= 2 and all(_is_number(x) for x in v):
        return list(v)
    return None


def _check_coefficients(args):
    """The coefficients of ``--check-at`` (None: halfway between the range's points)."""
    text = getattr(args, "check_at", None)
    if text is None:
        return None
    from transition_builder.friction import parse_friction

    mus = []
    for part in str(text).split(","):
        try:
            spec = parse_friction(part.strip())
        except ValueError as exc:
            raise InputError(f"--check-at: {exc}") from None
        if getattr(spec, "kind", "uniform") != "uniform" or getattr(spec, "mu_s", None) not in (None, spec.mu):
            raise InputError(f"--check-at takes plain coefficients, got {part.strip()!r}")
        mus.append(float(spec.mu))
    return mus


def plan_over_range(args, run_one) -> dict:
    """The robust plan over the range's models, replayed by direct simulation when asked
    (``--check-trials M``: halfway between the points, or at ``--check-at``)."""
    from analysis.friction_range import check_plan_between

    if args.check_trials < 0:
        raise InputError(f"--check-trials must be non-negative, got {args.check_trials}")
    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers must be a positive integer, got {args.workers}")
    coefficients = _check_coefficients(args)
    if coefficients is not None and not args.check_trials:
        raise InputError("--check-at needs --check-trials M")
    fr, scene, models = range_models(args)
    out = run_one(argparse.Namespace(**{**vars(args), "model": [p for _, _, p in models], "friction": None}))
    out["friction_range"] = {"interval": str(fr), "friction": [s for s, _, _ in models]}
    if args.check_trials and out.get("word"):
        out["friction_range"]["between_points"] = check_plan_between(
            scene, out["word"], out.get("final_cell"), fr, args.range_points, args.check_trials, args.seed,
            workers=getattr(args, "workers", None), coefficients=coefficients)
    return out


def rank_over_range(args, run_one) -> dict:
    """``rank`` at every point of the range: the middle point's ranking with each part's rank range,
    and the pairwise orders that hold over the whole interval."""
    from analysis.friction_range import rankings_over_range

    fr = _range(args)
    specs = fr.points(args.range_points)
    outs = [run_one(argparse.Namespace(**{**vars(args), "friction": s, "markdown": None})) for s in specs]
    summary = rankings_over_range(specs, [o["ranking"] for o in outs])
    out = dict(outs[len(outs) // 2])
    for row in out["ranking"]:
        row["rank_range"] = summary["rank_range"][row["shape"]]
    out["friction_range"] = {**summary, "interval": str(fr),
                             "rankings": {s: o["order"] for s, o in zip(specs, outs)}}
    return out
