"""``kruskal plan``: the shortest tilt sequence that orients the part, for a target.

Targets (one meaning everywhere, :mod:`kruskal_markov.sync.targets`): ``state`` (every start state
to one model state, today's ``sync``), ``cell`` (every start state into one report cell: the model's
partition, or ``--grid AxBxG`` on a built model's state poses), ``probability:E`` (at least ``1 - E``
of the initial distribution in one report cell). Several ``--model``: one word that does it under
every model (a robust plan). The search is exact within its budgets (``exact`` only with a proof,
``lower_bound`` always proven); see docs/plans.md.
"""
from __future__ import annotations

import argparse

import numpy as np

from analysis.commands import InputError
from analysis.commands._common import positive_float
from analysis.commands._kit import add_kit_options
from analysis.commands._range import add_range_options, is_range, plan_over_range


def add_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--model", metavar="PATH", action="append",
                       help="a built transition model (.npz); repeat for a robust plan over several models")
    group.add_argument("--automaton", metavar="FILE", help="an automaton in the JSON format of docs/commands.md")
    parser.add_argument("--target", default="cell",
                        help="state | cell | probability:E (default cell)")
    parser.add_argument("--grid", default=None, metavar="AxBxG",
                        help="cells of a report grid AxBxG on the models' state poses instead of the "
                             "models' partition (built models only)")
    parser.add_argument("--time-budget", type=positive_float, default=None, metavar="S",
                        help="seconds for the search (default: none; the node budget applies)")
    parser.add_argument("--node-budget", type=int, default=20_000_000, metavar="N",
                        help="images the search may compute (default 20,000,000); the same budget gives "
                             "the same answer on any machine")
    parser.add_argument("--memory-budget-mb", type=positive_float, default=1024.0, metavar="MB",
                        help="memory for the bound tables and the transposition table (default 1024)")
    parser.add_argument("--beam-width", type=int, default=64, help="beam search width (default 64)")
    parser.add_argument("--max-length", type=int, default=64, help="longest plan considered (default 64)")
    parser.add_argument("--threshold", type=float, default=0.0,
                        help="state/cell targets: the support automaton keeps entries >= T (default 0)")
    add_range_options(parser, check=True)
    add_kit_options(parser)


def grid_cells(model, spec: str) -> np.ndarray:
    """The cell of every state of a built model on the report grid ``spec`` (AxBxG).

    Rest states are binned by their pose (``extras["state_poses"]``) on the model's tray and
    symmetry; start states (no pose: they stand for the uniform start cells and are only occupied
    before the first tilt) each get a cell of their own.
    """
    from transition_builder.grid import ReportGrid

    meta = model.metadata.get("grid") if isinstance(model.metadata, dict) else None
    poses = model.extras.get("state_poses") if model.extras else None
    if meta is None or poses is None:
        raise InputError("--grid needs built models (state poses and the tray's grid); "
                         "an automaton has neither")
    grid = ReportGrid.from_spec(spec, meta["tray_x_mm"], meta["tray_y_mm"], int(meta.get("symmetry_order", 1)))
    poses = np.asarray(poses, dtype=np.float64)
    ok = np.all(np.isfinite(poses), axis=1)
    cells = np.empty(model.n_states, dtype=np.int64)
    cells[ok] = grid.voxel_index(poses[ok])
    cells[~ok] = grid.n_voxels + np.arange(int((~ok).sum()))
    return cells


def run(args: argparse.Namespace) -> dict:
    from kruskal_markov.automaton_json import model_from_automaton
    from kruskal_markov.model import TransitionModel
    from kruskal_markov.sync.plan import shortest_plan
    from kruskal_markov.sync.targets import parse_target

    try:
        target = parse_target(args.target)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    for name in ("node_budget", "beam_width", "max_length"):
        if getattr(args, name) < 1:
            raise InputError(f"--{name.replace('_', '-')} must be a positive integer")
    if not 0.0 <= args.threshold <= 1.0:
        raise InputError(f"--threshold must lie in [0, 1], got {args.threshold}")
    if getattr(args, "kit", None):
        from analysis.commands import _kit

        return _kit.plan(args)
    if is_range(args):
        return plan_over_range(args, run)
    if args.model:
        models = [TransitionModel.load(p) for p in args.model]
    elif args.automaton:
        models = [model_from_automaton(args.automaton)]
    else:
        raise InputError("one of --model PATH or --automaton FILE is required")
    cells = None
    if args.grid is not None:
        if target.kind == "state":
            raise InputError("--grid has no meaning for --target state")
        if args.automaton:
            raise InputError("--grid needs built models (state poses); an automaton has none")
        try:
            cells = [grid_cells(m, args.grid) for m in models]
        except ValueError as exc:
            raise InputError(str(exc)) from None
    names = [tuple(m.actions) for m in models]
    if any(n != names[0] for n in names):
        raise InputError("the models do not share their actions (a robust plan needs one alphabet)")
    res = shortest_plan(models, target, cells=cells, node_budget=args.node_budget, time_budget=args.time_budget,
                        memory_budget_mb=args.memory_budget_mb, beam_width=args.beam_width,
                        max_length=args.max_length, threshold=args.threshold)
    out = res.to_dict()
    out["models"] = list(args.model) if args.model else [args.automaton]
    out["states"] = [m.n_states for m in models] if len(models) > 1 else models[0].n_states
    if args.grid is not None:
        out["grid"] = args.grid
    return out


def format_text(result: dict) -> str:
    """Human-readable summary (``--json`` gives everything)."""
    lines = [f"target: {result['target']}"]
    if result["word"] is None:
        if result["exact"]:
            lines.append(f"no plan exists: {(result.get('witness') or {}).get('reason', '')}")
        else:
            lines.append("no plan found within the budgets")
    else:
        lines.append(f"word: {','.join(result['word']) if result['word'] else '(empty word)'}")
        kind = "shortest (proven)" if result["exact"] else "not proven shortest"
        lines.append(f"length: {result['length']}  [{kind}; method {result['method']}]")
        lines.append(f"final cell: {result['final_cell']}  success probability: {result['success_probability']}")
    if result.get("lower_bound") is not None and not result["exact"]:
        lines.append(f"lower bound (proven): {result['lower_bound']}")
    for note in result.get("notes") or []:
        lines.append(f"note: {note}")
    if "per_compartment" in result:
        from analysis.commands._kit import format_plan

        lines.append(format_plan(result))
    lines.append(f"seconds: {result['seconds']:.3f}")
    return "\n".join(lines)
