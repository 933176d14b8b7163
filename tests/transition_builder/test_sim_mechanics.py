"""Mechanics of the tilt simulator against closed-form rigid-body results.

Judges are Newtonian mechanics: a block on an incline of angle a with Coulomb friction mu slides
with acceleration g (sin a - mu cos a) when mu < tan a and stays put otherwise; the direction of
the slide does not depend on the block's yaw; a slender part pushed into a straight wall comes to
rest flush against it; the problem is invariant under rotating the (square) tray by 90 degrees.
Every judge runs on both engines (``engine``: PyBullet, the reference, and the planar engine).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from transition_builder.sampling import sample_start_poses
from transition_builder.scene import ACTIONS, scene_from_options
from transition_builder.sim import TraySimulator
from transition_builder.simulators import make_simulator, simulate
from transition_builder.status import OK

G = 9.81
TILT = math.radians(30.0)


@pytest.fixture(scope="module", params=["pybullet", "planar"])
def engine(request):
    """Both engines face every judge of this module."""
    return request.param


@pytest.fixture(scope="module")
def block_sim(engine):
    sim = make_simulator(scene_from_options("rectangle:40x40", 0.3, engine=engine))
    yield sim
    sim.close()


@pytest.mark.parametrize("action", ACTIONS)
@pytest.mark.parametrize("yaw_deg", [0.0, 30.0, 45.0])
def test_free_slide_acceleration_and_drift(block_sim, action, yaw_deg):
    """Distance vs time over a free slide (no wall contact): fitted acceleration within 0.2% of
    g (sin a - mu cos a) (measured: 0.022% at worst over the 24 cases), sideways drift under
    0.01 mm, no rotation, no lift off the floor (measured: none within 1e-4 mm)."""
    sc = block_sim.scene
    phi = sc.downhill_angle(action)
    u = np.array([math.cos(phi), math.sin(phi)])
    start = np.array([100.0, 100.0]) - 60.0 * u          # start uphill of the centre
    t, poses, z = block_sim.trajectory([start[0], start[1], math.radians(yaw_deg)], action, 0.3)
    d = poses[:, :2] - poses[0, :2]
    along = d @ u
    side = d @ np.array([-u[1], u[0]])
    # no wall contact during the window: the block's outline stays inside the tray
    outline = sc.shape.placed(poses)
    assert outline.min() > 0.0 and outline.max() < 200.0
    A = np.column_stack([np.ones_like(t), t, 0.5 * t * t])
    acc = np.linalg.lstsq(A, along, rcond=None)[0][2] / 1000.0
    expected = G * (math.sin(TILT) - sc.base_mu * math.cos(TILT))
    assert abs(acc / expected - 1.0) < 0.002, (acc, expected)
    assert along[-1] > 50.0                                  # it really slid
    assert np.max(np.abs(side)) < 0.01
    assert np.max(np.abs(poses[:, 2] - poses[0, 2])) < math.radians(0.001)
    assert np.max(np.abs(z)) < 0.001                         # stays on the floor (mm)


@pytest.mark.parametrize("action", ACTIONS)
@pytest.mark.parametrize("yaw_deg", [0.0, 30.0, 45.0])
def test_no_slide_above_friction_angle(action, yaw_deg, engine):
    """mu = 0.7 > tan 30 deg = 0.577: the block does not move."""
    sim = make_simulator(scene_from_options("rectangle:40x40", 0.7, engine=engine))
    try:
        t, poses, _ = sim.trajectory([100.0, 100.0, math.radians(yaw_deg)], action, 0.5)
        assert np.max(np.abs(poses - poses[0])) < 1e-3
        rest, status = sim.tilt([[100.0, 100.0, math.radians(yaw_deg)]], action)
        assert status[0] == OK
        assert np.allclose(rest[0, :2], [100.0, 100.0], atol=1e-3)
    finally:
        sim.close()


@pytest.mark.parametrize("action", ["N", "E", "S", "W"])
def test_rectangle_rests_flush_against_wall(action, engine):
    """A slender rectangle (80 x 10 mm, mu = 0.1) tilted into a wall from several yaws rests with
    an edge flush against that wall (within 0.1 degree; measured 0.027) and touching it (within
    0.08 mm; measured 0.040).

    Low friction on purpose: with Coulomb friction a part that meets a wall nearly end-on can
    rest on a corner (the gravity torque toward flush is smaller than the floor-friction torque),
    in reality as in the engine; here mechanics predicts flush for every start.
    """
    sc = scene_from_options("rectangle:80x10", 0.1, engine=engine)
    sim = make_simulator(sc)
    try:
        yaws = np.radians([15.0, 30.0, 45.0, 60.0, 75.0, 110.0, 135.0, 160.0])
        starts = np.column_stack([np.full(len(yaws), 100.0), np.full(len(yaws), 100.0), yaws])
        rest, status = sim.tilt(starts, action)
        assert np.all(status == OK)
        dev = (rest[:, 2] + math.pi / 4) % (math.pi / 2) - math.pi / 4
        assert np.max(np.abs(np.degrees(dev))) < 0.1, np.degrees(dev)
        phi = sc.downhill_angle(action)
        u = np.array([math.cos(phi), math.sin(phi)])
        wall = 200.0 if u.sum() > 0 else 0.0
        v = sc.shape.placed(rest)                              # (n, 4, 2)
        extreme = (v @ np.abs(u)).max(axis=1) if wall else (v @ np.abs(u)).min(axis=1)
        assert np.all(np.abs(extreme - wall) < 0.08), extreme
    finally:
        sim.close()


def _rotate(poses, k):
    """Rotate tray-frame poses by k * 90 degrees CCW about the centre of the 200 mm tray."""
    ang = k * math.pi / 2
    R = np.array([[math.cos(ang), -math.sin(ang)], [math.sin(ang), math.cos(ang)]])
    out = np.array(poses, dtype=float)
    out[:, :2] = (out[:, :2] - 100.0) @ R.T + 100.0
    out[:, 2] = (out[:, 2] + ang) % (2 * math.pi)
    return out


def test_rotating_the_problem_by_90_degrees_rotates_the_outcome(engine):
    """Rotate start pose and action by 90 degrees CCW (action index - 2 mod 8, e.g. N -> W):
    the rest pose is the rotated rest pose, within 1 mm and 1 degree for every trial and within
    0.05 mm / 0.05 degree for 95% of them (engine tolerance: each direction is simulated in its own
    rotated world, so round-off differs)."""
    sc = scene_from_options("allen-key", engine=engine)
    poses = sample_start_poses(sc.shape, 200.0, 200.0, 24, np.random.default_rng(7))
    dpos, dang = [], []
    for a in range(8):
        r0, s0 = simulate(sc, poses, a)
        r1, s1 = simulate(sc, _rotate(poses, 1), (a - 2) % 8)
        assert np.all(s0 == OK) and np.all(s1 == OK)
        e = _rotate(r0, 1) - r1
        dpos.append(np.hypot(e[:, 0], e[:, 1]))
        dang.append(np.abs((e[:, 2] + math.pi) % (2 * math.pi) - math.pi))
    dpos, dang = np.concatenate(dpos), np.degrees(np.concatenate(dang))
    assert dpos.max() < 1.0 and dang.max() < 1.0, (dpos.max(), dang.max())
    assert np.quantile(dpos, 0.95) < 0.05 and np.quantile(dang, 0.95) < 0.05


def test_rest_poses_lie_inside_the_tray_and_against_walls(engine):
    """After a tilt toward E every allen key touches the east wall (its easternmost point is
    within 0.1 mm of x = 200) and lies inside the tray."""
    sc = scene_from_options("allen-key", engine=engine)
    poses = sample_start_poses(sc.shape, 200.0, 200.0, 40, np.random.default_rng(3))
    rest, status = simulate(sc, poses, "E")
    assert np.all(status == OK)
    v = sc.shape.placed(rest)
    assert np.all(np.abs(v[..., 0].max(axis=1) - 200.0) < 0.1)
    assert v.min() > -0.1 and v.max() < 200.1


@pytest.mark.parametrize("action", ["NE", "W"])
@pytest.mark.parametrize("yaw_deg", [0.0, 30.0])
def test_distributed_support_mode_slides_right(action, yaw_deg):
    """contact legs:4 (four point legs) passes the same slide check: acceleration within 0.5%
    (measured 0.054% at worst), sideways drift under 0.05 mm (0.003)."""
    sc = scene_from_options("rectangle:40x40", 0.3, contact="legs:4", solver_iterations=20)
    with TraySimulator(sc) as sim:
        phi = sc.downhill_angle(action)
        u = np.array([math.cos(phi), math.sin(phi)])
        start = np.array([100.0, 100.0]) - 60.0 * u
        t, poses, z = sim.trajectory([start[0], start[1], math.radians(yaw_deg)], action, 0.3)
        d = poses[:, :2] - poses[0, :2]
        along, side = d @ u, d @ np.array([-u[1], u[0]])
        acc = np.linalg.lstsq(np.column_stack([np.ones_like(t), t, 0.5 * t * t]), along, rcond=None)[0][2]
        expected = G * (math.sin(TILT) - 0.3 * math.cos(TILT)) * 1000.0
        assert abs(acc / expected - 1.0) < 0.005
        assert np.max(np.abs(side)) < 0.05
        rest, status = sim.tilt([[100.0, 100.0, math.radians(yaw_deg)]], action)
        assert status[0] == OK


@pytest.mark.parametrize("mu", [0.05, 0.2, 0.45])
def test_slide_acceleration_follows_the_floor_coefficient(mu, engine):
    """The floor's coefficient is the contact's (the part's lateral friction is 1 and Bullet
    multiplies the two): acceleration g (sin a - mu cos a) within 3% for several mu."""
    with make_simulator(scene_from_options("rectangle:30x30", mu, engine=engine)) as sim:
        t, poses, _ = sim.trajectory([60.0, 60.0, 0.4], "NE", 0.25)
        along = (poses[:, :2] - poses[0, :2]) @ np.array([1.0, 1.0]) / math.sqrt(2.0)
        acc = np.linalg.lstsq(np.column_stack([np.ones_like(t), t, 0.5 * t * t]), along, rcond=None)[0][2]
        expected = G * (math.sin(TILT) - mu * math.cos(TILT)) * 1000.0
        assert abs(acc / expected - 1.0) < 0.03


def test_friction_map_tile_sets_the_local_coefficient(engine):
    """On a friction map the part feels the coefficient of the tile under it: a small block sliding
    east along one row of tiles follows the 1-D motion x'' = g (sin a - mu(x) cos a), integrated
    finely from the map, within 2% of the distance travelled and without sideways drift."""
    from transition_builder.friction import friction_map
    sc = scene_from_options("rectangle:10x10", "map:high:2", engine=engine)
    mu, tile = friction_map(sc.friction, 200.0, 200.0)
    with make_simulator(sc) as sim:
        t, poses, _ = sim.trajectory([15.0, 105.0, 0.0], "E", 0.35)
    x, v, dt = 15.0, 0.0, 1e-5
    ts, xs = [0.0], [x]
    for k in range(int(round(0.35 / dt))):
        acc = G * (math.sin(TILT) - mu[min(int(x // tile), mu.shape[0] - 1), 10] * math.cos(TILT)) * 1000.0
        v = max(v + acc * dt, 0.0)
        x += v * dt
        ts.append((k + 1) * dt)
        xs.append(x)
    expected = np.interp(t, ts, xs)
    travelled = expected[-1] - expected[0]
    assert travelled > 100.0
    assert np.max(np.abs(poses[:, 0] - expected)) < 0.02 * travelled
    assert np.max(np.abs(poses[:, 1] - 105.0)) < 0.01
    # the uniform floor at the map's mean gives a clearly different path (the map matters)
    uniform = 15.0 + 0.5 * G * (math.sin(TILT) - 0.3 * math.cos(TILT)) * 1000.0 * t ** 2
    assert np.max(np.abs(poses[:, 0] - uniform)) > 0.05 * travelled


# ---------------------------------------------------------------------------------------------
# Judges of the floor contact: free sliding on a level floor against a direct integration of
# distributed Coulomb friction (transition_builder.judges), at 1/16 of the default time step so
# that the engine's integrator error (about v0 dt / 2) stays below the tolerances.
from transition_builder._bullet_world import friction_radius_mm  # noqa: E402
from transition_builder.judges import disk_shape_spec, engine_free_slide, isotropy_error, reference_free_slide  # noqa: E402
from transition_builder.shapes import parse_shape  # noqa: E402

DISK = disk_shape_spec()
MU = 0.3
FREE_SLIDES = [(DISK, (100.0, 100.0, 0.0), (200.0, 100.0, 8.0)),
               (DISK, (100.0, 100.0, 0.0), (-150.0, 250.0, -12.0)),
               ("allen-key", (100.0, 100.0, 0.3), (300.0, 200.0, 6.0)),
               ("allen-key", (100.0, 100.0, 1.0), (-200.0, 250.0, -5.0)),
               ("allen-key", (100.0, 100.0, 4.0), (50.0, -300.0, 10.0))]


@pytest.mark.parametrize("shape,pose,twist", FREE_SLIDES, ids=["disk-1", "disk-2", "key-1", "key-2", "key-3"])
def test_coulomb_free_sliding_matches_integration(shape, pose, twist, engine):
    """The default contact's free slide ends within 0.2 mm and 0.5 degrees of the integration of
    distributed Coulomb friction (measured: at most 0.06 mm and 0.1 degree)."""
    ref = reference_free_slide(shape, pose, twist, mu=MU)
    eng = engine_free_slide(shape, pose, twist, contact="coulomb", mu=MU, engine=engine)
    assert np.hypot(*(eng.final[:2] - ref.final[:2])) < 0.2
    assert abs(math.degrees(eng.final[2] - ref.final[2])) < 0.5
    # it really moved: the judge is not a part at rest
    assert np.hypot(*(ref.final[:2] - np.array(pose[:2]))) > 5.0


def test_disk_stops_sliding_and_spinning_together(engine):
    """A disk sliding and spinning stops sliding and spinning at the same instant (within 2% of the
    stopping time), and its late v / (R omega) is within 5% of the integration's (Weidman and
    Malhotra 2005: about 0.65 at the very end)."""
    pose, twist = (100.0, 100.0, 0.0), (200.0, 100.0, 8.0)
    ref = reference_free_slide(DISK, pose, twist, mu=MU)
    eng = engine_free_slide(DISK, pose, twist, contact="coulomb", mu=MU, engine=engine)
    assert abs(ref.t_slide - ref.t_spin) <= 0.02 * ref.t_slide      # the judge itself
    assert abs(eng.t_slide - eng.t_spin) <= 0.02 * eng.t_slide
    assert abs(eng.t_slide - ref.t_slide) <= 0.02 * ref.t_slide
    assert abs(eng.ratio_late / ref.ratio_late - 1.0) < 0.05, (eng.ratio_late, ref.ratio_late)


def test_coulomb_pure_sliding_stops_at_v0_over_mu_g(engine):
    """Pure sliding (no spin) stops at v0 / (mu g), within 2%, for the disk and the key."""
    for shape, pose in ((DISK, (100.0, 100.0, 0.0)), ("allen-key", (100.0, 100.0, 0.7))):
        v0 = 300.0
        eng = engine_free_slide(shape, pose, (v0 * 0.6, v0 * 0.8, 0.0), contact="coulomb", mu=MU, engine=engine)
        expected = v0 / 1000.0 / (MU * G)
        assert abs(eng.t_slide / expected - 1.0) < 0.02, (eng.t_slide, expected)
        assert abs(eng.final[2] - pose[2]) < math.radians(0.01)       # no spin from nowhere


def test_disk_pure_spinning_stops_at_the_spin_law(engine):
    """A disk spinning in place stops at I omega0 / (mu m g rho), rho = (1/A) int |r| dA (for a
    uniform disk 3 R omega0 / (4 mu g)), within 2%, and does not drift."""
    shape = parse_shape(DISK)
    w0 = 10.0
    rho = friction_radius_mm(shape) / 1000.0
    expected = shape.inertia_kg_m2 / shape.mass_kg * w0 / (MU * G * rho)
    eng = engine_free_slide(DISK, (100.0, 100.0, 0.0), (0.0, 0.0, w0), contact="coulomb", mu=MU, engine=engine)
    assert abs(eng.t_spin / expected - 1.0) < 0.02, (eng.t_spin, expected)
    assert np.hypot(eng.final[0] - 100.0, eng.final[1] - 100.0) < 0.01


@pytest.mark.parametrize("angle_deg", [45.0, 30.0])
def test_coulomb_contact_is_isotropic(angle_deg, engine):
    """Turning the start (yaw and twist) by 45 (and 30) degrees turns the free slide by the same
    angle: displacement and rotation agree within 1% (25 legs: 6% and 4%; measured here 1e-4)."""
    d, r = isotropy_error("allen-key", (100.0, 100.0, 0.3), (300.0, 200.0, 6.0),
                          angle=math.radians(angle_deg), contact="coulomb", engine=engine)
    assert d < 0.01 and r < 0.01, (d, r)
