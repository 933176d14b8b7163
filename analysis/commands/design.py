"""``kruskal design (--shape S | --kit KIT)``: tray variants ranked for a part or a kit.

Sweeps the compartment size (``--tray-mm``: the side of the square of the same area), its aspect
ratio (``--aspect`` x/y) and the tilt angle (``--tilt-deg``), each a number or a range ``LO..HI``
of ``--points`` values (``LO..HI:N`` for N of them). Every variant's models are built or taken
from the model cache; per variant the shortest common plan (proven, or with its proven lower
bound), the converging share of random sequences and the expected random tilts, each with its
interval (:mod:`analysis.design`); the Pareto front against tray area, the best variant, and the
best variant's plan replayed by direct simulation (``--check-trials``).
"""
from __future__ import annotations

import argparse
import sys

from analysis.commands import InputError
from analysis.commands._common import FRICTION_HELP, add_contact, add_seed, check_writable_file, parse_resolution


def add_arguments(parser: argparse.ArgumentParser) -> None:
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--shape", default=None, help="the part (default allen-key)")
    source.add_argument("--kit", default=None, metavar="KIT", help="a kit file (docs/kits.md)")
    parser.add_argument("--friction", default=None, help="with --shape: " + FRICTION_HELP)
    parser.add_argument("--tray-mm", default=None, metavar="LO..HI",
                        help="compartment size: the side (mm) of the square of the same area (default: 200 for "
                             "--shape, the kit's own sizes for --kit)")
    parser.add_argument("--aspect", default=None, metavar="LO..HI", help="aspect ratio x/y (default 1)")
    parser.add_argument("--tilt-deg", default=None, metavar="LO..HI", help="tilt angle (default 30, or the kit's)")
    parser.add_argument("--points", type=int, default=3, help="values per range (default 3; LO..HI:N overrides)")
    parser.add_argument("--target", default="cell", help="plan target: state | cell | probability:E (default cell)")
    parser.add_argument("--resolution", default="1,1", metavar="MM,DEG",
                        help="snapping tolerance of the variants' models (default 1,1)")
    parser.add_argument("--start-samples", type=int, default=2000,
                        help="uniform start poses of each model's first tilt (default 2000)")
    parser.add_argument("--count", type=int, default=500, help="random sequences per variant (default 500)")
    parser.add_argument("--length", type=int, default=50, help="their length (default 50)")
    parser.add_argument("--runs", type=int, default=300, help="Monte Carlo runs of the expected tilts (default 300)")
    parser.add_argument("--epsilon", type=float, default=1e-3, help="convergence threshold in bits (default 1e-3)")
    parser.add_argument("--node-budget", type=int, default=2_000_000,
                        help="images the plan search may compute per variant (default 2,000,000)")
    parser.add_argument("--check-trials", type=int, default=200,
                        help="direct-simulation trials of the best variant's replay (default 200; 0: none)")
    add_seed(parser)
    add_contact(parser)
    parser.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")
    parser.add_argument("--figure", metavar="FILE.png", default=None, help="the Pareto plot")
    parser.add_argument("--animation", metavar="FILE.gif", default=None, help="the best variant's replay, animated")


def _kit_of(args):
    from analysis.commands._common import parse_contact_arg
    from analysis.kit import load_kit, parse_kit

    parse_contact_arg(args.contact)
    if args.kit:
        if args.friction is not None:
            raise InputError("--friction is for --shape; a kit gives each compartment's friction")
        try:
            return load_kit(args.kit)
        except ValueError as exc:
            raise InputError(str(exc)) from None
    comp = {"name": args.shape or "allen-key", "size_mm": [200, 200], "shape": args.shape or "allen-key"}
    if args.friction is not None:
        comp["friction"] = args.friction
    try:
        return parse_kit({"compartments": [comp]})
    except ValueError as exc:
        raise InputError(str(exc).replace("kit compartment", "--shape")) from None


def _check(args) -> None:
    for name in ("points", "count", "length", "runs", "node_budget", "start_samples"):
        if getattr(args, name) < 1:
            raise InputError(f"--{name.replace('_', '-')} must be a positive integer")
    if args.check_trials < 0:
        raise InputError("--check-trials must be >= 0")
    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers must be a positive integer, got {args.workers}")
    if not args.epsilon >= 0:
        raise InputError(f"--epsilon must be >= 0, got {args.epsilon}")
    check_writable_file(args.figure, "--figure")
    check_writable_file(args.animation, "--animation")


def run(args: argparse.Namespace) -> dict:
    from analysis.design import Sweep, parse_sweep_range, run_design
    from kruskal_markov.sync.targets import parse_target
    from transition_builder.builder import BuildSettings

    _check(args)
    try:
        target = str(parse_target(args.target))
    except ValueError as exc:
        raise InputError(str(exc)) from None
    kit = _kit_of(args)
    try:
        sweep = Sweep(parse_sweep_range(args.tray_mm, args.points, "--tray-mm", None if args.kit else 200.0),
                      parse_sweep_range(args.aspect, args.points, "--aspect", 1.0),
                      parse_sweep_range(args.tilt_deg, args.points, "--tilt-deg", kit.tilt_deg))
        mm, deg = parse_resolution(args.resolution)
        settings = BuildSettings(tol_mm=mm, tol_deg=deg, recenter_rounds=1, start_samples=args.start_samples)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    if args.tray_mm is None and args.aspect is not None and args.kit:
        raise InputError("--aspect with --kit needs --tray-mm (the kit's own sizes are kept otherwise)")
    from analysis.commands._kit import scenes_of, setting_changes

    scenes_of(kit, args)            # bad --contact/--engine values: one line before any build
    res = run_design(kit, sweep, settings, contact=args.contact, workers=args.workers,
                     setting_changes=setting_changes(args),
                     log=lambda text: sys.stderr.write(f"kruskal design: {text}\n"), target=target, seed=args.seed,
                     count=args.count, length=args.length, runs=args.runs, epsilon=args.epsilon,
                     node_budget=args.node_budget)
    if not res["variants"]:
        raise InputError("no variant of the sweep fits the parts: " + res["skipped"][0]["reason"])
    scenes = res.pop("_scenes")
    out = {**res, "target": target, "seed": args.seed, "names": kit.names,
           "source": args.kit or (args.shape or "allen-key"), "resolution": [mm, deg],
           "reference": _reference(res["variants"], kit, args)}
    best = res["variants"][res["best"]]
    if args.check_trials and best["word"]:
        from analysis.kit_replay import replay_plan

        replay = replay_plan(scenes[res["best"]], kit.names, best["word"], best["final_cells"],
                             best["success_probabilities"], args.check_trials, seed=args.seed, workers=args.workers)
        results = replay.pop("results")
        out["replay"] = replay
        if args.animation:
            from analysis.kit_figures import animate_kit

            out["animation"] = animate_kit(results, scenes[res["best"]], kit.names, args.animation)
    if args.figure:
        from analysis.kit_figures import pareto_figure

        out["figure"] = pareto_figure(out, args.figure)
    return out


def _reference(rows, kit, args):
    """The index of the paper's tray among the variants (200 x 200 mm at 30 degrees, a single part),
    with how much the best variant shortens its plan; None when the sweep does not hold it."""
    if args.kit:
        return None
    idx = next((i for i, r in enumerate(rows) if r["tray_mm"] == [200.0, 200.0] and r["tilt_deg"] == 30.0), None)
    if idx is None:
        return None
    ref, best = rows[idx], rows[best_index(rows)]
    shorter = None if ref["plan_length"] is None or best["plan_length"] is None else \
        ref["plan_length"] - best["plan_length"]
    return {"index": idx, "plan_length": ref["plan_length"], "shortened_by": shorter}


def best_index(rows) -> int:
    from analysis.design import best_variant

    return best_variant(rows)


def format_text(result: dict) -> str:
    """The variants as a table, best and Pareto marked, and the replay."""
    def f(x, spec=".3g"):
        return "-" if x is None else format(x, spec)

    lines = [f"design for {result['source']} (target {result['target']}, seed {result['seed']})",
             "  #  tray mm        tilt  area cm2  plan  bound  converging (95%)        expected tilts (95%)"]
    for i, r in enumerate(result["variants"]):
        mark = ("*" if i == result["best"] else " ") + ("P" if i in result["pareto"] else " ")
        tray = "kit's own" if r["tray_mm"] is None else f"{r['tray_mm'][0]:g} x {r['tray_mm'][1]:g}"
        plan = "none" if r["plan_length"] is None else f"{r['plan_length']}{'' if r['exact'] else '*'}"
        lo, hi = r["converging_share_ci"]
        tl, th = r["expected_tilts_ci"]
        tilts = (f"{f(r['expected_tilts'], '.1f')} [{f(tl, '.1f')}, {f(th, '.1f')}]" if r["expected_tilts"] is not None
                 else f">= {f(r['expected_tilts_lower'], '.1f')} (censored)")
        lines.append(f"{mark}{i:2d}  {tray:<13} {r['tilt_deg']:5.1f}  {r['area_mm2'] / 100:8.0f}  {plan:>4}  "
                     f"{f(r['lower_bound'], 'd'):>5}  {r['converging_share']:.2f} [{lo:.2f}, {hi:.2f}]  {tilts}")
    lines.append("* best, P Pareto front (area, plan length, expected tilts); plan* not proven shortest")
    rep = result.get("replay")
    if rep:
        for c in rep["compartments"]:
            lines.append(f"replay {c['name']}: {c['share']:.3f} in cell {c['predicted_cell']} (95% "
                         f"{c['share_ci95'][0]:.3f}-{c['share_ci95'][1]:.3f}); model {c['model_success']:.3f}")
    for k in ("figure", "animation"):
        if result.get(k):
            lines.append(f"{k}: {result[k]}")
    lines.append(f"seconds: {result['seconds']:.1f}")
    return "\n".join(lines)
