"""``kruskal fit --design``: the calibration experiment before any robot runs (analysis/fit/design.py)."""
from __future__ import annotations

import argparse

from analysis.commands import InputError
from analysis.commands._common import check_positive, parse_resolution


def add_design_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``--design`` (``--trials``, ``--sequences``, ``--tilts``, ``--at``, ``--target-width``)."""
    parser.add_argument("--design", action="store_true",
                        help="design the calibration log instead of fitting one: candidate sequences, their "
                             "predicted 90%% widths and the recommended sequence and trials (no --poses)")
    parser.add_argument("--sequences", type=int, default=8, help="--design: random candidate sequences (default 8)")
    parser.add_argument("--tilts", type=int, default=50, help="--design: tilts of every candidate (default 50)")
    parser.add_argument("--trials", type=int, default=500, help="--design: the trial budget (default 500)")
    parser.add_argument("--at", default="0.2,0.3,0.4", metavar="MU[,MU...]",
                        help="--design: the coefficients the design is made at, the prior range's points; each "
                             "candidate counts its smallest information over them (default 0.2,0.3,0.4)")
    parser.add_argument("--target-width", type=float, default=0.02,
                        help="--design: the 90%% width the recommended trials reach (default 0.02)")
    parser.add_argument("--design-step", type=float, default=0.025,
                        help="--design: finite-difference step of the information (default 0.025)")


def run_design(args: argparse.Namespace, scene, build_settings) -> dict:
    """The ``fit --design`` JSON: ``candidates``, ``recommended`` (and the settings used), from
    :func:`analysis.fit.design.design_for_scene` once the options are checked."""
    from analysis.fit.design import DesignSettings, design_for_scene

    if args.fit != "mu":
        raise InputError(f"--design designs a --fit mu calibration only, got --fit {args.fit!r}")
    for name in ("sequences", "tilts", "trials"):
        check_positive(getattr(args, name), f"--{name}")
    camera = parse_resolution(args.camera_noise) if args.camera_noise else (0.5, 0.5)
    try:
        at = tuple(float(v) for v in args.at.split(","))
    except ValueError:
        raise InputError(f"bad --at {args.at!r}: expected MU[,MU...], e.g. 0.2,0.3,0.4") from None
    try:
        s = DesignSettings(at=at, step=args.design_step, sequences=args.sequences, tilts=args.tilts,
                           trials=args.trials, target=args.target_width, camera=camera, seed=args.seed)
    except ValueError as exc:
        raise InputError(f"--design: {exc}") from None
    return design_for_scene(scene, s, build_settings, grid=args.grid, workers=args.workers, scheduler=args.scheduler,
                            progress=True if args.progress else None)
