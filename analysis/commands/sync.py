"""``kruskal sync``: the shortest synchronizing word (optimal sensorless plan) of a model or automaton:
the plan target ``state`` (``kruskal plan --target state``; see docs/plans.md).

Deterministic automata are synchronized from the whole state set (a reset word); stochastic
models through their support automaton (entries ``>= --threshold``) from the support of the
initial distribution. With ``--epsilon E`` the command instead searches the shortest word whose
predicted entropy (report grid, or states) from the initial distribution is ``<= E``.
"""
from __future__ import annotations

import argparse

from analysis.commands import InputError
from analysis.commands._common import add_model_source, load_model_source, positive_float


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_model_source(parser)
    parser.add_argument("--threshold", type=float, default=0.0,
                        help="support automaton: keep transition probabilities >= T (default 0: all "
                             "non-zero entries)")
    parser.add_argument("--epsilon", type=float, default=None,
                        help="instead: shortest word whose predicted entropy is <= E bits")
    parser.add_argument("--start", choices=("auto", "all", "initial"), default="auto",
                        help="start set: all states, the support of the initial distribution, or auto "
                             "(all states for deterministic automata, else the initial support)")
    parser.add_argument("--time-budget", type=positive_float, default=60.0, metavar="S",
                        help="seconds for the exact search before falling back to greedy (default 60)")
    parser.add_argument("--node-budget", type=int, default=None, metavar="N",
                        help="subsets the exact search may generate (default: no limit; the same budget "
                             "gives the same answer on any machine)")
    parser.add_argument("--memory-budget-mb", type=positive_float, default=None, metavar="MB",
                        help="memory of the search's tables (default 2048 for the subset search, 1024 for "
                             "the plan search)")
    parser.add_argument("--max-length", type=int, default=30,
                        help="--epsilon search: longest word tried (default 30)")


def run(args: argparse.Namespace) -> dict:
    from kruskal_markov.sync import epsilon_synchronizing_word, shortest_word, start_set, support_automaton

    if args.time_budget <= 0 or (args.memory_budget_mb is not None and args.memory_budget_mb <= 0):
        raise InputError("--time-budget and --memory-budget-mb must be positive")
    if not 0.0 <= args.threshold <= 1.0:
        raise InputError(f"--threshold must lie in [0, 1], got {args.threshold}")
    model = load_model_source(args)
    if args.epsilon is not None:
        if not args.epsilon >= 0:
            raise InputError(f"--epsilon must be >= 0, got {args.epsilon}")
        if args.max_length < 0:
            raise InputError("--max-length must be >= 0")
        res = epsilon_synchronizing_word(model, args.epsilon, max_length=args.max_length,
                                         time_budget=args.time_budget)
        out = res.as_dict(model.actions)
        out["epsilon"] = args.epsilon
        out["states"] = model.n_states
        return out
    if args.node_budget is not None and args.node_budget < 1:
        raise InputError("--node-budget must be a positive integer")
    aut = support_automaton(model, args.threshold)
    whole = {"auto": None, "all": True, "initial": False}[args.start]
    start = start_set(model, model.is_deterministic() if whole is None else whole)
    res = shortest_word(model, "state", start=args.start, threshold=args.threshold, time_budget=args.time_budget,
                        node_budget=args.node_budget, memory_budget_mb=args.memory_budget_mb)
    out = res.sync_dict()
    out["target"] = "state"     # kruskal plan --target state asks the same question
    out.update({"states": model.n_states, "start_states": len(start),
                "deterministic": aut.deterministic, "threshold": args.threshold,
                "mass_dropped": aut.mass_dropped, "mass_dropped_mean": aut.mass_dropped_mean})
    return out


def format_text(result: dict) -> str:
    """Human-readable summary (``--json`` gives everything)."""
    lines = []
    if result.get("word") is None:
        if result.get("exact"):
            w = result.get("witness") or {}
            lines.append(f"no synchronizing word exists: {w.get('reason', w)}")
        else:
            lines.append("no synchronizing word found within the budgets")
    else:
        word = ",".join(result["word"]) if result["word"] else "(empty word)"
        kind = "shortest (proven)" if result["exact"] else "not proven shortest"
        lines.append(f"word: {word}")
        lines.append(f"length: {result['length']}  [{kind}; method {result['method']}]")
    if result.get("lower_bound") is not None and not result.get("exact"):
        lines.append(f"lower bound: {result['lower_bound']}")
    if result.get("mass_dropped"):
        lines.append(f"probability mass dropped by the threshold: {result['mass_dropped']:.3g} (largest row)")
    for note in result.get("notes") or []:
        lines.append(f"note: {note}")
    lines.append(f"seconds: {result['seconds']:.3f}")
    return "\n".join(lines)
