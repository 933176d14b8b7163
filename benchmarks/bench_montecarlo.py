"""Direct Monte Carlo throughput: trials x tilts per second, one worker against all cores.

Measures, side by side in one run, ``run_direct`` on the allen key through a random sequence with
``workers=1`` and with every available core (processes), and the start-pose sampler alone.
Prints wall time, tilts per second, the parallel speed-up and the fault rate.
"""
from __future__ import annotations

import os
import time

import numpy as np

TRIALS = int(os.environ.get("KRUSKAL_BENCH_MC_TRIALS", "240"))
LENGTH = int(os.environ.get("KRUSKAL_BENCH_MC_LENGTH", "5"))


def main() -> None:
    from analysis.montecarlo import run_direct
    from transition_builder.executors import default_workers
    from transition_builder.sampling import sample_start_poses
    from transition_builder.scene import scene_from_options

    scene = scene_from_options("allen-key")
    seq = np.random.default_rng(0).integers(0, len(scene.actions), LENGTH).tolist()
    cores = default_workers()
    print(f"allen key, {TRIALS} trials x {LENGTH} random tilts, {cores} core(s) available "
          f"(load average before: {os.getloadavg()[0]:.2f})")

    t0 = time.perf_counter()
    sample_start_poses(scene.shape, scene.tray_x_mm, scene.tray_y_mm, 100_000, np.random.default_rng(0))
    print(f"start-pose sampling: {100_000 / (time.perf_counter() - t0):,.0f} poses/s")

    results = {}
    for workers in sorted({1, cores}):
        t0 = time.perf_counter()
        run_direct(scene, seq[:1], 32 * workers, seed=1, workers=workers)  # start pool, build simulators
        print(f"workers={workers}: start-up (pool + simulators, once per process) "
              f"{time.perf_counter() - t0:.2f} s")
        t0 = time.perf_counter()
        res = run_direct(scene, seq, TRIALS, seed=0, workers=workers)
        dt = time.perf_counter() - t0
        results[workers] = (dt, res)
        faults = sum(res.faults.values())
        print(f"workers={workers}: {dt:.2f} s wall, {res.tilts_simulated / dt:.1f} tilts/s total, "
              f"{res.tilts_simulated / dt / workers:.1f} tilts/s per worker, "
              f"faults {faults}/{res.tilts_simulated} tilts ({faults / max(res.tilts_simulated, 1):.2e}) "
              f"{res.faults}")
    if len(results) > 1:
        (d1, r1), (dn, rn) = results[1], results[cores]
        same = np.array_equal(r1.poses, rn.poses, equal_nan=True)
        print(f"speed-up with {cores} workers: {d1 / dn:.2f}x (ideal {cores}x); identical results: {same}")
    print(f"load average after: {os.getloadavg()[0]:.2f} (other jobs on the machine slow both runs)")


if __name__ == "__main__":
    main()
