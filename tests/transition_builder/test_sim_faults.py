"""Fault rate, determinism and bad input of the tilt simulator."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from transition_builder.sampling import sample_start_poses
from transition_builder.scene import scene_from_options
from transition_builder.sim import TraySimulator
from transition_builder.simulators import simulate
from transition_builder.status import ESCAPED, INVALID, OK, TIPPED, fault_counts


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
from transition_builder.simulators import simulate
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

        def outside(pose, twist=None):      # 250 mm further east: beyond the east wall
            orig(np.array([pose[0] + 250.0, pose[1], pose[2]]), twist)
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


# ----------------------------------------------------------------------------- every fault status, once
def _tilt_with(scene, pose, action, patch):
    """One tilt with ``patch(world)`` applied to the action's world first (a constructed state or
    reading); returns (rest pose, status)."""
    with TraySimulator(scene) as sim:
        patch(sim._world(action))
        rest, status = sim.tilt([pose], action)
    return rest[0], int(status[0])


def _after_set_pose(world, extra):
    orig = world.set_pose

    def wrapped(pose, twist=None):
        orig(pose, twist)
        extra(world)
    world.set_pose = wrapped


def _raise_by(world, dz_mm):
    """Move the placed part ``dz_mm`` up (down if negative), whichever links carry it: the free
    base (``part_links="floating"``, the default) or the z slide of the chain."""
    import pybullet as pb

    from transition_builder._bullet_world import J_Z
    if world.floating:
        pos, orn = pb.getBasePositionAndOrientation(world.body, physicsClientId=world.cid)
        pb.resetBasePositionAndOrientation(world.body, [pos[0], pos[1], pos[2] + dz_mm * world.mm], orn,
                                           physicsClientId=world.cid)
    else:
        pb.resetJointState(world.body, J_Z, dz_mm * world.mm, 0.0, physicsClientId=world.cid)


def test_tipped_from_the_simulator_a_part_held_in_the_air_at_rest():
    """Physics: a square pressed against the downhill (east) wall, raised 20 mm after placing (its
    prism still below the 30 mm wall's top, which 30 mm would clear): it cannot move in x, y or
    yaw, so the rest test passes while it still falls, and it comes to 'rest' lifted off the
    floor: TIPPED, never a pose. The same start without the lift rests on the floor: OK."""
    from transition_builder.status import TIPPED

    sc = scene_from_options("rectangle:20x20")
    against_east = [200.0 - 10.0, 100.0, 0.0]
    rest, code = _tilt_with(sc, against_east, "E", lambda w: _after_set_pose(w, lambda w: _raise_by(w, 20.0)))
    assert code == TIPPED and np.all(np.isnan(rest))
    rest, code = _tilt_with(sc, against_east, "E", lambda w: None)
    assert code == OK and np.all(np.isfinite(rest))


@pytest.mark.parametrize("lift_over_tolerance, expected", [(1.5, "tipped"), (0.5, "ok")])
def test_tipping_threshold_is_the_lift_tolerance(lift_over_tolerance, expected):
    """By construction (the planar part cannot tip by itself): a part read at rest 1.5 lift
    tolerances above the floor is TIPPED, at 0.5 it is not."""
    from transition_builder.status import STATUS_NAMES

    sc = scene_from_options("rectangle:20x20")
    tol = sc.settings.lift_tolerance_mm

    def lifted(w):
        w.lift_mm = lambda: lift_over_tolerance * tol
    _, code = _tilt_with(sc, [100.0, 100.0, 0.0], "E", lifted)
    assert STATUS_NAMES[code] == expected


def test_escaped_in_flight_below_the_floor():
    """Physics: a part dropped 20 mm below the floor (more than the lift tolerance) fell through it."""
    sc = scene_from_options("rectangle:20x20")
    rest, code = _tilt_with(sc, [100.0, 100.0, 0.0], "E", lambda w: _after_set_pose(w, lambda w: _raise_by(w, -20.0)))
    assert code == ESCAPED and np.all(np.isnan(rest))


def test_escaped_after_landing_from_the_simulator():
    """Physics: a tilted square slides into the east wall and rests poking a few thousandths of a
    millimetre into it (contact penetration). With the default escape tolerance (1 mm) that is a
    valid landing; with a tolerance of 0.001 mm the same landing is not a valid start of the next
    tilt, so the part escaped (after landing, not in flight, and not tipped)."""
    from transition_builder.sim import valid_start
    from transition_builder.status import STATUS_NAMES

    sc = scene_from_options("rectangle:20x20")
    strict = sc.with_settings(escape_tolerance_mm=1e-3)
    start = [[100.0, 100.0, 0.3]]
    rest, status = simulate(sc, start, "E")
    assert status.tolist() == [OK]
    assert not valid_start(strict, rest)[0]        # the landing pokes more than 0.001 mm into the wall
    rest_strict, status_strict = simulate(strict, start, "E")
    assert STATUS_NAMES[status_strict[0]] == "escaped" and np.all(np.isnan(rest_strict))


def test_escaped_after_landing_by_construction():
    """By construction: a rest pose read 30 mm beyond the east wall is ESCAPED, never a pose."""
    from transition_builder.status import STATUS_NAMES

    def outside(w):
        w.to_tray = lambda x, y, yaw: (230.0, 100.0, 0.0)
    rest, code = _tilt_with(scene_from_options("rectangle:20x20"), [100.0, 100.0, 0.0], "E", outside)
    assert STATUS_NAMES[code] == "escaped" and np.all(np.isnan(rest))


def test_invalid_when_the_state_goes_non_finite_in_flight():
    """By construction: a NaN read from the engine mid-tilt is INVALID, never a pose."""
    sc = scene_from_options("rectangle:20x20")

    def nan_state(w):
        orig = w.state
        calls = {"n": 0}

        def state():
            calls["n"] += 1
            s = orig()
            return s if calls["n"] < 5 else (float("nan"),) + tuple(s[1:])
        w.state = state
    rest, code = _tilt_with(sc, [100.0, 100.0, 0.0], "E", nan_state)
    assert code == INVALID and np.all(np.isnan(rest))


def test_fault_counts():
    from transition_builder.status import FAULT_NAMES, STATUS_NAMES, TIPPED, UNSETTLED

    assert STATUS_NAMES == ("ok", "tipped", "escaped", "unsettled", "invalid") and FAULT_NAMES == STATUS_NAMES[1:]
    counts = fault_counts(np.array([[OK, TIPPED], [ESCAPED, ESCAPED], [UNSETTLED, INVALID]], dtype=np.int8))
    assert counts == {"tipped": 1, "escaped": 2, "unsettled": 1, "invalid": 1}
    assert fault_counts([]) == {"tipped": 0, "escaped": 0, "unsettled": 0, "invalid": 0}
    with pytest.raises(ValueError, match=r"^unknown status code\(s\) \[5, 7\]$"):
        fault_counts([0, 5, 7, 5])


def _scripted(sc, script, lift_mm=0.0, poses=((100.0, 100.0, 0.0),)):
    """Tilts on a scripted engine: after ``n`` steps the part is at ``script(n) = (x, y, z, yaw)``
    (metres and radians in the world frame; velocities zero), lifted ``lift_mm``; a rest pose reads
    as (50, 60, 0.5). Returns (rest poses, statuses, steps taken)."""
    steps = {"n": 0}
    with TraySimulator(sc) as sim:
        w = sim._world("E")

        def step():
            steps["n"] += 1
        w.step = step
        w.state = lambda: tuple(script(steps["n"])) + (0.0, 0.0, 0.0)
        w.set_pose = lambda pose, twist=None: None
        w.lift_mm = lambda: lift_mm
        w.to_tray = lambda x, y, yaw: (50.0, 60.0, 0.5)
        rest, status = sim.tilt(list(poses), "E")
    return rest, status, steps["n"]


def test_rest_needs_the_dwell_in_consecutive_still_intervals():
    """By construction: still for one interval short of the dwell, then one move, then still: the
    rest test counts from zero again after the move and stops after exactly the dwell of consecutive
    still intervals (2 x dwell intervals in all). A move is a step of the rest speed's distance in x
    or y (exactly: ``<`` is still), or of the rest yaw rate's angle (exactly)."""
    sc = scene_from_options("rectangle:20x20")
    st = sc.settings
    dwell = max(1, math.ceil(st.dwell_s / st.check_interval_s - 1e-9))
    assert dwell >= 2
    d_lin = st.rest_speed_mm_s / 1000.0 * st.check_interval_s          # metres per interval
    d_ang = st.rest_angular_speed_rad_s * st.check_interval_s
    for move in ((0.01, 0.0, 0.0), (0.0, 0.01, 0.0), (d_lin, 0.0, 0.0), (0.0, d_lin, 0.0), (0.0, 0.0, d_ang)):
        def script(n, move=move):
            return (move[0], move[1], 0.0, move[2]) if n >= dwell else (0.0, 0.0, 0.0, 0.0)
        rest, status, steps = _scripted(sc, script)
        assert status.tolist() == [OK] and rest.tolist() == [[50.0, 60.0, 0.5]]
        assert steps == 2 * dwell, move


def test_escape_and_tip_thresholds_by_construction():
    """Beyond the escape radius (x or y; at it exactly: inside), below the floor by more than the
    lift tolerance (at it exactly, or just inside: not escaped), lifted more than the tolerance
    (exactly: lying flat)."""
    sc = scene_from_options("rectangle:20x20")
    tol = sc.settings.lift_tolerance_mm
    with TraySimulator(sc) as sim:
        r_out = sim._r_out
    lift = tol / 1000.0
    cases = [((1.001 * r_out, 0.0, 0.0), 0.0, ESCAPED), ((0.0, 1.001 * r_out, 0.0), 0.0, ESCAPED),
             ((r_out, 0.0, 0.0), 0.0, OK), ((0.0, 0.0, -2 * lift), 0.0, ESCAPED),
             ((0.0, 0.0, -lift), 0.0, OK), ((0.0, 0.0, -0.9995 * lift), 0.0, OK),
             ((0.0, 0.0, 0.0), tol, OK), ((0.0, 0.0, 0.0), 1.0001 * tol, TIPPED)]
    for (x, y, z), lifted, want in cases:
        rest, status, steps = _scripted(sc, lambda n, x=x, y=y, z=z: (x, y, z, 0.0), lift_mm=lifted)
        assert status.tolist() == [want], (x, y, z, lifted)
        if want == ESCAPED:
            assert steps == 1 and np.all(np.isnan(rest))


def test_an_invalid_start_does_not_stop_the_batch():
    sc = scene_from_options("rectangle:20x20")
    rest, status, _ = _scripted(sc, lambda n: (0.0, 0.0, 0.0, 0.0), poses=[(-50.0, 100.0, 0.0), (100.0, 100.0, 0.0)])
    assert status.tolist() == [INVALID, OK] and rest[1].tolist() == [50.0, 60.0, 0.5]
