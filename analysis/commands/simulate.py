"""``kruskal simulate``: direct Monte Carlo through a tilt sequence in the physics engine.

M uniform random collision-free start poses (from ``--seed``), each driven through the sequence
(with optional process noise before every tilt, ``--noise``), in this process, local worker
processes (``--workers``) or on a Dask cluster (``--scheduler``); the report-grid entropy after
every tilt, fault counts, and optionally every pose (``--poses``).
"""
from __future__ import annotations

import argparse
import sys

from analysis.commands._common import (
    FRICTION_HELP,
    add_contact,
    add_seed,
    add_tilt_time,
    check_positive,
    check_writable_file,
    parse_sequence,
    scene_from_args,
    sequence_rng,
)
from analysis.commands._kit import add_kit_options


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--shape", default=None,
                        help="allen-key | triangle:SEED | rectangle:WxH | polygon:x1,y1;x2,y2;... | FILE.json "
                             "(default allen-key)")
    parser.add_argument("--sequence", required=True,
                        help='comma-separated actions, e.g. "NE,S,W", or random:N (drawn from --seed)')
    parser.add_argument("--trials", type=int, default=1000, help="number of trials M (default 1000)")
    add_seed(parser)
    parser.add_argument("--grid", default="4x4x4", help="report grid AxBxG (default 4x4x4)")
    parser.add_argument("--theta-offset", type=float, default=None, metavar="RAD",
                        help="shift of the theta bin edges in radians (default half a bin: bins centred "
                             "on the tray axes; 0 gives the paper's edges)")
    parser.add_argument("--friction", default=None, help=FRICTION_HELP)
    parser.add_argument("--tilt-deg", type=float, default=None, help="tilt angle in degrees (default 30)")
    add_tilt_time(parser)
    parser.add_argument("--scene", metavar="FILE",
                        help="a scene file (.json/.toml); --shape/--friction/--tilt-deg then override it "
                             "only when given explicitly")
    add_contact(parser)
    parser.add_argument("--poses", metavar="FILE.csv",
                        help="write every trial's pose after every tilt "
                             "(columns trial,step,x_mm,y_mm,theta_rad,status)")
    parser.add_argument("--noise", default="none", metavar="SPEC",
                        help="process noise before every tilt: none or pose:SIGMA_MM,SIGMA_DEG "
                             "(default none; pose:0,0 is none)")
    parser.add_argument("--workers", type=int, default=None,
                        help="worker processes (default: all cores; 1 = in this process)")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="run on a Dask cluster, e.g. tcp://host:8786 (needs kruskal[distributed]; "
                             "--workers is then not used)")
    add_kit_options(parser, models=False)
    parser.add_argument("--animation", metavar="FILE.gif", default=None,
                        help="with --kit: an animated GIF of every compartment's trials after every tilt")
    parser.add_argument("--progress", action="store_true",
                        help="show a progress bar on standard error (default: only on a terminal)")


def run(args: argparse.Namespace) -> dict:
    from analysis.montecarlo import run_direct, write_poses_csv
    from transition_builder.noise import parse_noise

    if args.kit:
        from analysis.commands import _kit

        return _kit.simulate(args)
    if args.animation:
        from analysis.commands import InputError

        raise InputError("--animation needs --kit")
    noise = parse_noise(args.noise)
    check_positive(args.trials, "--trials")
    if args.workers is not None:
        check_positive(args.workers, "--workers")
    check_writable_file(args.poses, "--poses")
    scene = scene_from_args(args)
    rng = sequence_rng(args.seed)
    sequence = parse_sequence(args.sequence, scene.actions, rng)
    progress = True if args.progress else None  # None: a bar only when stderr is a terminal
    result = run_direct(scene, sequence, args.trials, seed=args.seed, workers=args.workers,
                        progress=progress, grid=args.grid, theta_offset=args.theta_offset, noise=noise,
                        scheduler=args.scheduler)
    out = result.to_dict()
    out["shape"] = scene.shape.name
    out["friction"] = str(scene.friction)
    out["tilt_time_s"] = scene.tilt_time_s
    out["contact"] = scene.settings.contact
    out["engine"] = scene.settings.engine
    out["scene_hash"] = scene.content_hash()
    if args.poses is not None:
        out["poses"] = write_poses_csv(args.poses, result)
    return out


def format_text(result: dict) -> str:
    """A short human summary: the entropy curve and the faults."""
    if result.get("kit"):
        from analysis.commands._kit import format_text as kit_text

        return kit_text(result)
    lines = [(f"shape {result['shape']}  friction {result['friction']}  trials {result['trials']}  "
              f"tilts {result['tilts']}  grid {result['grid']}  seed {result['seed']}  "
              f"noise {result.get('noise', 'none')}"),
             "step  action  entropy_bits  occupied  surviving"]
    seq = ["start"] + list(result["sequence"])
    for k, h in enumerate(result["entropy_bits"]):
        lines.append(f"{k:4d}  {seq[k]:>6}  {h:12.4f}  {result['occupied_voxels'][k]:8d}  "
                     f"{result['surviving'][k]:9d}")
    lines.append("faults: " + ", ".join(f"{k} {v}" for k, v in result["faults"].items()))
    if result.get("poses"):
        lines.append(f"poses: {result['poses']}")
    lines.append(f"seconds: {result['seconds']:.2f}")
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover
    sys.exit("run as: kruskal simulate ...")
