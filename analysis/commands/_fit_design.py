"""``kruskal fit --design``: the calibration experiment before any robot runs (analysis/fit/design.py)."""
from __future__ import annotations

import argparse

from analysis.commands import InputError
from analysis.commands._common import check_positive, parse_resolution, sequence_rng


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
    """The ``fit --design`` JSON: ``candidates``, ``recommended`` (and the settings used)."""
    from dataclasses import replace

    from analysis.fit.design import DesignSettings, design
    from analysis.montecarlo import report_grid_for
    from transition_builder.cache import cache_key, cached_build
    from transition_builder.friction import parse_friction

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
    model_sets, keys = [], []
    for mu0 in s.at:
        models = []
        for mu in (mu0 - s.step, mu0, mu0 + s.step):
            res, path, _ = cached_build(replace(scene, friction=parse_friction(round(mu, 10))), build_settings,
                                        workers=args.workers, scheduler=args.scheduler,
                                        progress=True if args.progress else None)
            models.append(res.model)
            keys.append(cache_key(path))
        model_sets.append(models)
    rng = sequence_rng(args.seed)
    randoms = [list(rng.integers(0, len(scene.actions), s.tilts)) for _ in range(s.sequences)]
    out = design(model_sets, scene.actions, s, report_grid_for(scene, args.grid), randoms)
    out.update({"models": keys, "camera_noise": list(camera), "engine": scene.settings.engine,
                "shape": scene.shape.name})
    return out
