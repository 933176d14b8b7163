"""``kruskal ensemble``: K random sequences through a model, the paper's Fig. 3 statistics.

Per step the mean and the 25% / 75% quantiles of the report-grid entropy (on the states for an
automaton without partition); per sequence the first step with entropy <= epsilon; the best
sequence (reaches epsilon first; ties: lowest final entropy).
"""
from __future__ import annotations

import argparse

from analysis.commands._common import (
    add_interval_options,
    add_model_source,
    add_seed,
    check_positive,
    interval_settings,
    load_model_source,
    parse_weights,
)
from analysis.commands._kit import add_kit_options
from analysis.commands._range import add_range_options, is_range, run_over_range


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_model_source(parser)
    parser.add_argument("--count", type=int, required=True, help="number of random sequences K")
    parser.add_argument("--length", type=int, required=True, help="length N of every sequence")
    add_seed(parser)
    parser.add_argument("--epsilon", type=float, default=1e-9,
                        help="convergence threshold in bits (default 1e-9)")
    parser.add_argument("--weights", default=None, metavar="w1,w2,...",
                        help="action probabilities (up to a factor): comma-separated in action order or "
                             "NAME=W pairs (default uniform)")
    parser.add_argument("--threads", type=int, default=None, help="Numba threads (default: all cores)")
    add_interval_options(parser)
    add_range_options(parser)
    add_kit_options(parser, workers=True)


def run(args: argparse.Namespace) -> dict:
    from kruskal_markov.ensemble import run_ensemble

    if getattr(args, "kit", None):
        from analysis.commands import _kit

        return _kit.ensemble(args)
    if is_range(args):
        return run_over_range(args, run)
    check_positive(args.count, "--count")
    check_positive(args.length, "--length")
    if args.threads is not None:
        check_positive(args.threads, "--threads")
    model = load_model_source(args)
    weights = parse_weights(args.weights, model.actions)
    res = run_ensemble(model, args.count, args.length, seed=args.seed, epsilon=args.epsilon,
                       weights=weights, threads=args.threads)
    steps = [None if s < 0 else int(s) for s in res.convergence_steps.tolist()]
    from kruskal_markov.answers import answer_intervals
    intervals = answer_intervals(model, seed=args.seed, count=args.count, length=args.length, epsilon=args.epsilon,
                                 weights=weights, ensemble=res, threads=args.threads, **interval_settings(args))
    from kruskal_markov.closed_classes import analyze_structure

    structure = analyze_structure(model)
    return {
        "mean": res.mean.tolist(),
        "q25": res.q25.tolist(),
        "q75": res.q75.tolist(),
        "converged": res.converged,
        "convergence_steps": steps,
        "best_sequence": [model.actions[a] for a in res.best_sequence],
        "best_entropy_bits": res.best_entropy.tolist(),
        "mean_states": res.mean_states.tolist(),
        "entropy_on": "partition" if model.partition is not None else "states",
        "count": args.count,
        "length": args.length,
        "seed": args.seed,
        "epsilon": res.epsilon,
        "max_mass_drift": res.max_mass_drift,
        "zero_entropy_excluded": (structure.zero_cell_entropy_excluded if model.partition is not None
                                  else structure.zero_entropy_excluded),
        "structure": structure.message,
        "intervals": intervals,
    }


def format_intervals(intervals: dict) -> list[str]:
    """One line per answer: the value, its Monte Carlo interval and its model interval."""
    def rng(x):
        return "-" if x is None or None in x else f"[{x[0]:.4g}, {x[1]:.4g}]"
    out = ["answer                 value     MC 95%                model 90% (posterior + structure)"]
    for k, v in intervals.items():
        if k == "settings" or v.get("value") is None:
            continue
        out.append(f"{k:20s}  {v['value']:8.4g}  {rng(v['mc_ci95']):20s}  {rng(v['model_ci90'])}")
    note = intervals.get("settings", {}).get("structural_note")
    if note:
        out.append(f"structural term: {note}")
    return out


def format_text(result: dict) -> str:
    """Human summary: the per-step statistics and the best sequence."""
    if result.get("kit"):
        from analysis.commands._kit import format_text as kit_text

        return kit_text(result)
    lines = [f"{result['count']} random sequences of length {result['length']} (seed {result['seed']}), "
             f"entropy on {result['entropy_on']}",
             "step      mean       q25       q75"]
    for t, (m, a, b) in enumerate(zip(result["mean"], result["q25"], result["q75"])):
        lines.append(f"{t:4d}  {m:8.4f}  {a:8.4f}  {b:8.4f}")
    lines.append(f"converged (entropy <= {result['epsilon']:g}): {result['converged']} of {result['count']}")
    lines.append(f"best sequence: {','.join(result['best_sequence'])}")
    lines += format_intervals(result["intervals"])
    lines.append(f"structure: {result['structure']}")
    lines.append(f"seconds: {result['seconds']:.2f}")
    return "\n".join(lines)
