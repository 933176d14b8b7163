"""Where a model build's time goes: physics against everything that is not physics (issue 44).

Two measurements of one allen-key build (from scratch, no cache), each in a fresh process:

1. **Serial, under cProfile** (``SerialExecutor``): the build's time split into physics
   (``pybullet.stepSimulation``), the Python around each physics step (the contact update, joint
   reads, friction-limit and force calls), the rest test, trial resets, world rebuilds, start and
   landing checks, noise, snapping and representatives, weights, assembly, checkpoints and the
   exploration's own bookkeeping (the remainder). cProfile inflates Python-heavy parts, so the
   un-profiled serial wall time is given beside it. The inter-process traffic a local pool would
   add is measured on the same tasks: every task's arguments and result pickled and unpickled
   once (what ``ProcessPoolExecutor`` does).
2. **Parallel** (``LocalExecutor`` with 2 workers, the kept pool started before the timing): wall
   time, the parent's CPU time (snapping and bookkeeping compete with the workers for the cores)
   and the workers' CPU time; ``idle`` is ``2 * wall - workers' CPU``: worker time spent waiting
   (for the parent, for the last task of a phase) or taken by the parent.

Run: ``python -m benchmarks build_profile``. Settings: ``KRUSKAL_BENCH_PROFILE=RES:START[,...]``
(default ``4,4:300``: 4 mm / 4 deg, 300 start poses, about 30 s serial; the key's default build is
``0.25,0.25:5000``), ``KRUSKAL_BENCH_PROFILE_PARTS=serial,parallel``; ``KRUSKAL_BENCH_PROFILE_BEFORE=DIR``
runs the same measurements with the code of another checkout (e.g. ``../main``, a sibling worktree) first, side by
side in one run (``KRUSKAL_BENCH_PROFILE_ONLY=before`` or ``after``: one of the two). The parallel
build also profiles the parent alone: the time it waits for results, against the work only it
does (snapping, weights, assembly, checkpoints), during which the workers wait. Every build also prints a digest of the model's arrays, so a before/after pair
shows whether the two models are identical. ``KRUSKAL_BENCH_PROFILE_SIM`` (JSON, e.g.
``{"contact_pairs": "needed"}``) changes the simulator settings of the builds;
``KRUSKAL_BENCH_PROFILE_SAVE=PATH`` saves the parallel build's model there.
"""
from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import time

_CATEGORIES = (
    "physics (stepSimulation)", "python around each step", "rest test", "trial resets",
    "world rebuilds", "start and landing checks", "noise", "snapping and representatives",
    "weights", "assembly", "checkpoints", "exploration bookkeeping",
)


def model_digest(model) -> str:
    """SHA-256 of a model: its arrays (matrices, initial distribution, partition, extras) and its
    metadata but the run statistics (which hold the build time)."""
    import numpy as np
    import scipy.sparse as sp

    h = hashlib.sha256()

    def put(x):
        if sp.issparse(x):
            x = x.tocsr()
            for a in (x.indptr, x.indices, x.data):
                h.update(np.ascontiguousarray(a).tobytes())
        elif isinstance(x, np.ndarray):
            h.update(np.ascontiguousarray(x).tobytes())
        elif isinstance(x, (list, tuple)):
            for y in x:
                put(y)
        elif isinstance(x, dict):
            for k in sorted(x):
                h.update(str(k).encode())
                put(x[k])
        else:
            h.update(repr(x).encode())

    for name in ("actions", "matrices", "initial", "partition", "n_cells", "extras"):
        h.update(name.encode())
        put(getattr(model, name))
    put({k: v for k, v in model.metadata.items() if k != "stats"})
    return h.hexdigest()[:16]


def _settings(spec: str):
    from transition_builder.builder import BuildSettings

    res, start = spec.split(":")
    mm, deg = (float(v) for v in res.split(","))
    return BuildSettings(tol_mm=mm, tol_deg=deg, start_samples=int(start))


def _ct(stats, name: str, module: str = "") -> float:
    """Summed cumulative time of the functions called ``name`` (in a file ending ``module``)."""
    return sum(v[3] for k, v in stats.items() if k[2] == name and k[0].endswith(module))


class _PickleTimer:
    """A serial executor that also times the pickle round trip of every task and result."""

    def __init__(self):
        from transition_builder.executors import SerialExecutor

        self._inner = SerialExecutor()
        self.workers = 1
        self.seconds = 0.0
        self.bytes = 0
        self.tasks = 0

    def map(self, fn, tasks):
        import pickle

        for i, task in self._inner.map(lambda *a: a, tasks):
            t = time.perf_counter()
            blob = pickle.dumps((fn, task))
            fn2, args = pickle.loads(blob)
            self.seconds += time.perf_counter() - t
            res = fn2(*args)
            t = time.perf_counter()
            blob2 = pickle.dumps(res)
            res = pickle.loads(blob2)
            self.seconds += time.perf_counter() - t
            self.bytes += len(blob) + len(blob2)
            self.tasks += 1
            yield i, res

    def close(self):
        pass


def _serial(spec: str) -> dict:
    import cProfile
    import pstats

    from transition_builder.builder import build_model
    from transition_builder.executors import SerialExecutor
    from transition_builder.scene import scene_from_options

    scene = scene_from_options("allen-key", **json.loads(os.environ.get("KRUSKAL_BENCH_PROFILE_SIM", "{}")))
    settings = _settings(spec)
    t = time.perf_counter()
    plain = build_model(scene, settings, executor=SerialExecutor())
    wall_plain = time.perf_counter() - t
    ex = _PickleTimer()
    pr = cProfile.Profile()
    t = time.perf_counter()
    pr.enable()
    res = build_model(scene, settings, executor=ex)
    pr.disable()
    total = time.perf_counter() - t
    s = pstats.Stats(pr).stats
    physics = _ct(s, "<built-in method pybullet.stepSimulation>")
    step = _ct(s, "step", "_bullet_world.py")
    run = _ct(s, "_run", "sim.py")
    set_pose = _ct(s, "set_pose", "_bullet_world.py")
    world = _ct(s, "_world", "sim.py")
    tilt = _ct(s, "tilt", "sim.py")
    tasks = _ct(s, "tilt_chunk") + _ct(s, "tilt_task")
    snapping = sum(_ct(s, f, "representatives.py") for f in ("_offer", "_recenter", "_members",
                                                            "_refinement_candidates", "_snap_spread"))
    weights = _ct(s, "_orbit_weights") + _ct(s, "_heavy_orbits")
    assembly = _ct(s, "_assemble")
    ckpt = _ct(s, "save", "state.py")
    noise = _ct(s, "perturb_pose") + _ct(s, "perturb_poses")
    parts = [physics, step - physics, run - step - set_pose, set_pose, world, tilt - run - world, noise,
             snapping, weights, assembly, ckpt]
    parts.append(max(total - tasks - ex.seconds - snapping - weights - assembly - ckpt, 0.0))
    out = {"spec": spec, "wall_serial_s": wall_plain, "profiled_s": total,
           "tilts": int(res.stats["tilts_simulated"]), "states": int(res.model.n_states),
           "digest": model_digest(res.model), "digest_unprofiled": model_digest(plain.model),
           "task_count": ex.tasks, "pickle_s": ex.seconds, "pickle_mb": ex.bytes / 1e6,
           "categories": dict(zip(_CATEGORIES, parts)),
           "steps": int(sum(v[1] for k, v in s.items() if k[2] == "<built-in method pybullet.stepSimulation>"))}
    return out


def _proc_cpu(pids) -> float:
    tick = os.sysconf("SC_CLK_TCK")
    total = 0.0
    for pid in pids:
        try:
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            total += (int(fields[11]) + int(fields[12])) / tick
        except OSError:
            pass
    return total


def _parallel(spec: str, workers: int = 2) -> dict:
    import cProfile
    import pstats

    from transition_builder import executors
    from transition_builder.builder import build_model
    from transition_builder.executors import LocalExecutor
    from transition_builder.scene import scene_from_options

    scene = scene_from_options("allen-key", **json.loads(os.environ.get("KRUSKAL_BENCH_PROFILE_SIM", "{}")))
    ex = LocalExecutor(workers)
    pool = executors._get_pool(workers)
    for f in [pool.submit(executors._worker_pid) for _ in range(4 * workers)]:
        f.result()                                  # every worker up
    pids = list(pool._processes)
    pr = cProfile.Profile()
    cpu0, par0, t = _proc_cpu(pids), time.process_time(), time.perf_counter()
    pr.enable()
    res = build_model(scene, _settings(spec), executor=ex)
    pr.disable()
    wall = time.perf_counter() - t
    workers_cpu, parent_cpu = _proc_cpu(pids) - cpu0, time.process_time() - par0
    save = os.environ.get("KRUSKAL_BENCH_PROFILE_SAVE")
    if save:
        res.model.save(save)             # e.g. for a held-out validation of the model afterwards
    s = pstats.Stats(pr).stats
    # the parent's time: waiting for the workers' results (inside the executor's map) and its own work
    wait = _ct(s, "map", "executors.py")
    snapping = sum(_ct(s, f, "representatives.py") for f in ("_offer", "_recenter", "_members",
                                                            "_refinement_candidates", "_snap_spread"))
    parent = {"waiting for results": wait, "snapping and representatives": snapping,
              "weights": _ct(s, "_orbit_weights") + _ct(s, "_heavy_orbits"),
              "assembly": _ct(s, "_assemble"), "checkpoints": _ct(s, "save", "state.py")}
    parent["other parent work"] = max(wall - sum(parent.values()), 0.0)
    return {"spec": spec, "workers": workers, "wall_s": wall, "parent_cpu_s": parent_cpu,
            "workers_cpu_s": workers_cpu, "idle_s": max(workers * wall - workers_cpu, 0.0),
            "tilts": int(res.stats["tilts_simulated"]), "tilts_per_s": res.stats["tilts_simulated"] / wall,
            "digest": model_digest(res.model), "parent": parent}


def _child(part: str, spec: str) -> None:
    out = _serial(spec) if part == "serial" else _parallel(spec)
    print("RESULT " + json.dumps(out), flush=True)
    from transition_builder.executors import shutdown_workers

    shutdown_workers()


def _run_child(code_dir: str, part: str, spec: str) -> dict:
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([code_dir, here]))
    # the child runs this file with the other checkout's packages first on the path
    cmd = [sys.executable, os.path.abspath(__file__), "--child", part, spec]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    for line in p.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    raise RuntimeError(f"profile child failed ({code_dir}, {part}, {spec}):\n{p.stderr[-2000:]}")


def _print_serial(label: str, r: dict) -> None:
    prof = r["profiled_s"]
    print(f"\n[{label}] serial build {r['spec']}: {r['wall_serial_s']:.1f} s un-profiled, {prof:.1f} s under "
          f"cProfile; {r['tilts']:,} tilts, {r['states']:,} states, {r['steps']:,} stepSimulation calls, "
          f"{r['task_count']} tasks; model digest {r['digest']} (un-profiled {r['digest_unprofiled']})")
    print("| part | s (cProfile) | share |")
    print("|---|---|---|")
    for name, v in r["categories"].items():
        print(f"| {name} | {v:.2f} | {100 * v / prof:.1f}% |")
    print(f"| inter-process traffic (pickle round trip of every task, {r['pickle_mb']:.1f} MB) | "
          f"{r['pickle_s']:.2f} | {100 * r['pickle_s'] / prof:.1f}% |")


def _print_parallel(label: str, r: dict) -> None:
    print(f"\n[{label}] parallel build {r['spec']} on {r['workers']} workers: {r['wall_s']:.1f} s wall, "
          f"{r['tilts_per_s']:.0f} tilts/s; workers' CPU {r['workers_cpu_s']:.1f} s, parent's CPU "
          f"{r['parent_cpu_s']:.1f} s, worker idle {r['idle_s']:.1f} s "
          f"({100 * r['idle_s'] / (r['workers'] * r['wall_s']):.0f}% of {r['workers']} x wall); "
          f"model digest {r['digest']}")
    print("| parent's wall time (cProfile on the parent only) | s | share |")
    print("|---|---|---|")
    for name, v in r["parent"].items():
        print(f"| {name} | {v:.1f} | {100 * v / r['wall_s']:.1f}% |")


def main() -> None:
    specs = os.environ.get("KRUSKAL_BENCH_PROFILE", "4,4:300").split(";")
    parts = os.environ.get("KRUSKAL_BENCH_PROFILE_PARTS", "serial,parallel").split(",")
    before = os.environ.get("KRUSKAL_BENCH_PROFILE_BEFORE")
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    trees = ([("before", before)] if before else []) + [("after", here)]
    only = os.environ.get("KRUSKAL_BENCH_PROFILE_ONLY")
    trees = [t for t in trees if only in (None, t[0])]
    for spec in specs:
        for part in parts:
            for label, tree in trees:
                r = _run_child(tree, part, spec)
                (_print_serial if part == "serial" else _print_parallel)(label, r)


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--child":
        _child(sys.argv[2], sys.argv[3])
    else:
        main()
