"""Time-step convergence of the floor-contact models: where does a tilt land at the default step,
and where at 1/16 (and 1/32) of it, with the same rest-test interval?

For each contact model, ``N_STARTS`` uniform collision-free allen-key starts (seed ``SEED``) are
tilted once toward E and once toward NE at the default time step and at finer ones (``substeps``
scaled so that the rest test still runs every ``substeps * time_step_s`` seconds). A landing
*agrees* with the reference when its centroid lies within 1 mm and its angle within 1 degree of the
reference landing (2 mm / 2 degrees also reported). The reference's own floor is the same contact
at 1/16 against 1/32 of the step: about 2% of tilts are sensitive (a pivot that can fall either
way) and no model can do better than its floor.

Run: ``python -m benchmarks contact`` (environment: ``KRUSKAL_BENCH_CONTACT_STARTS`` (600),
``KRUSKAL_BENCH_CONTACT_SEED`` (13, the held-out seed; 11 and 12 were used to choose the design),
``KRUSKAL_BENCH_CONTACT_MODELS`` (``coulomb,sphere-240``; see ``VARIANTS``),
``KRUSKAL_BENCH_CONTACT_REFINE`` (``1,2,16,32``), ``KRUSKAL_BENCH_CONTACT_FLOOR`` (1: also 1/32)).
Results: ``benchmarks/results/contact.json``. Costs per tilt are side by side only in
``python -m benchmarks sim``; the CPU seconds here are for orientation.
"""
from __future__ import annotations

import json
import math
import os
import pathlib
import time

import numpy as np

N_STARTS = int(os.environ.get("KRUSKAL_BENCH_CONTACT_STARTS", "600"))
SEED = int(os.environ.get("KRUSKAL_BENCH_CONTACT_SEED", "13"))
#: the designs compared: the default (coulomb at 1/480 s) and the old default (the sphere at 1/240 s)
VARIANTS = {"coulomb": {"contact": "coulomb"},
            "sphere-240": {"contact": "sphere", "time_step_s": 1.0 / 240.0, "substeps": 4},
            "coulomb-240": {"contact": "coulomb", "time_step_s": 1.0 / 240.0, "substeps": 4, "friction_substeps": 1,
                            "free_flight_step_factor": 1},
            "coulomb-needed": {"contact": "coulomb", "contact_pairs": "needed"},
            "coulomb-steady": {"contact": "coulomb", "long_steps": "free+steady"},
            "coulomb-needed-steady": {"contact": "coulomb", "contact_pairs": "needed", "long_steps": "free+steady"},
            "coulomb-needed-hold": {"contact": "coulomb", "contact_pairs": "needed", "long_steps": "free+steady-hold"},
            "coulomb-needed-stick": {"contact": "coulomb", "contact_pairs": "needed", "long_steps": "free+stick"},
            "coulomb-compound": {"contact": "coulomb", "part_links": "compound"},
            "coulomb-needed-compound": {"contact": "coulomb", "contact_pairs": "needed", "part_links": "compound"},
            "coulomb-needed-yaw": {"contact": "coulomb", "contact_pairs": "needed", "part_links": "yaw-compound"},
            "coulomb-needed-floating": {"contact": "coulomb", "contact_pairs": "needed", "part_links": "floating"},
            "coulomb-needed-floating-stick": {"contact": "coulomb", "contact_pairs": "needed", "part_links": "floating",
                                              "long_steps": "free+stick"}}
MODELS = os.environ.get("KRUSKAL_BENCH_CONTACT_MODELS", "coulomb,sphere-240").split(",")
REFINE = tuple(int(r) for r in os.environ.get("KRUSKAL_BENCH_CONTACT_REFINE", "1,2,16,32").split(","))
FLOOR = os.environ.get("KRUSKAL_BENCH_CONTACT_FLOOR", "1") == "1"
ACTIONS = ("E", "NE")


def landings(refine: int, starts, **settings):
    """Rest poses and statuses of every start under each action, and the CPU seconds they took,
    with the time step divided by ``refine`` (same rest-test interval)."""
    from transition_builder.scene import scene_from_options
    from transition_builder.sim import TraySimulator
    from transition_builder.sim_settings import SimSettings
    base = SimSettings(**settings)
    settings = dict(settings, **base.finer_step(refine))
    sc = scene_from_options("allen-key", **settings)
    sim = TraySimulator(sc)
    sim.prepare(ACTIONS)
    out, status = [], []
    cpu = time.process_time()
    for a in ACTIONS:
        r, s = sim.tilt(starts, a)
        out.append(r)
        status.append(s)
    cpu = time.process_time() - cpu
    sim.close()
    return np.concatenate(out), np.concatenate(status), cpu


def agreement(a, b, mm: float, deg: float) -> float:
    """Share of trials (both landed) whose landings lie within ``mm`` and ``deg`` of each other."""
    ok = np.isfinite(a[:, 0]) & np.isfinite(b[:, 0])
    d = np.hypot(a[ok, 0] - b[ok, 0], a[ok, 1] - b[ok, 1])
    t = np.degrees(np.abs((a[ok, 2] - b[ok, 2] + math.pi) % (2 * math.pi) - math.pi))
    return float(np.mean((d <= mm) & (t <= deg)))


def main():
    from transition_builder.sampling import sample_start_poses
    from transition_builder.shapes import parse_shape
    starts = sample_start_poses(parse_shape("allen-key"), 200.0, 200.0, N_STARTS, np.random.default_rng(SEED))
    results = {"starts": N_STARTS, "seed": SEED, "actions": list(ACTIONS), "models": {}}
    for contact in MODELS:
        runs = {}
        for refine in sorted(set(REFINE) | {16}):
            if refine == 32 and not FLOOR:
                continue
            runs[refine] = landings(refine, starts, **VARIANTS[contact])
        ref = runs[16][0]
        row = {"cpu_s_per_tilt": {str(k): v[2] / (2 * N_STARTS) for k, v in runs.items()},
               "faults": {str(k): int(np.sum(v[1] != 0)) for k, v in runs.items()}}
        row["settings"] = VARIANTS[contact]
        for refine in runs:
            if refine == 16:
                continue
            other = runs[refine][0]
            row[f"1/{refine}_vs_1/16"] = {"1mm_1deg": agreement(other, ref, 1, 1),
                                         "2mm_2deg": agreement(other, ref, 2, 2)}
        results["models"][contact] = row
        print(contact, json.dumps(row, indent=1), flush=True)
    out = pathlib.Path(__file__).parent / "results" / "contact.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
