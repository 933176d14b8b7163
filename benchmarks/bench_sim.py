"""Tilts per second per core and fault rate of the tray-tilt simulator (allen key, random actions
and uniform collision-free start poses) for the default contact (coulomb), the sphere and 4 legs,
with a naive free-body PyBullet loop side by side; the ratio of a default tilt's cost to a sphere
tilt's, measured in alternating chunks under the same load.

Run: ``python -m benchmarks sim`` (``make bench``). Both wall time and process (CPU) time are
printed: the machine may be shared, and CPU time is the honest per-core figure then.
"""
from __future__ import annotations

import math
import os
import time

import numpy as np

N_TILTS = int(os.environ.get("KRUSKAL_BENCH_TILTS", "4000"))
N_NAIVE = int(os.environ.get("KRUSKAL_BENCH_NAIVE", "600"))


def _ours(**settings):
    """The kruskal simulator: returns ``run(poses, actions) -> status``."""
    from transition_builder.scene import scene_from_options
    from transition_builder.sim import TraySimulator
    sim = TraySimulator(scene_from_options("allen-key", **settings))
    sim.prepare()                               # build the worlds outside the timing

    def run(poses, actions):
        status = np.empty(len(poses), dtype=np.int8)
        for a in range(8):
            m = actions == a
            _, status[m] = sim.tilt(poses[m], a)
        return status
    return run


def _naive():
    """A naive free body: the key as two boxes, 1/240 s, 10 iterations, default everything,
    rest checked every step from Python (speed < 1 mm/s and 0.03 rad/s for 0.1 s, max 4 s).
    Returns ``run(poses, actions) -> status`` (0 ok, 1 fault: tipped, escaped or unsettled)."""
    import pybullet as pb

    from transition_builder.scene import ACTION_ANGLES_DEG, ACTIONS, scene_from_options
    sc = scene_from_options("allen-key")
    cid = pb.connect(pb.DIRECT)
    pb.setTimeStep(1 / 240, physicsClientId=cid)
    pb.setPhysicsEngineParameter(numSolverIterations=10, physicsClientId=cid)
    fl = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[0.12, 0.12, 0.005], physicsClientId=cid)
    floor = pb.createMultiBody(0, fl, basePosition=[0.1, 0.1, -0.005], physicsClientId=cid)
    for (cx, cy), (hx, hy) in [((0.21, 0.1), (0.01, 0.12)), ((-0.01, 0.1), (0.01, 0.12)),
                               ((0.1, 0.21), (0.12, 0.01)), ((0.1, -0.01), (0.12, 0.01))]:
        ws = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[hx, hy, 0.015], physicsClientId=cid)
        pb.createMultiBody(0, ws, basePosition=[cx, cy, 0.015], physicsClientId=cid)
    pb.changeDynamics(floor, -1, lateralFriction=math.sqrt(0.3), physicsClientId=cid)
    he, pos = [], []
    for part in sc.shape.convex_parts:
        lo, hi = part.min(axis=0) / 1000, part.max(axis=0) / 1000
        he.append([(hi[0] - lo[0]) / 2, (hi[1] - lo[1]) / 2, 0.0025])
        pos.append([(hi[0] + lo[0]) / 2, (hi[1] + lo[1]) / 2, 0.0])
    cs = pb.createCollisionShapeArray([pb.GEOM_BOX] * len(he), halfExtents=he, collisionFramePositions=pos,
                                      physicsClientId=cid)
    body = pb.createMultiBody(sc.shape.mass_kg, cs, basePosition=[0.1, 0.1, 0.0025], physicsClientId=cid)
    pb.changeDynamics(body, -1, lateralFriction=math.sqrt(0.3), activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING,
                      physicsClientId=cid)
    g, a = 9.81, math.radians(30)

    def run(poses, actions):
        return np.array([_one(p, act) for p, act in zip(poses, actions)], dtype=np.int8)

    def _one(p, act):
        phi = math.radians(ACTION_ANGLES_DEG[ACTIONS[act]])
        pb.setGravity(g * math.sin(a) * math.cos(phi), g * math.sin(a) * math.sin(phi), -g * math.cos(a),
                      physicsClientId=cid)
        pb.resetBasePositionAndOrientation(body, [p[0] / 1000, p[1] / 1000, 0.0025],
                                           pb.getQuaternionFromEuler([0, 0, p[2]]), physicsClientId=cid)
        pb.resetBaseVelocity(body, [0, 0, 0], [0, 0, 0], physicsClientId=cid)
        still, ok = 0, False
        for _ in range(960):
            pb.stepSimulation(physicsClientId=cid)
            v, w = pb.getBaseVelocity(body, physicsClientId=cid)
            if math.hypot(v[0], v[1]) < 1e-3 and abs(w[2]) < 0.03:
                still += 1
                if still >= 24:
                    ok = True
                    break
            else:
                still = 0
        xyz, q = pb.getBasePositionAndOrientation(body, physicsClientId=cid)
        roll, pitch, _ = pb.getEulerFromQuaternion(q)
        inside = -0.001 < xyz[0] < 0.201 and -0.001 < xyz[1] < 0.201 and -0.001 < xyz[2] < 0.01
        return int(not ok or not inside or abs(roll) > 0.05 or abs(pitch) > 0.05)
    return run


def main():
    from transition_builder.sampling import sample_start_poses
    from transition_builder.shapes import parse_shape
    from transition_builder.status import fault_counts
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"machine: {os.cpu_count()} cores, load average {load:.2f} at start; the variants run in "
          f"alternating chunks so that they share the same load")
    variants = [("kruskal simulator (default: coulomb)", _ours(), N_TILTS),
                ("kruskal, contact sphere (the old default)", _ours(contact="sphere", time_step_s=1.0 / 240.0, substeps=4),
                 N_TILTS),
                ("kruskal, contact legs:4 (1/240 s, 50 it.)",
                 _ours(contact="legs:4", solver_iterations=50, time_step_s=1.0 / 240.0, substeps=4),
                 N_TILTS // 4),
                ("naive free body (10 it., 1/240 s)", _naive(), N_NAIVE)]
    shape = parse_shape("allen-key")
    rng = np.random.default_rng(1)
    chunks = 8
    stats = {name: [0.0, 0.0, [], 0] for name, _, _ in variants}
    for _ in range(chunks):
        for name, run, n in variants:
            k = max(1, n // chunks)
            poses = sample_start_poses(shape, 200.0, 200.0, k, rng)
            actions = rng.integers(0, 8, k)
            w0, c0 = time.perf_counter(), time.process_time()
            status = run(poses, actions)
            st = stats[name]
            st[0] += time.perf_counter() - w0
            st[1] += time.process_time() - c0
            st[2].append(status)
            st[3] += k
    for name, _, _ in variants:
        wall, cpu, status, n = stats[name]
        status = np.concatenate(status)
        nf = int(np.count_nonzero(status))
        detail = fault_counts(status) if name.startswith("kruskal") else "tipped/escaped/unsettled"
        print(f"{name:44s}: {n:5d} tilts  {n / cpu:6.1f} tilts/s per core (CPU)  {n / wall:6.1f} (wall)  "
              f"faults {nf} = {nf / n:.1e} {detail}")
    base = stats["kruskal, contact sphere (the old default)"]
    new = stats["kruskal simulator (default: coulomb)"]
    print(f"cost of a default (coulomb) tilt against a sphere tilt, side by side: "
          f"{(new[1] / new[3]) / (base[1] / base[3]):.2f}x CPU, {(new[0] / new[3]) / (base[0] / base[3]):.2f}x wall")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"load average {load:.2f} at end (other processes share the machine). Fault rates of 1e-4 "
          f"need >= 20,000 tilts: tests/transition_builder/test_sim_faults.py::test_fault_rate_20000_random_tilts")


if __name__ == "__main__":
    main()
