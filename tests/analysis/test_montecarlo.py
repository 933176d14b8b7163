"""Tests for analysis.montecarlo: direct Monte Carlo bookkeeping, parallel determinism, pose files.

The bookkeeping tests use a fake simulator (a deterministic "slide straight to the wall" rule with
injected faults) and check run_direct against an independent trial-by-trial loop. End-to-end
tests with the PyBullet simulator are at the end of the file.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass

import numpy as np
import pytest

from analysis.montecarlo import (
    DirectResult,
    entropy_by_step,
    read_poses_csv,
    resolve_sequence,
    run_direct,
    write_poses_csv,
)
from kruskal_markov.entropy import histogram_entropy_bits
from transition_builder.grid import ReportGrid
from transition_builder.sampling import sample_start_poses
from transition_builder.shapes import parse_shape
from transition_builder.status import ESCAPED, INVALID, OK, STATUS_NAMES, TIPPED, UNSETTLED

ACTIONS = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")
DIRECTIONS = {"N": 90, "NE": 45, "E": 0, "SE": -45, "S": -90, "SW": -135, "W": 180, "NW": 135}


@dataclass(frozen=True)
class FakeScene:
    shape: object
    tray_x_mm: float = 200.0
    tray_y_mm: float = 200.0
    actions: tuple = ACTIONS


def _slide(shape, pose, action, a, b):
    """Translate the part along the action's downhill direction until a vertex touches a wall."""
    ang = math.radians(DIRECTIONS[action])
    d = np.array([math.cos(ang), math.sin(ang)])
    d[np.abs(d) < 1e-12] = 0.0
    v = shape.placed(pose)
    travel = np.inf
    for axis, size in ((0, a), (1, b)):
        if d[axis] > 0:
            travel = min(travel, np.min((size - v[:, axis]) / d[axis]))
        elif d[axis] < 0:
            travel = min(travel, np.min(-v[:, axis] / d[axis]))
    out = np.array(pose, dtype=float)
    out[:2] += max(travel, 0.0) * d
    return out


def _fault_of(pose, action):
    """Injected faults: a deterministic function of the start orientation and the action."""
    key = int(pose[2] * 1e4)
    if key % 23 == ACTIONS.index(action):
        return (TIPPED, ESCAPED, UNSETTLED, INVALID)[(key // 23) % 4]
    return OK


class FakeSimulator:
    """A picklable stand-in for TraySimulator: ``tilt(poses, action) -> (rest, status)``."""

    builds = 0

    def __init__(self, scene, faults=True):
        self.scene = scene
        self.faults = faults
        FakeSimulator.builds += 1

    def tilt(self, poses, action):
        poses = np.asarray(poses, dtype=float)
        rest = np.empty_like(poses)
        status = np.zeros(len(poses), dtype=np.int64)
        for i, p in enumerate(poses):
            st = _fault_of(p, action) if self.faults else OK
            status[i] = st
            # a misbehaving engine might return garbage for a fault: run_direct must never keep it
            rest[i] = _slide(self.scene.shape, p, action, self.scene.tray_x_mm, self.scene.tray_y_mm) \
                if st == OK else [1e9, -1e9, 7.0]
        return rest, status


def fake_factory(scene):
    return FakeSimulator(scene)


def fake_factory_no_faults(scene):
    return FakeSimulator(scene, faults=False)


@pytest.fixture(scope="module")
def scene():
    return FakeScene(shape=parse_shape("allen-key"))


SEQ = ["NE", "S", "W", "W", "N", "SE", "E", "SW", "NW", "N"]


def _reference(scene, starts, seq, grid):
    """Trial-by-trial loop, written independently of run_direct."""
    sim = FakeSimulator(scene)
    m, n = len(starts), len(seq)
    poses = np.full((m, n + 1, 3), np.nan)
    status = np.zeros((m, n + 1), dtype=int)
    faults = {name: 0 for name in STATUS_NAMES[1:]}
    for t in range(m):
        p = starts[t]
        poses[t, 0] = p
        for k, act in enumerate(seq, start=1):
            rest, st = sim.tilt(p[None, :], act)
            status[t, k] = st[0]
            if st[0] != OK:
                faults[STATUS_NAMES[st[0]]] += 1
                status[t, k + 1:] = st[0]
                break
            p = rest[0]
            poses[t, k] = p
    entropy = []
    for k in range(n + 1):
        ok = status[:, k] == OK
        counts = np.bincount(grid.voxel_index(poses[ok, k]), minlength=grid.n_voxels)
        entropy.append(histogram_entropy_bits(counts))
    return poses, status, faults, np.array(entropy)


def test_bookkeeping_matches_trial_by_trial_loop(scene):
    res = run_direct(scene, SEQ, 400, seed=5, workers=1, simulator_factory=fake_factory)
    assert isinstance(res, DirectResult)
    starts = sample_start_poses(scene.shape, 200, 200, 400, np.random.default_rng(5))
    poses, status, faults, entropy = _reference(scene, starts, SEQ, res.grid)
    np.testing.assert_array_equal(res.poses[:, 0], starts)
    np.testing.assert_array_equal(res.status, status)
    np.testing.assert_allclose(res.poses, poses, equal_nan=True)
    np.testing.assert_allclose(res.entropy_bits, entropy, rtol=0, atol=1e-12)
    assert res.faults == faults
    assert sum(faults.values()) > 10 and all(v > 0 for v in faults.values())  # the test exercises faults
    # surviving counts drop exactly by the faults at each step; faulted poses are NaN
    assert res.surviving[0] == 400
    assert res.surviving[-1] == 400 - sum(faults.values())
    assert np.all(np.diff(res.surviving) <= 0)
    assert np.all(np.isnan(res.poses[res.status != OK]))
    assert res.tilts == len(SEQ) and res.trials == 400
    assert res.tilts_simulated == int(res.surviving[:-1].sum())
    js = res.to_dict()
    assert len(js["entropy_bits"]) == len(SEQ) + 1
    assert set(js["faults"]) == {"tipped", "escaped", "unsettled", "invalid"}
    assert js["sequence"] == SEQ


def test_entropy_drops_after_first_tilt_in_slide_model(scene):
    # the fake "slide to the wall" model: after one tilt every part touches the east wall, so the
    # x coordinate is confined to one bin and the entropy falls by about log2(4) = 2 bits
    res = run_direct(scene, ["E"], 2000, seed=1, workers=1, simulator_factory=fake_factory_no_faults)
    assert res.entropy_bits[0] > 5.0
    assert res.entropy_bits[0] - res.entropy_bits[1] > 1.5
    ix = res.grid.bin_indices(res.poses[:, 1])[0]
    assert np.all(ix == 3)


def test_same_result_for_any_number_of_workers(scene):
    a = run_direct(scene, SEQ[:4], 150, seed=9, workers=1, simulator_factory=fake_factory)
    b = run_direct(scene, SEQ[:4], 150, seed=9, workers=2, simulator_factory=fake_factory)
    np.testing.assert_array_equal(a.poses, b.poses)
    np.testing.assert_array_equal(a.status, b.status)
    np.testing.assert_array_equal(a.entropy_bits, b.entropy_bits)
    assert a.faults == b.faults
    c = run_direct(scene, SEQ[:4], 150, seed=10, workers=1, simulator_factory=fake_factory)
    assert not np.array_equal(a.poses[:, 0], c.poses[:, 0])


def test_simulator_built_once_per_process(scene):
    from transition_builder.simulators import _sim_cache

    _sim_cache().clear()
    FakeSimulator.builds = 0
    run_direct(scene, SEQ[:2], 600, seed=0, workers=1, simulator_factory=fake_factory)
    assert FakeSimulator.builds == 1  # many chunks, one simulator
    run_direct(scene, SEQ[2:4], 100, seed=1, workers=1, simulator_factory=fake_factory)
    assert FakeSimulator.builds == 1  # kept for the next call with the same scene
    run_direct(FakeScene(shape=parse_shape("rectangle:40x20")), SEQ[:1], 10, workers=1,
               simulator_factory=fake_factory)
    assert FakeSimulator.builds == 2  # a new scene gets its own simulator


def test_sequence_forms_and_errors(scene):
    assert resolve_sequence("NE,s, W", ACTIONS).tolist() == [1, 4, 6]
    assert resolve_sequence([0, "e", np.int64(7)], ACTIONS).tolist() == [0, 2, 7]
    with pytest.raises(ValueError, match="unknown action 'UP'"):
        resolve_sequence("N,UP", ACTIONS)
    with pytest.raises(ValueError, match="out of range"):
        resolve_sequence([8], ACTIONS)
    empty = run_direct(scene, [], 50, seed=0, workers=1, simulator_factory=fake_factory)
    assert empty.entropy_bits.shape == (1,) and empty.tilts == 0


def test_start_poses_and_argument_errors(scene):
    starts = np.array([[100.0, 100.0, 0.1], [60.0, 150.0, 2.0]])
    res = run_direct(scene, ["S"], None, start_poses=starts, workers=1, simulator_factory=fake_factory_no_faults)
    np.testing.assert_array_equal(res.poses[:, 0], starts)
    for i in range(2):
        np.testing.assert_allclose(res.poses[i, 1], _slide(scene.shape, starts[i], "S", 200, 200))
    with pytest.raises(ValueError, match="trials"):
        run_direct(scene, ["S"], 0, simulator_factory=fake_factory)
    with pytest.raises(ValueError, match="start poses"):
        run_direct(scene, ["S"], 3, start_poses=starts, simulator_factory=fake_factory)
    with pytest.raises(ValueError, match="workers"):
        run_direct(scene, ["S"], 3, workers=0, simulator_factory=fake_factory)


def test_grid_options(scene):
    res = run_direct(scene, ["E", "N"], 300, seed=2, workers=1, grid="2x3x5", theta_offset=0.0,
                     simulator_factory=fake_factory_no_faults)
    assert res.grid.shape == (2, 3, 5) and res.grid.theta_offset == 0.0
    g = ReportGrid(200, 200, 2, 3, 5, theta_offset=0.0)
    for k in range(3):
        assert res.entropy_bits[k] == pytest.approx(g.entropy_bits(res.poses[:, k]))
    with pytest.raises(ValueError, match="grid"):
        run_direct(scene, ["E"], 10, grid="4x4", simulator_factory=fake_factory)


def test_symmetric_shape_uses_reduced_theta():
    sq = FakeScene(shape=parse_shape("rectangle:30x30"))
    res = run_direct(sq, ["E"], 100, seed=0, workers=1, simulator_factory=fake_factory_no_faults)
    assert res.grid.symmetry_order == 4


# ---------------------------------------------------------------------------------- pose files

def test_poses_csv_roundtrip(scene, tmp_path):
    res = run_direct(scene, SEQ, 200, seed=3, workers=1, simulator_factory=fake_factory)
    path = tmp_path / "sub" / "poses.csv"
    write_poses_csv(path, res)
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["trial", "step", "x_mm", "y_mm", "theta_rad", "status"]
    n_faulted = int((res.fault_step >= 0).sum())
    expected_rows = int(res.surviving.sum()) + n_faulted  # every ok pose, plus one row per fault
    assert len(rows) - 1 == expected_rows
    assert {r[5] for r in rows[1:]} <= set(STATUS_NAMES)
    rec = read_poses_csv(path)
    assert rec.trials == 200 and rec.n_steps == len(SEQ) + 1
    np.testing.assert_allclose(entropy_by_step(rec, res.grid), res.entropy_bits, atol=1e-12)
    ok = rec.status == OK
    np.testing.assert_array_equal(rec.poses[ok], res.poses[rec.trial[ok], rec.step[ok]])  # exact floats
    assert not list(tmp_path.joinpath("sub").glob(".poses-*"))  # no temporary left behind


@pytest.mark.parametrize("text, message", [
    ("", "empty"),
    ("trial,step,x_mm,y_mm\n0,0,1,2\n", "missing column"),
    ("trial,step,x_mm,y_mm,theta_rad,status\n0,a,1,2,3,ok\n", "line 2: trial and step must be integers"),
    ("trial,step,x_mm,y_mm,theta_rad,status\n0,0,1,b,3,ok\n", "y_mm 'b' is not a number"),
    ("trial,step,x_mm,y_mm,theta_rad,status\n0,0,1,2,3,flying\n", "unknown status 'flying'"),
    ("trial,step,x_mm,y_mm,theta_rad,status\n0,0,1,2,3,ok\n0,0,1,2,3,ok\n", "appears twice"),
    ("trial,step,x_mm,y_mm,theta_rad,status\n0,0,,,,ok\n", "finite pose"),
    ("trial,step,x_mm,y_mm,theta_rad,status\n0,-1,1,2,3,ok\n", "step must be >= 0"),
    ("trial,step,x_mm,y_mm,theta_rad,status\n0,0,1,2\n", "expected 6 fields"),
])
def test_read_poses_csv_errors(tmp_path, text, message):
    f = tmp_path / "p.csv"
    f.write_text(text)
    with pytest.raises(ValueError, match=message):
        read_poses_csv(f)


def test_read_poses_csv_lenient_forms(tmp_path):
    # columns in any order, extra columns, no status column (a camera log), blank lines
    f = tmp_path / "robot.csv"
    f.write_text("frame,theta_rad,x_mm,y_mm,step,trial\n7,0.1,10,10,0,0\n\n8,3.0,190,190,0,1\n9,0.1,10,10,1,0\n")
    rec = read_poses_csv(f)
    assert rec.n_steps == 2 and rec.trials == 2
    g = ReportGrid(200, 200, 4, 4, 4)
    np.testing.assert_allclose(entropy_by_step(rec, g), [1.0, 0.0])
    with pytest.raises(ValueError, match="does not exist"):
        read_poses_csv(tmp_path / "nope.csv")


# ---------------------------------------------------------------------------------- real physics

@pytest.fixture(scope="module")
def real_scene():
    from transition_builder.scene import scene_from_options

    return scene_from_options("allen-key")


def test_real_physics_same_result_for_any_workers_and_repeat_calls(real_scene):
    """The physics is deterministic: 1 or 2 workers, a fresh or a reused worker pool, same result."""
    seq = ["NE", "W", "S"]
    a = run_direct(real_scene, seq, 40, seed=3, workers=2)
    b = run_direct(real_scene, ["E", "N"], 40, seed=8, workers=2)  # the workers' simulators now have history
    c = run_direct(real_scene, seq, 40, seed=3, workers=2)
    d = run_direct(real_scene, seq, 40, seed=3, workers=1)
    for other in (c, d):
        np.testing.assert_array_equal(a.poses, other.poses)
        np.testing.assert_array_equal(a.status, other.status)
    assert not np.array_equal(a.poses[:, 1], b.poses[:, 1], equal_nan=True)


def test_friction_map_same_result_for_any_workers():
    """A friction map, too: 1 or 2 workers, and workers whose simulators ran other trials first,
    give bit-identical poses (each chunk starts on fresh worlds: TraySimulator.fresh_start)."""
    from transition_builder.scene import scene_from_options

    scene = scene_from_options("allen-key", friction_spec="map:medium:2")
    seq = ["N", "SW", "E", "S"]
    a = run_direct(scene, seq, 40, seed=7, workers=1)
    run_direct(scene, ["W", "NE"], 40, seed=8, workers=2)             # give the pool's simulators history
    b = run_direct(scene, seq, 40, seed=7, workers=2)
    np.testing.assert_array_equal(a.status, b.status)
    np.testing.assert_array_equal(a.poses, b.poses)


def test_paper_sanity_initial_entropy(real_scene):
    """M = 10,000 uniform starts on the 4x4x4 grid: entropy near log2(occupied voxels)."""
    res = run_direct(real_scene, [], 10000, seed=0, workers=1)
    assert res.occupied_voxels[0] == 64
    assert abs(res.entropy_bits[0] - math.log2(res.occupied_voxels[0])) < 0.5


def test_paper_sanity_first_tilt_drops_entropy(real_scene):
    """After the first tilt the part lies against the wall and the entropy drops sharply."""
    res = run_direct(real_scene, ["E"], 300, seed=0, workers=1)
    assert res.surviving[1] >= 0.9 * 300
    ok = res.status[:, 1] == OK
    rest = res.poses[ok, 1]
    # every settled part touches the east wall (within 2 mm: contact margins) ...
    xmax = real_scene.shape.placed(rest)[..., 0].max(axis=1)
    assert np.all(xmax > real_scene.tray_x_mm - 2.0)
    # ... so only the last x bin is occupied: at most log2(4 y-bins x 4 theta-bins) = 4 bits are left
    assert np.all(res.grid.bin_indices(rest)[0] == res.grid.nx - 1)
    assert res.entropy_bits[1] <= 4.0 + 1e-9
    assert res.entropy_bits[1] < res.entropy_bits[0] - 1.0


def test_paper_sanity_diagonal_tilt_drives_parts_to_the_walls(real_scene):
    """NE tilt: every part ends against the east or the north wall (with mu = 0.3 at 30 degrees a
    part that meets one wall first may stay there: wall plus floor friction exceed the along-wall
    pull), and the entropy drops sharply."""
    res = run_direct(real_scene, ["NE"], 300, seed=1, workers=1)
    assert res.surviving[1] >= 0.9 * 300
    rest = res.poses[res.status[:, 1] == OK, 1]
    v = real_scene.shape.placed(rest)
    east = v[..., 0].max(axis=1) > real_scene.tray_x_mm - 2.0
    north = v[..., 1].max(axis=1) > real_scene.tray_y_mm - 2.0
    assert np.all(east | north)
    assert np.mean(east & north) > 0.5  # most reach the corner
    assert res.entropy_bits[0] - res.entropy_bits[1] > 2.0
