"""``kruskal validate``: a built model's entropy predictions against direct simulation.

K random sequences (``--seed``; the model's process noise in the reference); per sequence the
model's report-grid entropy curve beside direct Monte Carlo of M trials; the model's error beside
the reference's own sampling noise and, with ``--spread``, beside the simulator's own half-time-step
spread (``analysis.validate``).
"""
from __future__ import annotations

import argparse
import math

from analysis.commands import InputError
from analysis.commands._common import add_contact, add_seed, check_positive, parse_contact_arg, parse_engine_arg


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--model", required=True, metavar="PATH", help="a model built by `kruskal build`")
    parser.add_argument("--sequences", type=int, default=6, help="number of random sequences K (default 6)")
    parser.add_argument("--trials", type=int, default=1000, help="direct-simulation trials M per sequence")
    parser.add_argument("--length", type=int, default=50, help="length N of every sequence (default 50)")
    add_seed(parser)
    parser.add_argument("--spread", action="store_true",
                        help="also re-simulate the reference at half the time step")
    add_contact(parser)
    parser.add_argument("--reference", default=None, metavar="ENGINE",
                        help="simulate the reference in this engine (planar or pybullet; default the model's own); "
                             "the same as --engine")
    parser.add_argument("--bands", type=int, default=40, help="posterior draws for the model's band (default 40)")
    parser.add_argument("--structural-delta", type=float, default=None, metavar="D",
                        help="relative structural error of the band: the share of the probability outside "
                             "the most likely cell the model may have misplaced (default: the calibrated "
                             "kruskal_markov.structural.STRUCTURAL_DELTA; 0: the Dirichlet band alone)")
    parser.add_argument("--calibrate", action="store_true",
                        help="store this run's structural calibration in the model file: the split-conformal 90%% "
                             "quantile of every step's structural_needed, pooled with the steps of earlier "
                             "--calibrate runs on the model; later commands use it as the model's structural delta")
    parser.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS", help="a Dask distributed scheduler")
    parser.add_argument("--progress", action="store_true", help="progress bar on standard error")


def run(args: argparse.Namespace) -> dict:
    from analysis.validate import validate_model
    from kruskal_markov.model import TransitionModel

    for name in ("sequences", "trials", "length"):
        check_positive(getattr(args, name), f"--{name}")
    if args.trials < 2:
        raise InputError("--trials must be at least 2 (the reference's noise is a bootstrap)")
    contact = parse_contact_arg(args.contact)     # checked before any work
    engine = parse_engine_arg(args.reference) if args.reference is not None else parse_engine_arg(args.engine)
    if args.reference is not None and args.engine is not None and parse_engine_arg(args.engine) != engine:
        raise InputError("--reference and --engine name different engines: give one")
    delta = args.structural_delta
    if delta is not None and not (math.isfinite(delta) and delta >= 0):
        raise InputError(f"--structural-delta must be a non-negative number, got {args.structural_delta}")
    if args.calibrate and args.bands < 1:
        raise InputError("--calibrate needs the model's band (--bands of at least 1)")
    model = TransitionModel.load(args.model)
    from kruskal_markov.structural import is_sampled
    if args.calibrate and not is_sampled(model):
        raise InputError("--calibrate needs a model built by `kruskal build` (an automaton has no structural term)")
    result = validate_model(model, args.sequences, args.trials, args.seed, args.length, spread=args.spread,
                            bands=args.bands, workers=args.workers, scheduler=args.scheduler,
                            progress=True if args.progress else None, contact=contact, engine=engine,
                            structural_delta=delta)
    if args.calibrate:
        result["calibration"] = calibrate_model(model, result, args.model)
    return result


def calibrate_model(model, result: dict, path: str) -> dict:
    """Store the run's split-conformal ``delta`` (pooled with earlier calibrations' steps) in the model file.

    Returns the ``calibration`` JSON key: ``delta``, ``steps``, ``sequences`` (pooled; None once a record
    that predates the count is pooled in), ``seeds``, ``model`` (the path written) and, for a calibration of
    fewer than :data:`kruskal_markov.structural.MIN_CALIBRATION_SEQUENCES` sequences, ``warning``.
    """
    import math

    from kruskal_markov.structural import calibration_warning, conformal_quantile, with_calibration

    if result.get("contact") != result.get("model_contact") or result.get("engine") != result.get("model_engine"):
        raise InputError("--calibrate compares the model with its own physics: drop --contact/--engine/--reference")
    from kruskal_markov.structural import STRUCTURAL_RULE

    old = model.metadata.get("structural") if isinstance(model.metadata.get("structural"), dict) else {}
    if old.get("rule", STRUCTURAL_RULE) != STRUCTURAL_RULE:
        old = {}  # a calibration of another rule: its scores are on another scale
    new = [math.inf if x is None else float(x) for s in result["per_sequence"] for x in s["structural_needed"][1:]]
    scores = [math.inf if x is None else float(x) for x in old.get("scores", [])] + new
    seeds = [*old.get("seeds", []), result["seed"]]
    # sequences pooled: unknown (None) once a record that predates the count is pooled in
    before = old.get("sequences", None) if old.get("scores") else 0
    sequences = before + len(result["per_sequence"]) if isinstance(before, int) else None
    delta = conformal_quantile(scores, 0.9)
    if not math.isfinite(delta):
        raise InputError(f"--calibrate: {len(scores)} steps do not give a finite 90% structural delta "
                         "(too few steps, or a reference no band reaches): run more --sequences")
    finite = [round(x, 6) if math.isfinite(x) else None for x in scores]
    with_calibration(model, delta, level=0.9, steps=len(scores), sequences=sequences, seeds=seeds,
                     scores=finite).save(path)
    out = {"delta": delta, "steps": len(scores), "sequences": sequences, "seeds": seeds, "model": path}
    warn = calibration_warning(sequences)
    if warn:
        out["warning"] = warn
    return out


def format_text(result: dict) -> str:
    """Error, reference noise and (with --spread) the simulator's own spread, side by side."""
    lines = [f"{result['sequences']} sequences x {result['length']} tilts, M = {result['trials']}, "
             f"noise {result['noise']}, {result['states']} model states",
             "seq  mean_err  max_err  ref_noise  final_TV"
             + ("  spread_mean  spread_max" if "simulation_spread_bits" in result else "")]
    for i, s in enumerate(result["per_sequence"]):
        line = (f"{i:3d}  {s['mean_abs_error_bits']:8.3f}  {s['max_abs_error_bits']:7.3f}  "
                f"{s['reference_noise_bits']:9.3f}  {s['final_tv_distance']:8.3f}")
        if "simulation_spread_bits" in s:
            line += f"  {s['simulation_spread_bits']['mean']:11.3f}  {s['simulation_spread_bits']['max']:10.3f}"
        lines.append(line)
    lines.append(f"all: mean {result['mean_abs_error_bits']:.3f}  max {result['max_abs_error_bits']:.3f}  "
                 f"steps > 0.25: {100 * result['share_steps_above_0_25']:.1f}%  reference noise "
                 f"{result['reference_noise_bits']:.3f}")
    if result.get("band_coverage") is not None:
        lo, hi = result["band_coverage_ci95"]
        dlo, dhi = result["band_coverage_dirichlet_ci95"]
        q = result["structural_delta_q90"]
        lines.append(f"90% band (structural delta {result['structural_delta']:g}): covers "
                     f"{100 * result['band_coverage']:.0f}% of {result['band_steps']} steps (95% CI {100 * lo:.0f}-"
                     f"{100 * hi:.0f}%); Dirichlet band alone {100 * result['band_coverage_dirichlet']:.0f}% "
                     f"({100 * dlo:.0f}-{100 * dhi:.0f}%); this run would calibrate delta = "
                     + ("inf" if q is None else f"{q:.3f}"))
        lines.append(f"structural term: {result['structural_note']}")
    if "calibration" in result:
        c = result["calibration"]
        lines.append(f"calibrated: structural delta {c['delta']:.4g} from {c['steps']} steps (seeds "
                     f"{', '.join(map(str, c['seeds']))}), stored in {c['model']}")
        if c.get("warning"):
            lines.append(f"warning: {c['warning']}")
    if "simulation_spread_bits" in result:
        sp = result["simulation_spread_bits"]
        lines.append(f"simulator half-time-step spread: mean {sp['mean']:.3f}  max {sp['max']:.3f}")
    lines.append(f"seconds: {result['seconds']:.1f} (model {result['model_seconds']:.1f}, "
                 f"simulation {result['simulation_seconds']:.1f})")
    return "\n".join(lines)
