"""Fault rate, determinism and bad input of the tilt simulator."""
from __future__ import annotations

import json
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from transition_builder.sampling import sample_start_poses
from transition_builder.scene import scene_from_options
from transition_builder.sim import TraySimulator, simulate
from transition_builder.status import ESCAPED, INVALID, OK, fault_counts


def _random_tilts(seed: int, n: int):
    """n random tilts of the allen key from uniform collision-free poses: (status counts, tilts)."""
    sc = scene_from_options("allen-key")
    rng = np.random.default_rng(seed)
    poses = sample_start_poses(sc.shape, sc.tray_x_mm, sc.tray_y_mm, n, rng)
    actions = rng.integers(0, len(sc.actions), n)
    status = np.empty(n, dtype=np.int8)
    with TraySimulator(sc) as sim:
        for a in range(len(sc.actions)):
            m = actions == a
            _, status[m] = sim.tilt(poses[m], a)
    return fault_counts(status), n


def test_no_faults_in_2000_random_tilts():
    """The default suite's census: 2,000 random tilts of the allen key from random poses, no fault
    (the 20,000-tilt census behind the README's figure runs with ``-m slow``)."""
    counts, n = _random_tilts(303, 2_000)
    assert n == 2_000 and sum(counts.values()) == 0, counts


@pytest.mark.slow
def test_no_faults_in_20000_random_tilts():
    """The README's figure: 0 faults in 20,000 random tilts of the allen key from random poses."""
    with ProcessPoolExecutor(max_workers=2) as ex:
        results = list(ex.map(_random_tilts, [101, 202], [10_000, 10_000]))
    faults = sum(sum(c.values()) for c, _ in results)
    tilts = sum(n for _, n in results)
    assert tilts == 20_000
    assert faults == 0, [c for c, _ in results]


_CHILD = """
import json, sys, numpy as np
from transition_builder.scene import scene_from_options
from transition_builder.sampling import sample_start_poses
from transition_builder.sim import simulate
sc = scene_from_options("allen-key", "map:medium:4")
poses = sample_start_poses(sc.shape, 200.0, 200.0, 12, np.random.default_rng(11))
rest, status = simulate(sc, poses, sys.argv[1])
print(json.dumps({"rest": rest.tolist(), "status": status.tolist()}))
"""


def test_same_input_same_output_across_processes():
    """A fresh process gives bit-identical rest poses, and so does a batch run in another order."""
    sc = scene_from_options("allen-key", "map:medium:4")
    poses = sample_start_poses(sc.shape, 200.0, 200.0, 12, np.random.default_rng(11))
    rest, status = simulate(sc, poses, "SW")
    out = subprocess.run([sys.executable, "-c", _CHILD, "SW"], capture_output=True, text=True, check=True)
    child = json.loads(out.stdout)
    assert child["status"] == status.tolist()
    assert np.array_equal(np.array(child["rest"]), rest)          # bit for bit
    # order independence: one at a time, in reverse, after tilts in another direction
    with TraySimulator(sc) as sim:
        sim.tilt(poses[::-1], "SW")
        single = np.array([sim.tilt(poses[i:i + 1], "SW")[0][0] for i in range(len(poses) - 1, -1, -1)])[::-1]
    assert np.array_equal(single, rest)


def test_invalid_and_faulted_trials_are_never_poses():
    sc = scene_from_options("allen-key")
    poses = np.array([[100.0, 100.0, 0.5],            # fine
                      [np.nan, 100.0, 0.0],            # not finite
                      [2.0, 100.0, 0.0],               # overlaps the west wall
                      [100.0, 100.0, np.inf]])
    rest, status = simulate(sc, poses, "N")
    assert status.tolist() == [OK, INVALID, INVALID, INVALID]
    assert np.all(np.isfinite(rest[0])) and np.all(np.isnan(rest[1:]))
    assert status.dtype == np.int8


def test_escape_is_detected_without_walls_in_the_way():
    """Force a part out of the tray (teleport it beyond the east wall mid-run): ESCAPED, NaN pose."""
    sc = scene_from_options("rectangle:20x20")
    with TraySimulator(sc) as sim:
        w = sim._world("E")
        orig = w.set_pose

        def outside(pose):
            orig(pose)
            import pybullet as pb
            pb.resetJointState(w.body, 0, 250.0 * w.mm, 0.0, physicsClientId=w.cid)   # 250 mm east of centre
        w.set_pose = outside
        rest, status = sim.tilt([[100.0, 100.0, 0.0]], "E")
    assert status[0] == ESCAPED and np.all(np.isnan(rest))


def test_unsettled_when_time_runs_out():
    sc = scene_from_options("rectangle:20x20", max_time_s=0.05, dwell_s=0.04)
    rest, status = simulate(sc, [[20.0, 100.0, 0.0]], "E")
    assert status[0] == 3 and np.all(np.isnan(rest))


@pytest.mark.parametrize("action", ["X", "north", 8, -1, None, 2.5])
def test_unknown_action_is_a_clear_value_error(action):
    sc = scene_from_options("allen-key")
    with pytest.raises(ValueError, match="action"):
        simulate(sc, [[100.0, 100.0, 0.0]], action)


def test_subset_action_set_indexing():
    sc = scene_from_options("allen-key", actions="E,N")
    assert sc.actions == ("N", "E")
    with pytest.raises(ValueError, match="unknown action"):
        simulate(sc, [[100.0, 100.0, 0.0]], "S")
    r_name, _ = simulate(sc, [[100.0, 100.0, 0.0]], "E")
    r_idx, _ = simulate(sc, [[100.0, 100.0, 0.0]], 1)
    assert np.array_equal(r_name, r_idx)


@pytest.mark.parametrize("poses", [np.zeros((3, 2)), np.zeros(4), np.zeros((2, 3, 1))])
def test_bad_pose_shape(poses):
    with pytest.raises(ValueError, match="poses"):
        simulate(scene_from_options("allen-key"), poses, "E")


def test_friction_map_changes_outcomes_but_stays_sane():
    """A high-noise friction map changes where parts rest (vs uniform) yet produces no faults."""
    poses = sample_start_poses(scene_from_options("allen-key").shape, 200.0, 200.0, 30,
                               np.random.default_rng(5))
    r_u, s_u = simulate(scene_from_options("allen-key", 0.3), poses, "NE")
    r_m, s_m = simulate(scene_from_options("allen-key", "map:high:1"), poses, "NE")
    assert np.all(s_u == OK) and np.all(s_m == OK)
    assert not np.allclose(r_u, r_m, atol=1e-3)


@pytest.mark.parametrize("spec", [f"triangle:{i}" for i in range(1, 16)] + ["rectangle:80x10"])
def test_sequences_of_tilts_of_other_shapes_do_not_fault(spec):
    """The paper's random triangles (sharp corners) and a slender rectangle through 4-tilt random
    sequences, each tilt starting from the previous rest pose: no faults in 4 x 25 tilts."""
    sc = scene_from_options(spec)
    rng = np.random.default_rng(5)
    poses = sample_start_poses(sc.shape, 200.0, 200.0, 25, rng)
    with TraySimulator(sc) as sim:
        for _ in range(4):
            actions = rng.integers(0, 8, len(poses))
            status = np.empty(len(poses), dtype=np.int8)
            for a in range(8):
                m = actions == a
                poses[m], status[m] = sim.tilt(poses[m], a)
            assert np.all(status == OK), fault_counts(status)
