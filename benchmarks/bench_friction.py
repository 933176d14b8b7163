"""Static and kinetic friction (issue 40): the cost of a tilt with a pair beside today's contact
(one coefficient), side by side in one run, and the time-step convergence of landings with a pair.

Cost: uniform allen-key starts (seed 1) under random actions, tilted in alternating chunks with
``0.3`` (today), ``0.3/0.3`` (the same scene spelled as a pair), ``0.5/0.3`` and ``0.61/0.47``; CPU
seconds per tilt and their ratio to today's.

Convergence: ``KRUSKAL_BENCH_FRICTION_STARTS`` (600) uniform starts of the held-out seed
``KRUSKAL_BENCH_FRICTION_SEED`` (4040, named before any pair was run on it), tilted E and NE with
``0.5/0.3`` at the default step, 1/2 of it and 1/16 of it (the reference), landings compared within
1 mm / 1 degree and 2 mm / 2 degrees as in ``python -m benchmarks contact``; today's ``0.3`` on the
same starts beside it.

Run: ``python -m benchmarks friction`` (``KRUSKAL_BENCH_FRICTION_TILTS`` (2000) per cost variant;
``KRUSKAL_BENCH_FRICTION_PARTS`` ``cost,steps``). Results: ``benchmarks/results/friction.json``.
"""
from __future__ import annotations

import json
import os
import pathlib
import time

import numpy as np

N_TILTS = int(os.environ.get("KRUSKAL_BENCH_FRICTION_TILTS", "2000"))
N_STARTS = int(os.environ.get("KRUSKAL_BENCH_FRICTION_STARTS", "600"))
SEED = int(os.environ.get("KRUSKAL_BENCH_FRICTION_SEED", "4040"))
PARTS = os.environ.get("KRUSKAL_BENCH_FRICTION_PARTS", "cost,steps").split(",")
COST_FRICTIONS = ("0.3", "0.3/0.3", "0.5/0.3", "0.61/0.47")
STEP_FRICTIONS = ("0.5/0.3", "0.3")
REFINE = (1, 2, 16)


def _runner(friction):
    """The simulator at floor friction ``friction``: ``run(poses, actions) -> status`` (bench_sim's)."""
    from benchmarks.bench_sim import _ours
    return _ours(friction_spec=friction)


def cost() -> dict:
    """CPU seconds per tilt of each friction, alternating chunks on the same starts and actions."""
    from transition_builder.sampling import sample_start_poses
    from transition_builder.shapes import parse_shape
    shape = parse_shape("allen-key")
    runs = {f: _runner(f) for f in COST_FRICTIONS}
    rng = np.random.default_rng(1)
    chunks = 8
    cpu = {f: 0.0 for f in COST_FRICTIONS}
    faults = {f: 0 for f in COST_FRICTIONS}
    k = max(1, N_TILTS // chunks)
    for _ in range(chunks):
        poses = sample_start_poses(shape, 200.0, 200.0, k, rng)
        actions = rng.integers(0, 8, k)
        for f in COST_FRICTIONS:
            c0 = time.process_time()
            status = runs[f](poses, actions)
            cpu[f] += time.process_time() - c0
            faults[f] += int(np.count_nonzero(status))
    n = chunks * k
    out = {f: {"cpu_s_per_tilt": cpu[f] / n, "ratio_to_0.3": cpu[f] / cpu["0.3"], "faults": faults[f]}
           for f in COST_FRICTIONS}
    out["tilts"] = n
    return out


def steps() -> dict:
    """Agreement of landings at the default step and 1/2 of it with 1/16 of it (held-out seed)."""
    from benchmarks.bench_contact import agreement
    from transition_builder.sampling import sample_start_poses
    from transition_builder.scene import scene_from_options
    from transition_builder.shapes import parse_shape
    from transition_builder.sim import TraySimulator
    from transition_builder.sim_settings import SimSettings
    starts = sample_start_poses(parse_shape("allen-key"), 200.0, 200.0, N_STARTS, np.random.default_rng(SEED))
    out = {"starts": N_STARTS, "seed": SEED, "actions": ["E", "NE"]}
    for f in STEP_FRICTIONS:
        land = {}
        for r in REFINE:
            sim = TraySimulator(scene_from_options("allen-key", f, **SimSettings().finer_step(r)))
            land[r] = np.concatenate([sim.tilt(starts, a)[0] for a in ("E", "NE")])
            sim.close()
        out[f] = {f"1/{r}_vs_1/16": {"1mm_1deg": agreement(land[r], land[16], 1, 1),
                                     "2mm_2deg": agreement(land[r], land[16], 2, 2)} for r in REFINE if r != 16}
        print(f, json.dumps(out[f]), flush=True)
    return out


def main():
    results = {}
    if "cost" in PARTS:
        results["cost"] = cost()
        print(json.dumps(results["cost"], indent=1), flush=True)
    if "steps" in PARTS:
        results["steps"] = steps()
    path = pathlib.Path(__file__).parent / "results" / "friction.json"
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
