"""The planar engine against PyBullet: speed side by side, and the four parts of the rule that decides
the default engine (docs/simulator.md, "The planar engine and the rule that decides the default",
written with its seeds before any of these figures existed).

Parts (``python -m benchmarks engine_rule`` runs all; ``python -m benchmarks.bench_engine_rule PART ...``
runs some); every part writes its figures into ``benchmarks/data/engine_rule.json`` (merged, atomically):

- ``speed``: tilts per second per core of both engines' defaults in one process, 300 uniform key starts
  (seed 7) under each of the eight actions, on the uniform floor and on ``map:medium:1``;
- ``judges`` (rule a): every analytic judge on both engines;
- ``convergence`` (rule b): held-out seeds 901 and 902, 300 uniform key starts each, every action and the
  sequence ``E,N,SW``: the planar engine against itself at 1/16 of the step, and against PyBullet's default;
- ``models`` (rule c): the key and ``triangle:1..3`` at the compared resolution (1 mm / 1 degree, one
  recentring round, 2,000 starts) in both engines, each validated against PyBullet's direct simulation at a
  quarter step on seeds 911 and 912 (2 sequences x 200 trials x 20 tilts per seed; one reference per shape
  and seed, shared by both models);
- ``answers`` (rule d): the key's headline answers (converging share of 10^6 random 50-tilt sequences,
  expected random tilts, shortest one-cell and one-state plans) from its 1 mm models in the planar engine,
  PyBullet's default and PyBullet at a quarter step.
"""
from __future__ import annotations

import json
import math
import os
import sys
import time

import numpy as np

ACTIONS = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")
DATA = os.path.join(os.path.dirname(__file__), "data", "engine_rule.json")
CONVERGENCE_SEEDS = (901, 902)
MODEL_SEEDS = (911, 912)
MODEL_SHAPES = ("allen-key", "triangle:1", "triangle:2", "triangle:3")
#: the compared resolution of the report's contact section
COMPARED = {"tol_mm": 1.0, "tol_deg": 1.0, "recenter_rounds": 1, "start_samples": 2000}
VALIDATION = {"sequences": 2, "trials": 200, "length": 20}


def _save(part: str, value) -> None:
    from kruskal_markov.model import atomic_write_text
    data = {}
    if os.path.exists(DATA):
        with open(DATA, encoding="utf-8") as fh:
            data = json.load(fh)
    data[part] = value
    data.setdefault("measured", {})[part] = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    atomic_write_text(DATA, json.dumps(data, indent=1, sort_keys=True))


def _agree(a, b, mm: float = 1.0, deg: float = 1.0) -> float:
    """Share of rows where both poses exist and lie within ``mm`` and ``deg`` of each other (a fault in
    either counts as a disagreement)."""
    d = np.hypot(a[:, 0] - b[:, 0], a[:, 1] - b[:, 1])
    da = np.degrees(np.abs((a[:, 2] - b[:, 2] + math.pi) % (2 * math.pi) - math.pi))
    ok = np.isfinite(d) & np.isfinite(da)
    return float(np.mean(ok & (d < mm) & (da < deg)))


def speed(n: int = 300, seed: int = 7) -> dict:
    """Tilts per second per core, both engines' defaults, one process, side by side."""
    from transition_builder.sampling import sample_start_poses
    from transition_builder.scene import scene_from_options
    from transition_builder.simulators import make_simulator
    out = {}
    for friction in ("0.3", "map:medium:1"):
        base = scene_from_options("allen-key", friction)
        starts = sample_start_poses(base.shape, 200.0, 200.0, n, np.random.default_rng(seed))
        sims = {e: make_simulator(base.with_settings(engine=e)) for e in ("planar", "pybullet")}
        for sim in sims.values():      # compile, build worlds
            sim.prepare()
            sim.tilt(starts[:2], "E")
        rows = {}
        totals = {"planar": 0.0, "pybullet": 0.0}
        for a in ACTIONS:
            row = {}
            for e, sim in sims.items():
                t = time.perf_counter()
                sim.tilt(starts, a)
                dt = time.perf_counter() - t
                totals[e] += dt
                row[e] = n / dt
            row["ratio"] = row["planar"] / row["pybullet"]
            rows[a] = row
            print(f"  {friction:>13} {a:>2}: planar {row['planar']:8.0f}  pybullet {row['pybullet']:6.0f} tilts/s"
                  f"  ({row['ratio']:.1f}x)", flush=True)
        summary = {e: len(ACTIONS) * n / t for e, t in totals.items()}
        summary["ratio"] = totals["pybullet"] / totals["planar"]
        print(f"  {friction:>13} all: {summary['ratio']:.1f}x", flush=True)
        out[friction] = {"by_action": rows, "all_actions": summary}
    _save("speed", {"starts": n, "seed": seed, **out})
    return out


def judges() -> dict:
    """Rule (a): every analytic judge on both engines, with its target."""
    from transition_builder.judges import (
        JUDGE_TARGETS,
        NEW_JUDGE_TARGETS,
        PAIR_JUDGE_TARGETS,
        engine_judges,
        pair_judges,
    )
    out = {}
    for engine in ("planar", "pybullet"):
        t = time.perf_counter()
        table = engine_judges(engine)
        for shape, pj in pair_judges(engine=engine).items():
            table.update({f"{name} ({shape})": v for name, v in pj.items()})
        targets = {**JUDGE_TARGETS, **NEW_JUDGE_TARGETS}
        for name in list(table):
            base = name.split(" (")[0]
            targets.setdefault(name, PAIR_JUDGE_TARGETS.get(base, targets.get(base)))
        passed = {name: bool(table[name] <= targets[name]) for name in table}
        out[engine] = {"values": table, "targets": {k: targets[k] for k in table}, "passed": passed,
                       "all_pass": all(passed.values()), "seconds": time.perf_counter() - t}
        print(f"  {engine}: all judges pass: {out[engine]['all_pass']}", flush=True)
        for name, ok in passed.items():
            if not ok:
                print(f"    FAIL {name}: {table[name]:.4g} > {targets[name]}", flush=True)
    _save("judges", out)
    return out


def convergence(n: int = 300) -> dict:
    """Rule (b): the planar engine against itself at 1/16 of the step (and against PyBullet's default)."""
    from transition_builder.sampling import sample_start_poses
    from transition_builder.scene import scene_from_options
    from transition_builder.sim_settings import SimSettings
    from transition_builder.simulators import make_simulator
    base = scene_from_options("allen-key")
    planar = make_simulator(base.with_settings(engine="planar"))
    fine = make_simulator(base.with_settings(engine="planar", **SimSettings().finer_step(16)))
    bullet = make_simulator(base.with_settings(engine="pybullet"))
    out = {}
    for seed in CONVERGENCE_SEEDS:
        starts = sample_start_poses(base.shape, 200.0, 200.0, n, np.random.default_rng(seed))
        self_by, pb_by = {}, {}
        for a in ACTIONS:
            p = planar.tilt(starts, a)[0]
            self_by[a] = _agree(p, fine.tilt(starts, a)[0])
            pb_by[a] = _agree(p, bullet.tilt(starts, a)[0])
        p, f, b = starts, starts, starts
        for a in ("E", "N", "SW"):
            p, f, b = planar.tilt(p, a)[0], fine.tilt(f, a)[0], bullet.tilt(b, a)[0]
        seq_self, seq_pb = _agree(p, f), _agree(p, b)
        pooled = float(np.mean(list(self_by.values())))
        out[str(seed)] = {"self_sixteenth_by_action": self_by, "self_sixteenth_pooled": pooled,
                          "self_sixteenth_E_N_SW": seq_self, "pybullet_by_action": pb_by,
                          "pybullet_pooled": float(np.mean(list(pb_by.values()))), "pybullet_E_N_SW": seq_pb}
        print(f"  seed {seed}: planar vs its 1/16 step {pooled:.3f} pooled over actions, E,N,SW {seq_self:.3f}; "
              f"vs PyBullet {out[str(seed)]['pybullet_pooled']:.3f}, E,N,SW {seq_pb:.3f}", flush=True)
    pooled_all = float(np.mean([v["self_sixteenth_pooled"] for v in out.values()]))
    out["rule_b"] = {"pooled_over_actions_and_seeds": pooled_all, "target": 0.96, "passed": pooled_all >= 0.96}
    _save("convergence", out)
    return out


def _build(scene, workers=None):
    from transition_builder.builder import BuildSettings
    from transition_builder.cache import cached_build
    t = time.perf_counter()
    cb = cached_build(scene, BuildSettings(**COMPARED), workers=workers)
    return cb.result.model, time.perf_counter() - t


def models() -> dict:
    """Rule (c): each engine's model against PyBullet's quarter-step direct simulation."""
    from analysis.validate import model_grid, validate_model
    from transition_builder.scene import scene_from_options
    from transition_builder.sim_settings import SimSettings
    from transition_builder.tilting import run_direct
    out = {}
    for shape in MODEL_SHAPES:
        built = {e: _build(scene_from_options(shape, engine=e)) for e in ("planar", "pybullet")}
        grid = model_grid(built["planar"][0])
        refs = {}

        def reference(sc, seq, trials, seed, noise, shape=shape, grid=grid, refs=refs):
            key = (tuple(seq), trials, seed)
            if key not in refs:
                quarter = scene_from_options(shape, engine="pybullet", **SimSettings().finer_step(4))
                refs[key] = run_direct(quarter, seq, trials, seed=seed, grid=grid, noise=noise)
            return refs[key]

        row = {}
        for seed in MODEL_SEEDS:
            for engine, (model, seconds) in built.items():
                v = validate_model(model, VALIDATION["sequences"], VALIDATION["trials"], seed, VALIDATION["length"],
                                   bands=0, simulate=reference)
                row[f"{engine} {seed}"] = {"mean_abs_error_bits": v["mean_abs_error_bits"],
                                           "reference_noise_bits": v["reference_noise_bits"],
                                           "states": int(model.n_states), "build_seconds": seconds}
        err = {e: float(np.mean([row[f"{e} {s}"]["mean_abs_error_bits"] for s in MODEL_SEEDS]))
               for e in ("planar", "pybullet")}
        noise = float(np.mean([row[f"pybullet {s}"]["reference_noise_bits"] for s in MODEL_SEEDS]))
        row["mean"] = {**err, "reference_noise_bits": noise,
                       "passed": bool(err["planar"] <= err["pybullet"] + noise)}
        print(f"  {shape}: planar {err['planar']:.3f} bits, pybullet {err['pybullet']:.3f} bits "
              f"(reference noise {noise:.3f}); no worse: {row['mean']['passed']}", flush=True)
        out[shape] = row
    out["rule_c"] = {"passed": all(out[s]["mean"]["passed"] for s in MODEL_SHAPES)}
    _save("models", out)
    return out


def _answers(model, seed: int = 0) -> dict:
    from analysis.orientability import part_metrics
    from kruskal_markov.ensemble import run_ensemble
    from kruskal_markov.entropy import CONVERGED_BITS
    from kruskal_markov.sync import shortest_plan
    t = time.perf_counter()
    ens = run_ensemble(model, 10**6, 50, seed=seed, epsilon=CONVERGED_BITS)
    m = part_metrics(model, seed=seed, sync_time_budget=60.0)
    cell = shortest_plan(model, "cell", time_budget=60.0)
    state = shortest_plan(model, "state", time_budget=60.0)
    return {"states": int(model.n_states), "converging_share": int(ens.converged) / 10**6,
            "expected_random_tilts": m.random_tilts, "expected_random_tilts_lower": m.random_tilts_lower,
            "cell_plan": cell.length, "cell_plan_exact": bool(cell.exact), "cell_plan_lower_bound": cell.lower_bound,
            "state_plan": state.length, "state_plan_exact": bool(state.exact),
            "state_plan_lower_bound": state.lower_bound, "seconds": time.perf_counter() - t}


def answers() -> dict:
    """Rule (d): the key's headline answers in the planar engine, PyBullet, and PyBullet at a quarter step."""
    from transition_builder.scene import scene_from_options
    from transition_builder.sim_settings import SimSettings
    variants = {"planar": {"engine": "planar"}, "pybullet": {"engine": "pybullet"},
                "pybullet quarter step": {"engine": "pybullet", **SimSettings().finer_step(4)}}
    out = {}
    for name, changes in variants.items():
        model, seconds = _build(scene_from_options("allen-key", **changes))
        out[name] = {**_answers(model), "build_seconds": seconds}
        print(f"  {name}: {json.dumps({k: out[name][k] for k in ('states', 'converging_share', 'expected_random_tilts', 'cell_plan', 'state_plan')})}",
              flush=True)
    checks = {}
    pb, q, pl = out["pybullet"], out["pybullet quarter step"], out["planar"]
    for k in ("converging_share", "expected_random_tilts"):
        if pb[k] is None or q[k] is None or pl[k] is None:
            checks[k] = None
            continue
        allowed = max(abs(q[k] - pb[k]), 0.1 * abs(pb[k]))
        checks[k] = {"difference": abs(pl[k] - pb[k]), "allowed": allowed, "passed": abs(pl[k] - pb[k]) <= allowed}
    for k in ("cell_plan", "state_plan"):
        if pb[k] is None or pl[k] is None:
            checks[k] = None
            continue
        allowed = max(abs((q[k] or pb[k]) - pb[k]), 1, 0.1 * pb[k])
        checks[k] = {"difference": abs(pl[k] - pb[k]), "allowed": allowed, "passed": abs(pl[k] - pb[k]) <= allowed}
    out["rule_d"] = {"checks": checks, "passed": all(c is not None and c["passed"] for c in checks.values())}
    print(f"  rule (d): {out['rule_d']}", flush=True)
    _save("answers", out)
    return out


PARTS = {"speed": speed, "judges": judges, "convergence": convergence, "models": models, "answers": answers}


def main(parts=None) -> None:
    for name in parts or PARTS:
        print(f"-- {name}", flush=True)
        PARTS[name]()


if __name__ == "__main__":
    unknown = sorted(set(sys.argv[1:]) - set(PARTS))
    if unknown:
        sys.exit(f"unknown part(s) {', '.join(unknown)}; known: {', '.join(PARTS)}")
    main(sys.argv[1:] or None)
