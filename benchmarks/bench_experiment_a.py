"""Experiment A's speed-up, measured side by side: a model's build against direct simulation in one run.

The machine's speed drifts: the same direct-simulation sample (experiment A's first sequence, 400
trials, 2 workers) ran at 699 tilts/s in one benchmark run and at 541 tilts/s in another on the same
day. A build timed in one run and a tilt rate timed in another therefore do not make a ratio. Here
every round times them together:

1. direct simulation of the rate sample (``bench_pareto._direct_rate``): rate before;
2. the allen-key model of the design built from scratch on 2 workers (``build_model``, no cache), then
   experiment A from it (43 random 50-tilt sequences, seed 0: ``entropy_trajectory`` each);
3. the rate sample again: rate after.

(The worker pool is started before the first timing.)

Direct experiment A with 10,000 trials per sequence (43 x 10,000 x 50 tilts) is extrapolated at the
mean of the two rates; the speed-up is that time over the model's (build + A). The spread of the two
rates is reported beside it, and the ratio at each. Every round's model must be the same, array for
array (a build is reproducible; a difference is reported as a failure).

The model's error is judged on both held-out sets of ``bench_builder`` (seeds 2026 and 2027, 6 x 30
tilts, M = 2,000, whichever are cached there) and set beside direct simulation's error at equal
time on the same set: M = model time x rate / (43 x 50) trials per sequence, read off the
subsample curve of ``bench_pareto``. A second judge, where cached, is the same trials simulated at
half the time step: against it direct simulation's error at equal time is its sampling noise plus
the default simulator's time-step error, which the model carries too (the first judge charges the
model with that error and direct simulation with none). ``KRUSKAL_BENCH_A_ROUNDS`` (default 2)
sets the number of rounds, ``KRUSKAL_BENCH_A_DESIGN`` (default ``det``, the default settings) the
design: a variant of ``bench_builder.VARIANTS``; ``KRUSKAL_BENCH_A_REJUDGE=1`` judges the saved
rounds of the design again without timing anything. Writes the design's entry of
``benchmarks/results/experiment_a.json``, which ``python -m benchmarks pareto`` puts into
``reports/full/pareto.md``.
"""
from __future__ import annotations

import json
import os
import platform
import time

ROUNDS = int(os.environ.get("KRUSKAL_BENCH_A_ROUNDS", "2"))
DESIGN = os.environ.get("KRUSKAL_BENCH_A_DESIGN", "det")


def _warm_up(scene) -> None:
    """Start the worker pool (about a second) before anything is timed: direct simulation of
    experiment A would pay it once in 8 hours."""
    from analysis.montecarlo import run_direct

    run_direct(scene, [0, 1], 32, seed=1, workers=2)


def _experiment_a_seconds(model) -> float:
    """Experiment A from ``model``: the entropy of 43 random 50-tilt sequences (seed 0), timed."""
    from analysis.sequences import random_sequences_for
    from benchmarks.bench_pareto import A_LENGTH, A_SEQUENCES
    from kruskal_markov.entropy import entropy_trajectory

    t = time.perf_counter()
    for seq in random_sequences_for(model.n_actions, A_SEQUENCES, A_LENGTH, 0):
        entropy_trajectory(model, seq)
    return time.perf_counter() - t


def _judge(model, seed: int) -> dict | None:
    """The model's error on the held-out set ``seed`` (6 x 30 tilts, M = 2,000), and direct
    simulation's at each subsample size (None when the references are not cached: run
    ``python -m benchmarks builder``, with ``KRUSKAL_BENCH_BUILDER_SEED`` for the second set).
    Where the same trials are cached at half the time step too, both are also judged against those
    (``finer_simulator``): direct simulation's subsamples of the default simulator then carry its
    time-step error as the model does."""
    import numpy as np

    from analysis.sequences import random_sequences_for
    from analysis.validate import model_grid, reference_seed, validate_model
    from benchmarks.bench_builder import LENGTH, SEQUENCES, TRIALS, reference_cache
    from benchmarks.bench_pareto import _subsample_errors
    from transition_builder.scene import scene_from_options

    scene = scene_from_options("allen-key")
    grid = model_grid(model)
    simulate, _ = reference_cache(scene, TRIALS, grid, 2, cached_only=True)
    seqs = random_sequences_for(len(scene.actions), SEQUENCES, LENGTH, seed)
    refs = [simulate(scene, s, TRIALS, reference_seed(seed, i), "none") for i, s in enumerate(seqs)]
    if any(r is None for r in refs):
        return None
    half_scene = scene.with_settings(**scene.settings.finer_step(2))
    halves = [simulate(half_scene, s, TRIALS, reference_seed(seed, i), "none") for i, s in enumerate(seqs)]
    finer = all(h is not None for h in halves)
    val = validate_model(model, SEQUENCES, TRIALS, seed, LENGTH, spread=finer, bands=40, simulate=simulate)
    mc = _subsample_errors(refs, tuple(scene.actions), grid, seqs)
    out = {"mean_abs_error_bits": float(val["mean_abs_error_bits"]), "max_abs_error_bits": float(val["max_abs_error_bits"]),
           "judge": f"{SEQUENCES} held-out {LENGTH}-tilt sequences (seed {seed}), M = {TRIALS:,}",
           "direct_subsample_errors": {str(m): e for m, e in mc.items()}}
    if finer:
        # the same trials at half the time step: both methods sample the default simulator, so both
        # carry its time-step error against this judge (sequences of equal length: mean of means)
        vs_half = [s["model_vs_half_time_step"] for s in val["per_sequence"]]
        mc_half = _subsample_errors(refs, tuple(scene.actions), grid, seqs, [h.entropy_bits for h in halves])
        out["finer_simulator"] = {
            "judge": "the same trials simulated at half the time step (1/480 s, 8 sub-steps)",
            "mean_abs_error_bits": float(np.mean([v["mean"] for v in vs_half])),
            "max_abs_error_bits": float(max(v["max"] for v in vs_half)),
            "simulation_spread_bits": val["simulation_spread_bits"],
            "direct_subsample_errors": {str(m): e for m, e in mc_half.items()}}
    return out


def _judge_rounds(out: dict, model) -> None:
    """Judge ``model`` on both held-out sets and say, per round and set, whether the target is met:
    at least 100x, with neither the mean nor the max error above direct simulation's at equal time."""
    from benchmarks.bench_builder import HELD_OUT_SEED, SECOND_HELD_OUT_SEED
    from benchmarks.bench_pareto import A_LENGTH, A_SEQUENCES, _direct_error_at, missed_target

    def at_equal_time(judged: dict, row: dict, m: float) -> dict:
        """Direct simulation's error at ``m`` trials per sequence under one judge, and the verdict."""
        mc = {int(k): e for k, e in judged["direct_subsample_errors"].items()}
        direct = {"mean": _direct_error_at(mc, m, "mean"), "max": _direct_error_at(mc, m, "max")}
        return {"direct_error_at_equal_time": direct,
                "target_met": not missed_target(row["speedup"], judged, direct)}

    out["judged"] = {}
    for seed in (HELD_OUT_SEED, SECOND_HELD_OUT_SEED):
        judged = _judge(model, seed)
        if judged is None:
            print(f"held-out set {seed}: references not cached, not judged")
            continue
        out["judged"][str(seed)] = judged
        finer = judged.get("finer_simulator")
        for row in out["rounds"]:
            m = row["total_seconds"] * 0.5 * (row["rate_before"] + row["rate_after"]) / (A_SEQUENCES * A_LENGTH)
            row["direct_trials_at_equal_time"] = m
            entry = at_equal_time(judged, row, m)
            if finer:
                entry["finer_simulator"] = at_equal_time(finer, row, m)
            row.setdefault("by_set", {})[str(seed)] = entry
            head = f"round {row['round']}, set {seed}: "
            for label, j, e in ((head, judged, entry),
                                ("    against the half-step simulator: ", finer, entry.get("finer_simulator"))):
                if e:
                    d = e["direct_error_at_equal_time"]
                    print(f"{label}direct at equal time M = {m:.0f}: {d['mean']:.3f} / {d['max']:.2f} bits; model "
                          f"{j['mean_abs_error_bits']:.3f} / {j['max_abs_error_bits']:.2f}; target met: "
                          f"{e['target_met']}", flush=True)


def _rejudge(settings) -> None:
    """``KRUSKAL_BENCH_A_REJUDGE=1``: judge the timed rounds already saved for the design again (e.g.
    on a set whose references were cached later), with the design's model that the timing run (or the
    builder bench) saved (``benchmarks/results/model-<design>.npz``; builds are reproducible, so it is
    the model timed)."""
    from benchmarks.bench_builder import RESULTS
    from kruskal_markov.model import TransitionModel
    from transition_builder.builder import build_key
    from transition_builder.scene import scene_from_options

    path = RESULTS / "experiment_a.json"
    entry = json.loads(path.read_text())["designs"].get(DESIGN) if path.exists() else None
    model_path = RESULTS / f"model-{DESIGN}.npz"
    if entry is None or not model_path.exists():
        raise SystemExit(f"nothing to judge again for {DESIGN!r}: time it first (which saves {model_path.name})")
    model = TransitionModel.load(str(model_path))
    if model.metadata.get("build_key") != build_key(scene_from_options("allen-key"), settings):
        raise SystemExit(f"{model_path} was not built with the settings of {DESIGN!r}")
    _judge_rounds(entry, model)
    _save(path, entry)


def main() -> None:
    from benchmarks.bench_builder import RESULTS, VARIANTS
    from benchmarks.bench_pareto import A_LENGTH, A_SEQUENCES, A_TRIALS, _direct_rate
    from transition_builder.builder import BuildSettings, build_model
    from transition_builder.scene import scene_from_options

    if DESIGN not in VARIANTS:
        raise SystemExit(f"KRUSKAL_BENCH_A_DESIGN={DESIGN!r} is not a builder variant ({', '.join(VARIANTS)})")
    changes, description = VARIANTS[DESIGN]
    changes = dict(changes)
    if "scene" in changes:
        raise SystemExit(f"variant {DESIGN!r} changes the simulator; experiment A is judged at the default one")
    settings = BuildSettings(**changes)
    if os.environ.get("KRUSKAL_BENCH_A_REJUDGE"):
        _rejudge(settings)
        return
    scene = scene_from_options("allen-key")
    direct_tilts = A_SEQUENCES * A_TRIALS * A_LENGTH
    rounds, first = [], None
    _warm_up(scene)
    for r in range(ROUNDS):
        before = _direct_rate(scene)
        t = time.perf_counter()
        result = build_model(scene, settings, workers=2, progress=None)
        build_s = time.perf_counter() - t
        a_s = _experiment_a_seconds(result.model)
        after = _direct_rate(scene)
        rate = 0.5 * (before + after)
        total = build_s + a_s
        row = {"round": r + 1, "rate_before": before, "rate_after": after, "build_seconds": build_s,
               "experiment_a_seconds": a_s, "total_seconds": total, "tilts": result.stats["tilts_simulated"],
               "states": result.stats["states"], "direct_seconds": direct_tilts / rate,
               "speedup": direct_tilts / rate / total,
               "speedup_range": [direct_tilts / min(before, after) / total, direct_tilts / max(before, after) / total]}
        if first is None:
            first = result.model
            first.save(str(RESULTS / f"model-{DESIGN}.npz"))     # builds are reproducible: the model timed
        else:
            row["same_model_as_round_1"] = first.same_arrays(result.model)
        rounds.append(row)
        print(f"round {r + 1}: direct {before:.0f} / {after:.0f} tilts/s (before / after); build {build_s:.0f} s "
              f"+ experiment A {a_s:.1f} s; direct A {row['direct_seconds']:,.0f} s; speed-up "
              f"{row['speedup']:.0f}x ({row['speedup_range'][1]:.0f}-{row['speedup_range'][0]:.0f}x)", flush=True)
    out = {"design": DESIGN, "description": description, "rounds": rounds,
           "machine": f"{platform.machine()}, {os.cpu_count()} cores", "load_average": os.getloadavg()[0],
           "direct_tilts": direct_tilts}
    _save(RESULTS / "experiment_a.json", out)                    # the timings, judged or not
    _judge_rounds(out, first)
    _save(RESULTS / "experiment_a.json", out)


def _save(path, entry: dict) -> None:
    """Write ``entry`` as the entry of its design in the results file (other designs kept)."""
    from kruskal_markov.model import atomic_write_text

    path.parent.mkdir(parents=True, exist_ok=True)
    designs = json.loads(path.read_text()).get("designs", {}) if path.exists() else {}
    designs[entry["design"]] = entry
    atomic_write_text(path, json.dumps({"designs": designs}, indent=1))
