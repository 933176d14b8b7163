"""``kruskal rank --shapes S1 S2 ...``: orientability ranking of parts from their built models.

Each shape's model is built (or taken from the cache) with ``--resolution`` and the metrics of
:mod:`analysis.orientability` are computed from it: the shortest synchronizing word, the expected
number of random tilts to converge, the mean entropy after 10 and 50 random tilts and the share of
random 50-tilt sequences that converge. ``--check-trials M`` also simulates one random 50-tilt
sequence per shape directly and reports the rank correlation of model and simulation.
"""
from __future__ import annotations

import argparse

from analysis.commands import InputError
from analysis.commands._common import (
    FRICTION_HELP,
    add_contact,
    add_seed,
    add_tilt_time,
    check_writable_file,
    parse_resolution,
    positive_float,
)
from analysis.commands._range import is_range, rank_over_range
from analysis.orientability import random_tilts_text


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--shapes", nargs="+", required=True, metavar="S", help="shape specs (as --shape)")
    parser.add_argument("--friction", default=None,
                        help=FRICTION_HELP + "; or a range LO..HI (ranks across it)")
    parser.add_argument("--tilt-deg", type=float, default=None, help="tilt angle in degrees (default 30)")
    add_tilt_time(parser)
    parser.add_argument("--scene", metavar="FILE", help="a scene file (.json/.toml): tray, friction, simulator; "
                        "each shape replaces its part")
    add_contact(parser)
    parser.add_argument("--support-points", type=int, default=None, help=argparse.SUPPRESS)   # old: --contact
    parser.add_argument("--resolution", default="0.5,0.5", metavar="MM,DEG",
                        help="snapping tolerance of the models (default 0.5,0.5: cheaper than build's default)")
    parser.add_argument("--recenter-rounds", type=int, default=1, help="recentring rounds (default 1)")
    parser.add_argument("--start-samples", type=int, default=5000,
                        help="uniform start poses of each model's first tilt (default 5000)")
    parser.add_argument("--count", type=int, default=2000, help="random 50-tilt sequences per shape (default 2000)")
    parser.add_argument("--runs", type=int, default=500, help="Monte Carlo runs of the expected lengths (default 500)")
    parser.add_argument("--sync-time-budget", type=positive_float, default=20.0, metavar="S",
                        help="seconds of exact shortest-word search per shape (default 20)")
    parser.add_argument("--check-trials", type=int, default=0, metavar="M",
                        help="also simulate one random 50-tilt sequence per shape with M trials (default 0: off)")
    parser.add_argument("--markdown", metavar="FILE.md", help="also write the ranking as a Markdown table")
    add_seed(parser)
    parser.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")
    parser.add_argument("--range-points", type=int, default=3,
                        help="with --friction LO..HI: rankings across the range (default 3)")


def run(args: argparse.Namespace) -> dict:
    from analysis.experiments.context import direct_summary
    from analysis.orientability import part_metrics, rank_parts
    from analysis.sequences import random_sequences_for
    from kruskal_markov.entropy import entropy_trajectory
    from transition_builder.cache import cached_build

    if is_range(args):
        return rank_over_range(args, run)
    if args.count < 1 or args.runs < 2 or args.check_trials < 0 or args.recenter_rounds < 0:
        raise InputError("--count >= 1, --runs >= 2, --check-trials >= 0 and --recenter-rounds >= 0 required")
    if not args.sync_time_budget > 0:
        raise InputError("--sync-time-budget must be positive")
    scenes, settings = scenes_and_settings(args)
    check_writable_file(args.markdown, "--markdown")
    mm, deg = settings.tol_mm, settings.tol_deg
    metrics, checks, models = {}, {}, {}
    first = scenes[args.shapes[0]]
    seq = random_sequences_for(len(first.actions), 1, 50, args.seed)[0]
    for spec, scene in scenes.items():
        result, path, cached = cached_build(scene, settings, workers=args.workers)
        models[spec] = {"model": path, "cached": cached, "states": result.model.n_states}
        metrics[spec] = part_metrics(result.model, seed=args.seed, count=args.count, runs=args.runs,
                                     sync_time_budget=args.sync_time_budget)
        if args.check_trials:
            names = [result.model.actions[a] for a in seq]
            direct = direct_summary(scene, names, args.check_trials, args.seed, args.workers)
            checks[spec] = {"model": float(entropy_trajectory(result.model, names).entropy_bits[1:].mean()),
                            "direct": float(sum(direct["entropy_bits"][1:]) / 50)}
    ranking = rank_parts(metrics)
    for row in ranking:
        row.update(models[row["shape"]])
    out = {"contact": next(iter(scenes.values())).settings.contact,
           "engine": next(iter(scenes.values())).settings.engine, "ranking": ranking, "order": [r["shape"] for r in ranking],
           "resolution": [mm, deg], "seed": args.seed}
    if checks:
        out["check"] = {"sequence": [first.actions[a] for a in seq], "trials": args.check_trials,
                        "mean_entropy": checks, "on": "mean entropy over one random 50-tilt sequence"}
        if len(checks) >= 3:
            from scipy.stats import spearmanr

            rho = spearmanr([c["model"] for c in checks.values()], [c["direct"] for c in checks.values()])[0]
            out["check"]["spearman"] = float(rho)
    if args.markdown:
        from kruskal_markov.model import atomic_write_text

        atomic_write_text(args.markdown, markdown_table(out, _command_line(args)))
        out["markdown"] = args.markdown
    return out


def scenes_and_settings(args: argparse.Namespace):
    """The scene of every ``--shapes`` entry and the build settings of ``rank`` (every shape checked
    before the first, long, build); a build with these hits ``rank``'s cache (benchmarks/bench_ranges.py)."""
    from analysis.commands.build import scene_for
    from transition_builder.builder import BuildSettings

    if len(set(args.shapes)) != len(args.shapes):
        raise InputError("--shapes lists a shape twice")
    mm, deg = parse_resolution(args.resolution)
    scenes = {}
    for spec in args.shapes:
        try:
            scenes[spec] = scene_for(argparse.Namespace(**{**vars(args), "shape": spec}))
        except ValueError as exc:
            raise InputError(f"--shapes {spec!r}: {exc}") from None
    try:
        settings = BuildSettings(tol_mm=mm, tol_deg=deg, recenter_rounds=args.recenter_rounds, seed=args.seed,
                                 start_samples=args.start_samples)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    return scenes, settings


def _command_line(args) -> str:
    """The ``kruskal rank`` command that reproduces ``args`` (every option that changes results)."""
    import shlex

    parts = ["kruskal rank --shapes", " ".join(shlex.quote(s) for s in args.shapes)]
    for opt in ("friction", "tilt_deg", "tilt_time", "scene", "contact", "engine", "support_points", "resolution",
                "recenter_rounds", "start_samples", "count", "runs", "sync_time_budget", "check_trials", "seed"):
        value = getattr(args, opt, None)
        if value is not None:
            parts.append(f"--{opt.replace('_', '-')} {shlex.quote(str(value))}")
    return " ".join(parts)


def _word_text(row: dict, none: str, not_found: str) -> str:
    """The shortest-word column: its length (``*`` if greedy), ``none`` when no word exists (proven),
    ``not_found`` when the search ended without a word or a proof that there is none."""
    if row["sync_length"] is None:
        return none if row["sync_exact"] else not_found
    return f"{row['sync_length']}{'' if row['sync_exact'] else '*'}"


def markdown_table(result: dict, command: str = "kruskal rank") -> str:
    """The ranking as a Markdown table (best first) with the check, if any; ``command`` is the
    command line that made it."""
    def f(x, spec):
        return "-" if x is None else format(x, spec)

    mm, deg = result["resolution"]
    lines = ["# Orientability ranking", "",
             f"`{command}` (models at {mm:g} mm / {deg:g} degrees). "
             "Metrics from each part's model (docs/commands.md): the shortest synchronizing word (plan target "
             "`state`; * = greedy, "
             "not proven shortest; none = proven not to exist; not found = neither a word nor a proof within "
             "the budget), the expected number of random tilts until the predicted entropy is "
             "<= 1e-3 bits (censored: random runs that never got there in 1,000 tilts; with any, only a lower "
             "bound is known, shown as >= x), the mean entropy "
             "after 10 and 50 random tilts, and the share of random 50-tilt sequences that converge. Ranked by: "
             "a synchronizing word exists, then the expected random tilts, then the shortest word, then the "
             "converging share, then the entropies; `decided by` names the metric that separates a part from "
             "the next.", "",
             "| rank | part | states | shortest word | expected random tilts (censored) | H after 10 / 50 | "
             "converging | decided by |", "|---|---|---|---|---|---|---|---|"]
    for r in result["ranking"]:
        word = _word_text(r, "none", "not found")
        lines.append(f"| {r['rank']} | {r['shape']} | {r['states']:,} | {word} | {random_tilts_text(r)} "
                     f"({r['random_tilts_censored']}) | {r['mean_entropy_10']:.2f} / {r['mean_entropy_50']:.2f} | "
                     f"{100 * r['converging_share_50']:.0f}% | {r['decided_by'] or '-'} |")
    c = result.get("check")
    if c:
        lines += ["", f"Check against direct simulation ({c['on']}, M = {c['trials']}): "
                      + ", ".join(f"{k} model {v['model']:.2f} / direct {v['direct']:.2f} bits"
                                  for k, v in c["mean_entropy"].items())
                      + (f"; Spearman rank correlation {c['spearman']:.2f}." if "spearman" in c else ".")]
    return "\n".join(lines) + "\n"


def format_text(result: dict) -> str:
    """One line per shape, best first."""
    lines = ["rank  shape                      sync  random tilts  H10    H50    converging  decided by"]
    for r in result["ranking"]:
        rt = random_tilts_text(r)
        sl = _word_text(r, "none", "?")
        lines.append(f"{r['rank']:4d}  {r['shape']:<26} {sl:>5} {rt:>13}  {r['mean_entropy_10']:.2f}   "
                     f"{r['mean_entropy_50']:.2f}   {100 * r['converging_share_50']:5.1f}%     {r['decided_by'] or '-'}")
    if "check" in result and "spearman" in result["check"]:
        lines.append(f"model vs direct simulation (Spearman): {result['check']['spearman']:.2f}")
    lines.append(f"seconds: {result['seconds']:.1f}")
    return "\n".join(lines)
