"""``kruskal build``: sample the physics engine into per-action transition matrices (a model ``.npz``).

States are representative rest poses reached from the uniform start distribution, reduced by the
tray's symmetry (``transition_builder.builder``; design and measurements in ``docs/builder.md``).
Finished models are cached under a content hash of everything that changes them; a killed build
resumes from its checkpoint when started again.
"""
from __future__ import annotations

import argparse

from analysis.commands import InputError
from analysis.commands._common import add_contact, add_seed, check_writable_file, parse_resolution


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--shape", default=None, help="allen-key | triangle:SEED | rectangle:WxH | "
                        "polygon:x1,y1;x2,y2;... | FILE.json (default allen-key)")
    parser.add_argument("--friction", default=None, help="a Coulomb coefficient or map:LEVEL:SEED")
    parser.add_argument("--tilt-deg", type=float, default=None, help="tilt angle in degrees (default 30)")
    parser.add_argument("--scene", metavar="FILE", help="a scene file (.json/.toml)")
    parser.add_argument("--noise", default="none", help="process noise: none | pose:SIGMA_MM,SIGMA_DEG")
    parser.add_argument("--resolution", default=None, metavar="MM,DEG",
                        help="snapping tolerance of representative rest poses, mm and degrees "
                             "(default 0.25,0.25 without noise, 0.75,0.75 with noise)")
    parser.add_argument("--samples", type=int, default=None, metavar="K",
                        help="samples per state and action (default 1 without noise, 4 with noise)")
    parser.add_argument("--start-samples", type=int, default=5000,
                        help="uniform start poses for the first tilt (default 5000)")
    parser.add_argument("--grid", default="4x4x4", help="report grid AxBxG (default 4x4x4)")
    parser.add_argument("--theta-offset", type=float, default=None, metavar="RAD",
                        help="theta bin offset of the report grid (default half a bin)")
    parser.add_argument("--refine-rounds", type=int, default=None, metavar="R",
                        help="adaptive refinement rounds of a deterministic build (default: the builder's)")
    parser.add_argument("--recenter-rounds", type=int, default=None, metavar="R",
                        help="recentring rounds of a deterministic build (default: the builder's)")
    parser.add_argument("--explore-weight", type=float, default=None, metavar="W",
                        help="expand only states that hold probability >= W on some random sequence "
                             "(default 0 = everything without noise, 1e-3 with noise)")
    parser.add_argument("--confirm-samples", type=int, default=None, metavar="K1",
                        help="noisy builds: top heavy rows up to K1 samples first, and only those whose "
                             "samples disagree on the report cell up to K (default: the builder's)")
    parser.add_argument("--max-samples", type=int, default=None, metavar="KMAX",
                        help="noisy builds: rows of weight w >= --heavy-weight get K * w / heavy-weight "
                             "samples, up to KMAX (default: the builder's)")
    parser.add_argument("--heavy-weight", type=float, default=None, metavar="W",
                        help="the weight from which --max-samples adds samples (default: the builder's)")
    parser.add_argument("--probes", type=int, default=None, metavar="M",
                        help="deterministic builds: representatives of weight >= --probe-weight tilt up to M of "
                             "their members; where one lands in another report cell the row becomes the "
                             "members' landings (default: 4 without noise at the default tolerance or finer, 0 "
                             "with noise, weighted exploration or a coarser tolerance)")
    parser.add_argument("--probe-weight", type=float, default=None, metavar="W",
                        help="the weight from which --probes probes a representative (default: the builder's)")
    parser.add_argument("--probe-distance", type=float, default=None, metavar="D",
                        help="with --probes, a member landing in the representative's report cell but more than "
                             "D tolerance balls from its landing also makes the row sensitive (default: 4 "
                             "with --probes, 0 without)")
    parser.add_argument("--flush-side", action=argparse.BooleanOptionalAction, default=None,
                        help="snap only between poses resting on the same end of an edge flush with a wall "
                             "(default: on without noise, off with noise)")
    parser.add_argument("--no-symmetry", action="store_true", help="do not use the tray's rotation symmetry")
    add_contact(parser)
    parser.add_argument("--support-points", type=int, default=None, help=argparse.SUPPRESS)   # old: --contact
    parser.add_argument("--max-states", type=int, default=400_000, help="stop exploring beyond this many states")
    add_seed(parser)
    parser.add_argument("--out", metavar="PATH", help="write the model here (default: the cache file)")
    parser.add_argument("--no-cache", action="store_true", help="rebuild even if a cached model exists")
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

    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers must be at least 1, got {args.workers}")
    check_writable_file(args.out, "--out")
    scene = scene_for(args)
    mm, deg = parse_resolution(args.resolution) if args.resolution is not None else (None, None)
    settings = BuildSettings(tol_mm=mm, tol_deg=deg, start_samples=args.start_samples, samples=args.samples,
                             grid=args.grid, theta_offset=args.theta_offset, symmetry=not args.no_symmetry,
                             max_states=args.max_states, noise=args.noise, seed=args.seed,
                             explore_weight=args.explore_weight,
                             **({} if args.confirm_samples is None else {"confirm_samples": args.confirm_samples}),
                             **({} if args.flush_side is None else {"flush_side": args.flush_side}),
                             **({} if args.max_samples is None else {"max_samples": args.max_samples}),
                             **({} if args.heavy_weight is None else {"heavy_weight": args.heavy_weight}),
                             **({} if args.probes is None else {"probes": args.probes}),
                             **({} if args.probe_weight is None else {"probe_weight": args.probe_weight}),
                             **({} if args.probe_distance is None else {"probe_distance": args.probe_distance}),
                             **({} if args.refine_rounds is None else {"refine_rounds": args.refine_rounds}),
                             **({} if args.recenter_rounds is None else {"recenter_rounds": args.recenter_rounds}))
    result, path, cached = cached_build(scene, settings, args.out, use_cache=not args.no_cache,
                                        workers=args.workers, scheduler=args.scheduler,
                                        progress=True if args.progress else None)
    stats = dict(result.stats)
    out = {"model": path, "states": stats.get("states"), "voxels_total": stats.get("voxels_total"),
           "tilts_simulated": 0 if cached else stats.get("tilts_simulated"),
           "fault_rate": stats.get("fault_rate"), "cached": cached, "shape": scene.shape.name,
           "friction": str(scene.friction), "noise": settings.noise, "contact": scene.settings.contact}
    if cached:
        stats["tilts_simulated_when_built"] = stats.pop("tilts_simulated", None)
    out.update({k: v for k, v in stats.items() if k not in out})
    return out
