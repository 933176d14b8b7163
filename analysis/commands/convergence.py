"""``kruskal convergence``: expected length of a random synchronizing sequence.

Actions are drawn independently (uniform, or ``--weights``) and applied to the start set (all
states of a deterministic automaton, else the initial support of the support automaton) until it
is one state. Exact (absorbing chain on reachable subsets, within ``--max-subsets``), Monte Carlo
with a 95% confidence interval, and pair-chain lower/upper bounds, side by side. For stochastic
models ``--epsilon`` adds the Monte Carlo number of random tilts until predicted entropy <= E.
"""
from __future__ import annotations

import argparse

from analysis.commands import InputError
from analysis.commands._common import (
    add_interval_options,
    add_model_source,
    add_seed,
    interval_settings,
    load_model_source,
    parse_weights,
    positive_float,
)
from analysis.commands._kit import add_kit_options
from analysis.commands._range import add_range_options, is_range, run_over_range


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_model_source(parser)
    add_seed(parser)
    parser.add_argument("--weights", default=None,
                        help="action probabilities, comma-separated in action order or NAME=W pairs "
                             "(normalised; default uniform)")
    parser.add_argument("--threshold", type=float, default=0.0,
                        help="support automaton: keep transition probabilities >= T (default 0)")
    parser.add_argument("--start", choices=("auto", "all", "initial"), default="auto",
                        help="start set (default auto: all states if deterministic, else initial support)")
    parser.add_argument("--runs", type=int, default=2000, help="Monte Carlo runs (default 2000)")
    parser.add_argument("--max-steps", type=int, default=None,
                        help="Monte Carlo: letters per run before a run is censored (default 100000, fewer on "
                             "automata over 6,400 states: runs x letters x states/64 <= 2e10 word operations, "
                             "about 20 s; the output's mc_max_steps says what was used)")
    parser.add_argument("--max-subsets", type=int, default=200_000,
                        help="exact answer only if at most this many subsets are reachable (default 200000)")
    parser.add_argument("--pair-time-budget", type=positive_float, default=45.0, metavar="S",
                        help="seconds for the pair-chain upper bound iteration (default 45)")
    parser.add_argument("--mc-time-budget", type=positive_float, default=None, metavar="S",
                        help="seconds for the Monte Carlo runs; runs still going are censored, which makes "
                             "the result depend on the machine's speed (default: none, so the same seed "
                             "gives the same output; --max-steps still censors)")
    parser.add_argument("--memory-budget-mb", type=positive_float, default=2048.0, metavar="MB",
                        help="memory for the quadratic pair computations: the pair-graph check runs within half of it, "
                             "the pair-chain bounds within all of it (default 2048)")
    parser.add_argument("--epsilon", type=float, default=None,
                        help="stochastic models: also Monte Carlo of tilts until entropy <= E bits")
    add_interval_options(parser)
    add_range_options(parser)
    add_kit_options(parser, workers=True)


def run(args: argparse.Namespace) -> dict:
    if is_range(args):
        return run_over_range(args, run)
    from kruskal_markov.convergence import (
        expected_sync_length,
        letter_weights,
        monte_carlo_entropy_tilts,
    )
    from kruskal_markov.sync import start_set, support_automaton

    if args.runs < 2:
        raise InputError("--runs must be >= 2")
    if args.pair_time_budget <= 0 or (args.mc_time_budget is not None and args.mc_time_budget <= 0):
        raise InputError("--pair-time-budget and --mc-time-budget must be positive")
    if (args.max_steps is not None and args.max_steps < 1) or args.max_subsets < 1:
        raise InputError("--max-steps and --max-subsets must be >= 1")
    if not 0.0 <= args.threshold <= 1.0:
        raise InputError(f"--threshold must lie in [0, 1], got {args.threshold}")
    if getattr(args, "kit", None):
        from analysis.commands import _kit

        return _kit.convergence(args)
    model = load_model_source(args)
    weights = parse_weights(args.weights, model.actions)
    w = letter_weights(model.n_actions, weights)
    aut = support_automaton(model, args.threshold)
    whole = {"auto": None, "all": True, "initial": False}[args.start]
    if whole is None:
        whole = model.is_deterministic()
    start = start_set(model, whole)
    res = expected_sync_length(aut, start, w, seed=args.seed, runs=args.runs,
                               max_subsets=args.max_subsets, max_steps=args.max_steps,
                               pair_time_budget=args.pair_time_budget, mc_time_budget=args.mc_time_budget,
                               memory_budget_mb=args.memory_budget_mb)
    keys = ("exact", "monte_carlo", "ci95", "monte_carlo_lower", "pair_lower", "pair_upper")
    out = {"expected_length": {k: res[k] for k in keys}}
    out.update({k: v for k, v in res.items() if k not in keys})
    out.update({"states": model.n_states, "start_states": len(start),
                "deterministic": aut.deterministic, "mass_dropped": aut.mass_dropped,
                "weights": [float(x) for x in w]})
    if args.epsilon is not None:
        if not args.epsilon >= 0:
            raise InputError(f"--epsilon must be >= 0, got {args.epsilon}")
        out["entropy_tilts"] = monte_carlo_entropy_tilts(model, args.epsilon, w, runs=min(args.runs, 1000),
                                                         seed=args.seed, max_steps=min(res["mc_max_steps"], 2000))
        out["epsilon"] = args.epsilon
        from kruskal_markov.answers import answer_intervals
        ans = answer_intervals(model, seed=args.seed, count=min(args.runs, 2000), length=50, epsilon=args.epsilon,
                               runs=min(args.runs, 1000), max_steps=min(res["mc_max_steps"], 2000), weights=w,
                               entropy_tilts=out["entropy_tilts"], **interval_settings(args))
        out["entropy_tilts"]["intervals"] = ans["random_tilts"]
        out["intervals"] = {"random_tilts": ans["random_tilts"], "settings": ans["settings"]}
    return out


def format_text(result: dict) -> str:
    """Human-readable summary (``--json`` gives everything)."""
    e = result["expected_length"]

    def f(x):
        return "n/a" if x is None else f"{x:.4g}"

    lines = []
    if result.get("infinite"):
        lines.append("expected length: infinite (some start states are never merged)")
    lines += [f"exact:       {f(e['exact'])}",
              (f"monte carlo: at least {f(e['monte_carlo_lower'])}  ({result['mc_censored']} of "
               f"{result['mc_runs']} runs censored, so no mean)" if result.get("mc_censored") else
               f"monte carlo: {f(e['monte_carlo'])}  95% CI [{f(e['ci95'][0])}, {f(e['ci95'][1])}]"),
              f"pair bounds: [{f(e['pair_lower'])}, {f(e['pair_upper'])}]"
              + (f"  ({result['pair_bounds']})" if result.get("pair_bounds") else "")]
    if "entropy_tilts" in result:
        t = result["entropy_tilts"]
        lines.append(f"tilts until entropy <= {result['epsilon']}: {f(t['mean'])}  95% CI "
                     f"[{f(t['ci95'][0])}, {f(t['ci95'][1])}]")
    lines.append(f"seconds: {result['seconds']:.3f}")
    return "\n".join(lines)
