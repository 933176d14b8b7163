"""``--kit KIT`` on ``plan``, ``ensemble``, ``convergence`` and ``simulate``: one tilt sequence for
every compartment of a kit tray (:mod:`analysis.kit`, :mod:`kruskal_markov.kit`, docs/kits.md).

The compartments' models are built (or taken from the model cache) at ``--resolution`` and
``--start-samples``; each command then answers for the whole kit with the single-part keys, plus
each compartment's own figures (``per_compartment`` for ``plan``, ``compartments`` otherwise).
"""
from __future__ import annotations

import argparse
import sys

from analysis.commands import InputError

__all__ = ["add_kit_options", "plan", "ensemble", "convergence", "simulate"]


def add_kit_options(parser: argparse.ArgumentParser, *, models: bool = True, workers: bool = False) -> None:
    """``--kit`` (and with ``models``: ``--resolution``, ``--start-samples``; with ``workers``: ``--workers``)."""
    parser.add_argument("--kit", default=None, metavar="KIT",
                        help="a kit file (JSON: tilt_deg, tilt_time_s, compartments with name, size_mm, shape, "
                             "friction): one tilt sequence for every compartment (docs/kits.md)")
    if models:
        parser.add_argument("--resolution", default="1,1", metavar="MM,DEG",
                            help="with --kit: snapping tolerance of the compartments' models (default 1,1)")
        parser.add_argument("--start-samples", type=int, default=2000,
                            help="with --kit: uniform start poses of each model's first tilt (default 2000)")
    if workers:
        parser.add_argument("--workers", type=int, default=None,
                            help="with --kit: worker processes of the builds (default: all cores)")


def _reject(args, options) -> None:
    for opt in options:
        if getattr(args, opt, None) not in (None, [], False):
            raise InputError(f"--kit builds the compartments' models itself: drop --{opt.replace('_', '-')}")


def load(args):
    """The kit of ``--kit`` (one-line InputError when bad)."""
    from analysis.kit import load_kit

    try:
        return load_kit(args.kit)
    except ValueError as exc:
        raise InputError(str(exc)) from None


def build_settings(args):
    """The :class:`~transition_builder.builder.BuildSettings` of the kit's models."""
    from analysis.commands._common import parse_resolution
    from transition_builder.builder import BuildSettings

    mm, deg = parse_resolution(args.resolution)
    if args.start_samples < 1:
        raise InputError(f"--start-samples must be at least 1, got {args.start_samples}")
    if getattr(args, "workers", None) is not None and args.workers < 1:
        raise InputError(f"--workers must be a positive integer, got {args.workers}")
    try:
        return BuildSettings(tol_mm=mm, tol_deg=deg, recenter_rounds=1, start_samples=args.start_samples)
    except ValueError as exc:
        raise InputError(str(exc)) from None


def setting_changes(args) -> dict:
    """The simulator settings of the command's own options over the kit's (``--engine`` where the
    command has it)."""
    engine = getattr(args, "engine", None)
    return {} if engine is None else {"engine": engine}


def scenes_of(kit, args) -> list:
    """The kit's scenes under the command's ``--contact`` and ``--engine`` (one-line InputError)."""
    try:
        return kit.scenes(getattr(args, "contact", None), **setting_changes(args))
    except ValueError as exc:
        raise InputError(str(exc)) from None


def models_of(args):
    """``(kit, [compartment dicts])``: the kit and its models (:func:`analysis.kit.kit_models`)."""
    from analysis.kit import kit_models

    _reject(args, ("model", "automaton", "shape", "friction"))
    kit = load(args)
    settings = build_settings(args)
    scenes_of(kit, args)            # bad --contact/--engine values: one line before any build
    comps = kit_models(kit, settings, contact=getattr(args, "contact", None), workers=getattr(args, "workers", None),
                       log=lambda text: sys.stderr.write(f"kruskal: {text}\n"), setting_changes=setting_changes(args))
    return kit, comps


def _models_entry(comps) -> list:
    return [{"name": c["name"], "shape": c["scene"].shape.name, "tray_mm": [c["scene"].tray_x_mm, c["scene"].tray_y_mm],
             "model": c["path"], "states": c["model"].n_states, "cached": c["cached"],
             "engine": getattr(c["scene"].settings, "engine", "pybullet")} for c in comps]


def plan(args) -> dict:
    """``kruskal plan --kit``: the shortest common plan, each compartment's own beside it."""
    from kruskal_markov.kit import kit_plan
    from kruskal_markov.sync.targets import parse_target

    target = parse_target(args.target)
    if args.grid is not None:
        raise InputError("--grid is not supported with --kit (each compartment uses its model's report grid)")
    kit, comps = models_of(args)
    res = kit_plan([c["model"] for c in comps], target, node_budget=args.node_budget, time_budget=args.time_budget,
                   memory_budget_mb=args.memory_budget_mb, beam_width=args.beam_width, max_length=args.max_length,
                   threshold=args.threshold)
    out = res["common"].to_dict()
    out["joint_success_probability"] = res["joint_success"]
    out["per_compartment"] = [{"name": c["name"], "word": None if p.word is None else list(p.word),
                               "length": p.length, "exact": p.exact, "lower_bound": p.lower_bound,
                               "final_cell": p.final_cell, "success_probability": p.success_probability}
                              for c, p in zip(comps, res["own"])]
    out["compartments"] = _models_entry(comps)
    out["kit"] = args.kit
    out["engine"] = _engine(comps)
    return out


def _engine(comps) -> str:
    """The engine every compartment's model was built in (one per kit: the command's ``--engine``)."""
    return getattr(comps[0]["scene"].settings, "engine", "pybullet")


def ensemble(args) -> dict:
    """``kruskal ensemble --kit``: random sequences through every compartment at once."""
    from analysis.commands._common import check_positive, parse_weights
    from kruskal_markov.kit import kit_ensemble, wilson_interval

    check_positive(args.count, "--count")
    check_positive(args.length, "--length")
    kit, comps = models_of(args)
    models = [c["model"] for c in comps]
    weights = parse_weights(args.weights, models[0].actions)
    r = kit_ensemble(models, args.count, args.length, seed=args.seed, epsilon=args.epsilon, weights=weights,
                     threads=args.threads)
    actions = models[0].actions
    per = []
    for c, e in zip(comps, r["compartments"]):
        per.append({"name": c["name"], "mean": e.mean.tolist(), "q25": e.q25.tolist(), "q75": e.q75.tolist(),
                    "converged": e.converged,
                    "convergence_steps": [None if s < 0 else int(s) for s in e.convergence_steps.tolist()]})
    return {"mean": r["mean"].tolist(), "q25": r["q25"].tolist(), "q75": r["q75"].tolist(),
            "converged": r["converged"], "converged_ci95": wilson_interval(r["converged"], args.count),
            "convergence_steps": [None if s < 0 else int(s) for s in r["convergence_steps"].tolist()],
            "best_sequence": [actions[a] for a in r["best_sequence"]],
            "best_entropy_bits": r["best_entropy"].tolist(),
            "entropy_on": "kit: the sum of the compartments' report-cell entropies (the joint distribution's)",
            "count": args.count, "length": args.length, "seed": args.seed, "epsilon": r["epsilon"],
            "compartments": [dict(p, **m) for p, m in zip(per, _models_entry(comps))], "kit": args.kit,
            "engine": _engine(comps)}


def convergence(args) -> dict:
    """``kruskal convergence --kit``: the expected random tilts until every compartment is oriented."""
    from kruskal_markov.convergence import default_mc_steps, expected_sync_length, letter_weights
    from kruskal_markov.kit import kit_entropy_tilts, kit_sync_lengths
    from kruskal_markov.sync import start_set, support_automaton

    kit, comps = models_of(args)
    models = [c["model"] for c in comps]
    from analysis.commands._common import parse_weights

    w = letter_weights(models[0].n_actions, parse_weights(args.weights, models[0].actions))
    whole = {"auto": None, "all": True, "initial": False}[args.start]
    auts, starts, own = [], [], []
    for m in models:
        aut = support_automaton(m, args.threshold)
        start = start_set(m, m.is_deterministic() if whole is None else whole)
        auts.append(aut)
        starts.append(start)
        own.append(expected_sync_length(aut, start, w, seed=args.seed, runs=args.runs, max_subsets=args.max_subsets,
                                        max_steps=args.max_steps, pair_time_budget=args.pair_time_budget,
                                        memory_budget_mb=args.memory_budget_mb))
    steps = default_mc_steps(sum(m.n_states for m in models), args.runs) if args.max_steps is None else args.max_steps
    if any(o.get("infinite") for o in own):     # some compartment is never oriented: neither is the kit
        mc = {"mean": None, "ci95": [None, None], "runs": 0, "censored": 0, "lower": None}
    else:
        mc = kit_sync_lengths(auts, starts, w, runs=args.runs, seed=args.seed, max_steps=steps)
    single = len(models) == 1
    lowers = [o["pair_lower"] for o in own]
    out = {"expected_length": {
        "exact": own[0]["exact"] if single else None, "monte_carlo": mc["mean"], "ci95": mc["ci95"],
        "monte_carlo_lower": mc["lower"],
        "pair_lower": None if None in lowers else max(lowers),
        "pair_upper": own[0]["pair_upper"] if single else None},
        "mc_runs": mc["runs"], "mc_censored": mc["censored"], "mc_max_steps": steps,
        "infinite": any(o.get("infinite") for o in own),
        "how": "shared random sequences drive every compartment; a run ends when every compartment's support "
               "set is one state at once (pair_lower: the largest compartment's own pair-chain lower bound)",
        "weights": [float(x) for x in w], "kit": args.kit}
    if args.epsilon is not None:
        if not args.epsilon >= 0:
            raise InputError(f"--epsilon must be >= 0, got {args.epsilon}")
        out["entropy_tilts"] = kit_entropy_tilts(models, args.epsilon, w, runs=min(args.runs, 1000), seed=args.seed,
                                                 max_steps=min(steps, 2000))
        out["epsilon"] = args.epsilon
    out["compartments"] = [dict(m, expected_length={k: o[k] for k in ("exact", "monte_carlo", "ci95",
                                                                        "monte_carlo_lower", "pair_lower",
                                                                        "pair_upper")})
                           for m, o in zip(_models_entry(comps), own)]
    out["engine"] = _engine(comps)
    return out


def simulate(args) -> dict:
    """``kruskal simulate --kit``: every compartment driven by one sequence in direct simulation."""
    from analysis.commands._common import check_positive, check_writable_file, parse_sequence, sequence_rng
    from analysis.kit_replay import compartment_seed, final_cell_counts, simulate_kit

    _reject(args, ("shape", "friction", "scene", "tilt_deg", "tilt_time", "poses"))
    if args.noise not in (None, "none") or args.scheduler:
        raise InputError("--kit simulates without --noise and --scheduler")
    check_positive(args.trials, "--trials")
    if args.workers is not None:
        check_positive(args.workers, "--workers")
    check_writable_file(args.animation, "--animation")
    kit = load(args)
    scenes = scenes_of(kit, args)
    sequence = parse_sequence(args.sequence, scenes[0].actions, sequence_rng(args.seed))
    results = simulate_kit(scenes, sequence, args.trials, seed=args.seed, workers=args.workers, grid=args.grid)
    comps = []
    for i, (c, scene, res) in enumerate(zip(kit.compartments, scenes, results)):
        d = res.to_dict()
        comps.append({"name": c.name, "shape": scene.shape.name, "tray_mm": [scene.tray_x_mm, scene.tray_y_mm],
                      "entropy_bits": d["entropy_bits"], "faults": d["faults"], "surviving": d["surviving"],
                      "occupied_voxels": d["occupied_voxels"], "final_cells": final_cell_counts(res),
                      "seed": compartment_seed(args.seed, i)})
    out = {"compartments": comps, "trials": args.trials, "tilts": int(len(sequence)),
           "sequence": [scenes[0].actions[a] for a in sequence],
           "entropy_bits": [float(sum(h)) for h in zip(*(c["entropy_bits"] for c in comps))],
           "entropy_on": "kit: the sum of the compartments' report-grid entropies", "seed": args.seed,
           "grid": args.grid, "kit": args.kit, "engine": getattr(scenes[0].settings, "engine", "pybullet")}
    if args.animation:
        from analysis.kit_figures import animate_kit

        out["animation"] = animate_kit(results, scenes, kit.names, args.animation)
    return out


def format_plan(result: dict) -> str:
    """Human-readable lines of ``plan --kit`` after the plan's own."""
    lines = [f"joint success probability (product of the compartments'): {result['joint_success_probability']}",
             "compartment           own shortest  exact  final cell  success"]
    for p in result["per_compartment"]:
        lines.append(f"{p['name']:<20}  {str(p['length']):>12}  {str(p['exact']):>5}  {str(p['final_cell']):>10}  "
                     f"{p['success_probability']}")
    return "\n".join(lines)


def format_text(result: dict) -> str:
    """Human-readable summary of ``simulate --kit`` and ``ensemble --kit`` (``--json`` gives everything)."""
    def curve(values):
        return " ".join(f"{v:.3g}" for v in values)

    lines = [f"kit {result['kit']}: {len(result['compartments'])} compartments"]
    if "trials" in result:      # simulate
        lines.append(f"sequence: {','.join(result['sequence'])}  trials {result['trials']}  seed {result['seed']}")
        lines.append(f"kit entropy (bits, sum over compartments): {curve(result['entropy_bits'])}")
        for c in result["compartments"]:
            lines.append(f"{c['name']}: entropy {curve(c['entropy_bits'])}; faults "
                         + ", ".join(f"{k} {v}" for k, v in c["faults"].items()))
        if result.get("animation"):
            lines.append(f"animation: {result['animation']}")
    else:                       # ensemble
        lines.append(f"{result['count']} random sequences of length {result['length']} (seed {result['seed']})")
        lines.append(f"kit mean entropy (bits): {curve(result['mean'])}")
        lo, hi = result["converged_ci95"]
        lines.append(f"converged (every compartment at once): {result['converged']} of {result['count']} "
                     f"(95% interval {lo:.3f}-{hi:.3f} as a share)")
        for c in result["compartments"]:
            lines.append(f"  {c['name']}: converged {c['converged']} of {result['count']}")
        lines.append(f"best sequence: {','.join(result['best_sequence'])}")
    lines.append(f"seconds: {result['seconds']:.2f}")
    return "\n".join(lines)
