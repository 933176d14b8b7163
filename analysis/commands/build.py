"""``kruskal build``: sample the physics engine into per-action transition matrices (a model ``.npz``).

States are representative rest poses reached from the uniform start distribution, reduced by the
tray's symmetry (``transition_builder.builder``; design and measurements in ``docs/builder.md``).
Finished models are cached under a content hash of everything that changes them; a killed build
resumes from its checkpoint when started again.
"""
from __future__ import annotations

import argparse

from analysis.commands import InputError
from analysis.commands._common import (
    FRICTION_HELP,
    add_contact,
    add_seed,
    add_tilt_time,
    check_positive,
    check_writable_file,
    parse_resolution,
)
from transition_builder.builder.options import BUILD_OPTIONS


def _flagged():
    """The build options with a flag of their own, the ones set apart last."""
    return sorted((o for o in BUILD_OPTIONS if o.flag), key=lambda o: o.set_apart)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--shape", default=None, help="allen-key | triangle:SEED | rectangle:WxH | "
                        "polygon:x1,y1;x2,y2;... | FILE.json (default allen-key)")
    parser.add_argument("--friction", default=None, help=FRICTION_HELP)
    parser.add_argument("--tilt-deg", type=float, default=None, help="tilt angle in degrees (default 30)")
    add_tilt_time(parser)
    parser.add_argument("--scene", metavar="FILE", help="a scene file (.json/.toml)")
    parser.add_argument("--noise", default="none", help="process noise: none | pose:SIGMA_MM,SIGMA_DEG")
    parser.add_argument("--resolution", default=None, metavar="MM,DEG",
                        help="snapping tolerance of representative rest poses, mm and degrees "
                             "(default 0.25,0.25 without noise, 0.75,0.75 with noise)")
    for option in _flagged():           # each defined once, in transition_builder.builder.options
        if option.type is bool:
            parser.add_argument(option.flag, action=argparse.BooleanOptionalAction, default=None, help=option.help)
        else:
            parser.add_argument(option.flag, type=option.type, default=None, metavar=option.metavar,
                                help=option.help)
    parser.add_argument("--no-symmetry", action="store_true", help="do not use the tray's rotation symmetry")
    add_contact(parser)
    parser.add_argument("--support-points", type=int, default=None, help=argparse.SUPPRESS)   # old: --contact
    add_seed(parser)
    parser.add_argument("--out", metavar="PATH", help="write the model here (default: the cache file)")
    parser.add_argument("--no-cache", action="store_true",
                        help="build from scratch: reuse neither a cached model nor a checkpoint")
    parser.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS", help="a Dask distributed scheduler")
    parser.add_argument("--progress", action="store_true", help="progress bar on standard error")


def scene_for(args):
    """The scene named by --scene/--shape/--friction/--tilt-deg/--contact (``--support-points K``,
    the option's name before simulator version 4, means ``sphere`` for 1 and ``legs:K`` otherwise)."""
    from analysis.commands._common import scene_from_args

    k = getattr(args, "support_points", None)
    if k is not None:
        if getattr(args, "contact", None) is not None:
            raise InputError("give --contact or --support-points, not both")
        if k < 1:
            raise InputError(f"--support-points must be at least 1, got {k}")
        args = argparse.Namespace(**{**vars(args), "contact": "sphere" if k == 1 else f"legs:{k}",
                                     "support_points": None})
    return scene_from_args(args)


def run(args: argparse.Namespace) -> dict:
    from transition_builder.builder import BuildSettings
    from transition_builder.cache import cached_build

    if args.workers is not None:
        check_positive(args.workers, "--workers")
    check_writable_file(args.out, "--out")
    scene = scene_for(args)
    mm, deg = parse_resolution(args.resolution) if args.resolution is not None else (None, None)
    chosen = {o.name: getattr(args, o.name) for o in _flagged() if getattr(args, o.name) is not None}
    settings = BuildSettings(tol_mm=mm, tol_deg=deg, symmetry=not args.no_symmetry, noise=args.noise, seed=args.seed,
                             **chosen)
    result, path, cached = cached_build(scene, settings, args.out, use_cache=not args.no_cache,
                                        workers=args.workers, scheduler=args.scheduler,
                                        progress=True if args.progress else None)
    stats = dict(result.stats)
    out = {"model": path, "key": result.model.metadata.get("build_key"), "states": stats.get("states"),
           "voxels_total": stats.get("voxels_total"),
           "tilts_simulated": 0 if cached else stats.get("tilts_simulated"),
           "fault_rate": stats.get("fault_rate"), "cached": cached, "shape": scene.shape.name,
           "friction": str(scene.friction), "tilt_time_s": scene.tilt_time_s, "noise": settings.noise, "contact": scene.settings.contact,
           "engine": scene.settings.engine}
    if cached:
        stats["tilts_simulated_when_built"] = stats.pop("tilts_simulated", None)
    out.update({k: v for k, v in stats.items() if k not in out})
    return out
