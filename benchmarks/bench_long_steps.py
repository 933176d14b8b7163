"""Faster physics at the same judges and step convergence (issue 44): the default simulator beside
``contact_pairs=needed`` and a candidate with ``long_steps`` (docs/builder.md, "Longer steps while
the contact is steady").

Parts (``KRUSKAL_BENCH_LONG_PART``, comma-separated; default ``cpu``):

- ``cpu``: CPU seconds per tilt of every variant, side by side in alternating rounds
  (``KRUSKAL_BENCH_LONG_ROUNDS``, 2): ``KRUSKAL_BENCH_LONG_STARTS`` (300) uniform allen-key starts of
  seed 31 tilted E and NE (the issue's "physics tilts per second per core"), then the rest poses of
  those starts under E tilted N, NE, W and SW (a build's tilts start from rest poses, mostly against
  walls); landings within 1 mm / 1 degree of the default's; then a small serial build (8 mm / 8 deg,
  50 starts, seed 5): tilts per CPU second.
- ``worlds``: CPU per ``stepSimulation`` call of one world holding 1, 2, 4 or 8 keys in as many
  trays (:func:`worlds`): what stepping several trials in one world would save.
- ``judges``: the free-sliding judges (:func:`transition_builder.judges.judges_table`, 1/16 of the
  step) of the candidate against :data:`~transition_builder.judges.JUDGE_TARGETS`.
- ``build:LABEL`` (``default``, ``needed`` or ``candidate``): the key's default model built from
  scratch on 2 workers (wall time, CPU of the workers, tilts, states); saved to
  ``KRUSKAL_BENCH_LONG_SAVE``/``LABEL``.npz when that directory is set.
- ``validate``: the held-out validation (:data:`VALIDATION_SEED`, 3 sequences x 30 tilts,
  ``KRUSKAL_BENCH_LONG_TRIALS`` trials, 2,000 by default) of the saved ``default`` and
  ``candidate`` models against the same direct simulation under the default simulator.
- ``family:LABEL:MU``: one member of a five-coefficient family of the key at the fit's grid (1 mm /
  1 degree, one recentring round, 2,000 starts), built from scratch on 2 workers with the variant's
  settings; run MU = 0.2, 0.25, 0.3, 0.35, 0.4 as separate jobs and add the times.

The step convergence is ``python -m benchmarks contact`` with
``KRUSKAL_BENCH_CONTACT_MODELS=coulomb,coulomb-needed,coulomb-needed-stick``.
Run: ``KRUSKAL_BENCH_LONG_PART=cpu,judges python -m benchmarks long_steps``.
"""
from __future__ import annotations

import json
import math
import os
import time

import numpy as np

STARTS = int(os.environ.get("KRUSKAL_BENCH_LONG_STARTS", "300"))
ROUNDS = int(os.environ.get("KRUSKAL_BENCH_LONG_ROUNDS", "2"))
#: the variants compared (SimSettings changes): today's default, the pairs alone, the candidate
VARIANTS = {"default": {},
            "needed": {"contact_pairs": "needed"},
            "candidate": {"contact_pairs": "needed", "long_steps": "free+stick"}}
#: the held-out seed of the validation (named in docs/builder.md before its first run)
VALIDATION_SEED = 6047


def _agree(a, b) -> float:
    ok = np.isfinite(a[:, 0]) & np.isfinite(b[:, 0])
    d = np.hypot(*(a[ok, :2] - b[ok, :2]).T)
    th = np.abs((a[ok, 2] - b[ok, 2] + math.pi) % (2 * math.pi) - math.pi)
    return float(np.mean((d <= 1.0) & (th <= math.radians(1.0))))


def _tilts(settings: dict, starts) -> dict:
    """CPU seconds and landings of the uniform tilts (E, NE) and of the rest-pose tilts (the rest
    poses under E, tilted N, NE, W, SW) under ``settings``."""
    from transition_builder.scene import scene_from_options
    from transition_builder.sim import TraySimulator
    with TraySimulator(scene_from_options("allen-key", **settings)) as sim:
        sim.prepare()
        t = time.process_time()
        uni = np.concatenate([sim.tilt(starts, a)[0] for a in ("E", "NE")])
        c_uni = time.process_time() - t
        rest, st = sim.tilt(starts, "E")
        rest = rest[st == 0]
        t = time.process_time()
        wall = np.concatenate([sim.tilt(rest, a)[0] for a in ("N", "NE", "W", "SW")])
        c_wall = time.process_time() - t
    return {"uniform": (uni, c_uni), "rest": (wall, c_wall)}


def _small_build(settings: dict) -> tuple[float, int]:
    from transition_builder.builder import BuildSettings, build_model
    from transition_builder.executors import SerialExecutor
    from transition_builder.scene import scene_from_options
    t = time.process_time()
    r = build_model(scene_from_options("allen-key", **settings),
                    BuildSettings(tol_mm=8, tol_deg=8, start_samples=50, seed=5), executor=SerialExecutor())
    return time.process_time() - t, int(r.stats["tilts_simulated"])


def cpu_side_by_side(variants: dict | None = None, rounds: int | None = None) -> dict:
    """Every variant (``variants``: label -> SimSettings changes, the first the reference; default
    :data:`VARIANTS`), alternating, ``rounds`` (default ``ROUNDS``) times: CPU per tilt, agreement
    with the first variant's landings."""
    variants = VARIANTS if variants is None else variants
    rounds = ROUNDS if rounds is None else rounds
    first = next(iter(variants))
    from transition_builder.sampling import sample_start_poses
    from transition_builder.shapes import parse_shape
    starts = sample_start_poses(parse_shape("allen-key"), 200.0, 200.0, STARTS, np.random.default_rng(31))
    rows = {k: {"uniform_ms": [], "rest_ms": [], "small_build_tilts_per_cpu_s": []} for k in variants}
    ref = None
    for settings in variants.values():
        _tilts(settings, starts[:5])            # warm up (imports, compiled kernels) outside the timings
    for rnd in range(rounds):
        for label, settings in variants.items():
            r = _tilts(settings, starts)
            if label == first:
                ref = r
            row = rows[label]
            for part in ("uniform", "rest"):
                row[f"{part}_ms"].append(1e3 * r[part][1] / len(r[part][0]))
                row[f"{part}_within_1mm_1deg_of_{first}"] = _agree(r[part][0], ref[part][0])
            c, n = _small_build(settings)
            row["small_build_tilts_per_cpu_s"].append(n / c)
            print(f"round {rnd + 1}, {label}: uniform {row['uniform_ms'][-1]:.2f} ms/tilt, rest poses "
                  f"{row['rest_ms'][-1]:.2f} ms/tilt, small build {n / c:.0f} tilts/CPU s", flush=True)
    base = {k: float(np.mean(rows[first][k])) for k in ("uniform_ms", "rest_ms")}
    for label, row in rows.items():
        row["uniform_speedup"] = base["uniform_ms"] / float(np.mean(row["uniform_ms"]))
        row["rest_speedup"] = base["rest_ms"] / float(np.mean(row["rest_ms"]))
        print(f"{label}: " + json.dumps(row), flush=True)
    return rows


def judges(settings: dict | None = None) -> dict:
    """The judges of the variant ``settings`` (default: the candidate)."""
    from transition_builder.judges import JUDGE_TARGETS, judges_table
    c = VARIANTS["candidate"] if settings is None else settings
    j = judges_table(("coulomb",), mu=0.3, refine=16, **c)["coulomb"]
    fails = [k for k, v in j.items() if not v <= JUDGE_TARGETS[k]]
    print("judges, " + json.dumps(c) + ": " + json.dumps({k: round(v, 5) for k, v in j.items()})
          + f"; failing: {fails or 'none'}", flush=True)
    return j


def build(label: str, build_settings=None, friction=None, settings: dict | None = None) -> dict:
    """The key's model with variant ``label`` (its SimSettings changes ``settings``, default
    ``VARIANTS[label]``) built from scratch on 2 workers (no cache): wall time, the workers' CPU
    seconds (from /proc, as ``python -m benchmarks build_profile`` counts them)."""
    from benchmarks.bench_build_profile import _proc_cpu, model_digest
    from transition_builder import executors
    from transition_builder.builder import BuildSettings, build_model
    from transition_builder.scene import scene_from_options
    args = (friction,) if friction is not None else ()
    sc = scene_from_options("allen-key", *args, **(VARIANTS[label] if settings is None else settings))
    ex = executors.LocalExecutor(2)
    pool = executors._get_pool(2)
    for f in [pool.submit(executors._worker_pid) for _ in range(8)]:
        f.result()                                  # every worker up
    pids = list(pool._processes)
    cpu0, par0, t = _proc_cpu(pids), time.process_time(), time.perf_counter()
    r = build_model(sc, build_settings or BuildSettings(), executor=ex)
    out = {"label": label, "friction": friction, "wall_s": time.perf_counter() - t,
           "workers_cpu_s": _proc_cpu(pids) - cpu0, "parent_cpu_s": time.process_time() - par0,
           "tilts": int(r.stats["tilts_simulated"]),
           "states": r.model.n_states, "digest": model_digest(r.model)}
    out["tilts_per_worker_cpu_s"] = out["tilts"] / out["workers_cpu_s"]
    save = os.environ.get("KRUSKAL_BENCH_LONG_SAVE")
    if save and friction is None:
        os.makedirs(save, exist_ok=True)
        r.model.save(os.path.join(save, f"{label}.npz"))
    print("build " + json.dumps(out), flush=True)
    return out


def validate(trials: int, labels=("default", "candidate"), seed: int = VALIDATION_SEED, own: bool = False) -> dict:
    """Held-out validation of the saved models ``labels`` (``KRUSKAL_BENCH_LONG_SAVE``/LABEL.npz)
    against one direct simulation under the default simulator (seed ``seed``); with ``own``, each
    model against a direct simulation under its own simulator settings instead (how well the
    builder represents its physics, apart from the change of physics)."""
    from analysis.validate import validate_model
    from kruskal_markov.model import TransitionModel
    from transition_builder.tilting import run_direct
    save = os.environ["KRUSKAL_BENCH_LONG_SAVE"]
    refs = {}

    def simulate(sc, sq, m, sd, nz):
        if not own:
            sc = sc.with_settings(contact_pairs="all", long_steps="free",      # ground truth: today's simulator
                                  part_links="per-part")
        key = (tuple(int(a) for a in sq) if not isinstance(sq, str) else sq, m, sd, str(nz), sc.content_hash())
        if key not in refs:
            refs[key] = run_direct(sc, sq, m, seed=sd, workers=2, noise=nz)
        return refs[key]

    out = {}
    for label in labels:
        v = validate_model(TransitionModel.load(os.path.join(save, f"{label}.npz")), sequences=3, trials=trials,
                           seed=seed, length=30, bands=0, workers=2, simulate=simulate)
        out[label] = {k: v[k] for k in ("mean_abs_error_bits", "max_abs_error_bits", "final_tv_distance",
                                        "reference_noise_bits")}
        print(f"validation (seed {seed}, M = {trials}{', own simulator' if own else ''}), {label}: " + json.dumps(out[label]), flush=True)
    return out


def worlds(counts=(1, 2, 4, 8), calls: int = 200) -> dict:
    """CPU per ``stepSimulation`` call (two 1/480 s steps) of one world holding ``N`` keys in ``N``
    trays one metre apart (``contact_pairs=needed``): with every part at rest against the east wall
    (tilted E), and with every part released in the open. Does one call serve several trials?"""
    import pybullet as pb

    from transition_builder._bullet_world import BulletWorld
    from transition_builder.scene import scene_from_options
    from transition_builder.sim import TraySimulator
    sc = scene_from_options("allen-key", contact_pairs="needed")
    with TraySimulator(sc) as sim:
        wall_pose = sim.tilt([[100.0, 100.0, 0.0]], "E")[0][0]
    out = {}
    for n in counts:
        w = BulletWorld(sc, sc.downhill_angle(sc.action_index("E")))
        cid, c0, bodies = w.cid, w.centre.copy(), [w.body]
        for k in range(1, n):
            w.centre = c0 - np.array([k * 1000.0, 0.0])     # tray k one metre further along +x
            w._build_tray(sc, cid)
            w._build_part(sc, sc.settings, cid)
            bodies.append(w.body)
        for label, pose in (("wall", wall_pose), ("open", (100.0, 100.0, 0.3))):
            for k, b in enumerate(bodies):
                w.centre = c0 - np.array([k * 1000.0, 0.0])
                wx, wy = w._world_xy(pose[:2])
                for j, q in ((0, wx), (1, wy), (2, 0.0), (3, pose[2] - w.phi)):
                    pb.resetJointState(b, j, float(q), 0.0, physicsClientId=cid)
            for _ in range(5):
                pb.stepSimulation(physicsClientId=cid)
            t = time.process_time()
            for _ in range(calls):
                pb.stepSimulation(physicsClientId=cid)
            us = 1e6 * (time.process_time() - t) / calls
            out[f"{label}, N={n}"] = {"us_per_call": us, "us_per_part": us / n}
            print(f"one world, {n} parts, {label}: {us:.0f} us per call, {us / n:.0f} us per part", flush=True)
        w.close()
    return out


def main():
    from transition_builder.builder import BuildSettings
    for part in os.environ.get("KRUSKAL_BENCH_LONG_PART", "cpu").split(","):
        if part == "cpu":
            cpu_side_by_side()
        elif part == "worlds":
            worlds()
        elif part == "judges":
            judges()
        elif part.startswith("build:"):
            build(part.split(":")[1])
        elif part == "validate":
            validate(int(os.environ.get("KRUSKAL_BENCH_LONG_TRIALS", "2000")))
        elif part.startswith("family:"):
            _, label, mu = part.split(":")
            build(label, BuildSettings.compared(), float(mu))
        else:
            raise SystemExit(f"unknown part {part!r}: cpu, worlds, judges, build:LABEL, validate, "
                             "family:LABEL:MU")


if __name__ == "__main__":
    main()
