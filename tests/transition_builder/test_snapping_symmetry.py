"""Tests for pose snapping (nearest representative within tolerance, same cell and contacts) and
the tray's rotation group."""
from __future__ import annotations

import math

import numpy as np
import pytest

from transition_builder.grid import ReportGrid
from transition_builder.scene import scene_from_options
from transition_builder.shapes import parse_shape
from transition_builder.snapping import PoseIndex, wall_contacts
from transition_builder.symmetry import tray_symmetry


@pytest.fixture()
def index():
    shape = parse_shape("rectangle:20x10")
    grid = ReportGrid(200, 200, 4, 4, 4, symmetry_order=shape.symmetry_order)
    return PoseIndex(shape, grid, tol_mm=0.5, tol_deg=0.5)


def test_snap_nearest_within_tolerance(index):
    index.add([[100.0, 100.0, 0.0], [100.6, 100.0, 0.0]])
    got = index.snap([[100.2, 100.0, 0.0], [100.45, 100.0, 0.0], [101.2, 100.0, 0.0], [100.0, 100.0, 0.0]])
    assert got.tolist() == [0, 1, -1, 0]
    # theta within 0.5 degree, and the ball is Euclidean in normalised units
    th = math.radians(0.4)
    assert index.snap([[100.0, 100.0, th]]).tolist() == [0]
    assert index.snap([[100.0 + 0.4, 100.0, th]]).tolist() == [1]          # nearer rep 1 (0.2/0.5 vs 0.4/0.5)
    assert index.snap([[100.0 - 0.4, 100.0, th]]).tolist() == [-1]         # sqrt(0.8^2+0.8^2) > 1


def test_theta_is_periodic_modulo_symmetry(index):
    # rectangle: symmetry order 2, so theta = pi - tiny is next to theta = 0
    index.add([[100.0, 100.0, 0.001]])
    assert index.snap([[100.0, 100.0, math.pi - 0.001]]).tolist() == [0]
    assert index.snap([[100.0, 100.0, 2 * math.pi - 0.001]]).tolist() == [0]


def test_never_snaps_across_cells_or_contacts(index):
    index.add([[49.9, 100.0, 0.0]])                       # report cell boundary at x = 50
    assert index.snap([[50.1, 100.0, 0.0]]).tolist() == [-1]
    assert index.snap([[49.7, 100.0, 0.0]]).tolist() == [0]
    # touching the west wall (x = 10 for a 20 mm wide part at theta 0) vs 0.3 mm off it
    index.add([[10.0, 100.0, 0.0]])
    assert wall_contacts(index.shape, [[10.0, 100.0, 0.0]], 200, 200, 0.05).tolist() == [1]
    assert index.snap([[10.3, 100.0, 0.0]]).tolist() == [-1]
    assert index.snap([[10.01, 100.0, 0.0]]).tolist() == [1]


def test_flush_side_tells_the_two_ends_of_a_nearly_flush_edge_apart():
    # a 20 x 10 rectangle resting on the south wall (centre y = 5), its long edge a hair off flush
    shape = parse_shape("rectangle:20x10")
    eps = 1e-4
    poses = [[100.0, 5.0 + 10 * eps, eps], [100.0, 5.0 + 10 * eps, -eps], [100.0, 100.0, 0.3]]
    plain = wall_contacts(shape, poses, 200, 200, 0.05)
    sided = wall_contacts(shape, poses, 200, 200, 0.05, flush_side=True)
    assert plain.tolist() == [4, 4, 0]                      # both touch the south wall only
    assert sided[0] & 15 == 4 and sided[1] & 15 == 4        # the wall bits are unchanged
    assert {int(sided[0]) >> 4, int(sided[1]) >> 4} == {0, 4}   # the south flush bit tells the ends apart
    # one vertex touching (a corner on the wall): no flush bit; no wall: nothing
    corner = [[100.0, 5.0 * math.cos(0.3) + 10.0 * math.sin(0.3), 0.3]]
    assert wall_contacts(shape, corner, 200, 200, 0.05, flush_side=True).tolist() == [4]
    assert sided[2] == 0
    # the index then never snaps one end onto the other, however close
    grid = ReportGrid(200, 200, 4, 4, 4, symmetry_order=shape.symmetry_order)
    idx = PoseIndex(shape, grid, 0.5, 0.5, flush_side=True)
    idx.add(poses[:1])
    assert idx.snap(poses[:2]).tolist() == [0, -1]
    assert PoseIndex(shape, grid, 0.5, 0.5).snap(poses[1:2]).tolist() == [-1]   # empty index
    plain_idx = PoseIndex(shape, grid, 0.5, 0.5)
    plain_idx.add(poses[:1])
    assert plain_idx.snap(poses[:2]).tolist() == [0, 0]


def test_tree_and_tail_give_the_same_answers():
    shape = parse_shape("allen-key")
    grid = ReportGrid(200, 200, 4, 4, 4)
    rng = np.random.default_rng(0)
    reps = np.column_stack([rng.uniform(20, 180, 3000), rng.uniform(20, 180, 3000), rng.uniform(0, 6.28, 3000)])
    queries = reps[:500] + rng.normal(0, 0.3, (500, 3)) * [1, 1, 0.005]
    a = PoseIndex(shape, grid, 0.5, 0.5)
    a.add(reps)                       # one add: everything in the tree
    b = PoseIndex(shape, grid, 0.5, 0.5)
    for r in reps:                    # one at a time: tree rebuilt every few hundred, the rest in the tail
        b.add(r[None])
    got_a, got_b = a.snap(queries), b.snap(queries)
    assert np.array_equal(got_a, got_b)
    # brute force
    q, _ = a.embed(queries)
    p, _ = a.embed(reps)
    d = np.abs(q[:, None] - p[None])
    d[..., 2] = np.minimum(d[..., 2], a.box[2] - d[..., 2])
    dist = np.sqrt((d ** 2).sum(-1))
    expect = np.where(dist.min(1) <= 1.0, dist.argmin(1), -1)
    assert np.array_equal(got_a, expect)
    assert (expect >= 0).sum() > 100


def test_square_tray_has_order_four():
    sym = tray_symmetry(scene_from_options("allen-key"))
    assert sym.order == 4
    names = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")
    # a quarter turn counter-clockwise: E -> N, N -> W, NE -> NW
    assert names[sym.rotate_action(names.index("E"), 1)] == "N"
    assert names[sym.rotate_action(names.index("N"), 1)] == "W"
    assert names[sym.rotate_action(names.index("NE"), 1)] == "NW"
    assert names[sym.rotate_action(names.index("NE"), -1)] == "SE"
    assert [names[b] for b in sym.action_orbit_representatives()] == ["N", "NE"]
    p = np.array([[150.0, 120.0, 0.5]])
    q = sym.rotate_poses(p, 1)
    np.testing.assert_allclose(q, [[80.0, 150.0, 0.5 + math.pi / 2]])
    np.testing.assert_allclose(sym.rotate_poses(q, 3), p)


def test_symmetry_off_for_friction_maps_and_rectangular_trays():
    assert tray_symmetry(scene_from_options("allen-key", friction_spec="map:low:1")).order == 1
    rect = tray_symmetry(scene_from_options("allen-key", tray_mm=(200.0, 150.0)))
    assert rect.order == 2
    assert sorted(rect.action_map[1].tolist()) == list(range(8))
    assert tray_symmetry(scene_from_options("allen-key"), enabled=False).order == 1
    # an action set not closed under quarter turns falls back to half turns
    assert tray_symmetry(scene_from_options("allen-key", actions="N,S")).order == 2
    assert tray_symmetry(scene_from_options("allen-key", actions="N,E")).order == 1


def test_neighbour_counts_match_a_periodic_ball_query_on_tight_clusters():
    """The recentring density (a compiled sweep) against scipy's ball query with the same periodic
    metric, on the kind of data it was written for: tight clusters of near-identical points (and
    exact duplicates), clusters straddling the theta wrap, and groups that must not see each other."""
    from scipy.spatial import cKDTree

    from transition_builder._density import neighbour_counts

    rng = np.random.default_rng(5)
    period, r = 12.0, 0.05
    centres = np.column_stack([rng.uniform(1, 5, 40), rng.uniform(1, 5, 40), rng.uniform(0, period, 40)])
    centres[:5, 2] = period - 1e-3                       # across the wrap
    which = rng.integers(0, 40, 3000)
    pts = centres[which] + rng.normal(0, 0.02, (3000, 3))
    pts[:, 2] = np.mod(pts[:, 2], period)
    pts[1:600:2], which[1:600:2] = pts[0:600:2], which[0:600:2]     # exact duplicates
    pts[600:640], which[600:640] = pts[0:40], which[0:40] + 1         # ... and the same points in other groups
    pts[-50:] = np.column_stack([rng.uniform(10, 50, 50), rng.uniform(10, 50, 50), rng.uniform(0, period, 50)])
    group = which % 3                                    # clusters of three groups share places
    got = neighbour_counts(pts, group, r, period)
    want = np.zeros(len(pts), dtype=np.int64)
    for g in range(3):
        sel = np.flatnonzero(group == g)
        tree = cKDTree(pts[sel], boxsize=[1e6, 1e6, period])
        want[sel] = tree.query_ball_point(pts[sel], r, return_length=True)
    assert np.array_equal(got, want)
    assert want.max() > 20 and (want == 1).any()       # dense clusters and lone points both tested
    with pytest.raises(ValueError, match="points"):
        neighbour_counts(pts[:, :2], group, r, period)


@pytest.mark.parametrize("tray, order", [((200.0, 200.0), 4), ((200.0, 150.0), 2)])
def test_rotate_poses_is_the_rotation_about_the_tray_centre(tray, order):
    """Every group element against cos/sin rotation by j * 2 pi / order about the centre (the
    quarter and half turns are computed exactly in the code, so they agree to round-off)."""
    sym = tray_symmetry(scene_from_options("allen-key", tray_mm=tray))
    assert sym.order == order
    rng = np.random.default_rng(3)
    p = np.column_stack([rng.uniform(20, tray[0] - 20, 50), rng.uniform(20, tray[1] - 20, 50),
                         rng.uniform(0, 2 * math.pi, 50)])
    cx, cy = tray[0] / 2, tray[1] / 2
    for j in range(-1, order + 1):
        phi = 2 * math.pi * j / order
        c, s = math.cos(phi), math.sin(phi)
        want_x = cx + c * (p[:, 0] - cx) - s * (p[:, 1] - cy)
        want_y = cy + s * (p[:, 0] - cx) + c * (p[:, 1] - cy)
        got = sym.rotate_poses(p, j)
        np.testing.assert_allclose(got[:, 0], want_x, atol=1e-9)
        np.testing.assert_allclose(got[:, 1], want_y, atol=1e-9)
        dth = np.angle(np.exp(1j * (got[:, 2] - (p[:, 2] + phi))))
        np.testing.assert_allclose(dth, 0.0, atol=1e-9)
        assert np.all((got[:, 2] >= 0) & (got[:, 2] < 2 * math.pi))


# ----------------------------------------------------------------------------- the group, whole
def _fields(sym):
    return sym.order, sym.centre, sym.action_map.tolist(), sym.action_map.dtype, sym.reason


def test_every_group_whole_with_its_reason():
    ident = [list(range(8))]
    cases = [
        (scene_from_options("allen-key"), True,
         (4, (100.0, 100.0), None, np.int64, "square tray, uniform friction")),
        (scene_from_options("allen-key", tray_mm=(200.0, 150.0)), True,
         (2, (100.0, 75.0), None, np.int64, "rectangular tray, uniform friction")),
        (scene_from_options("allen-key", actions="N,S"), True,
         (2, (100.0, 100.0), [[0, 1], [1, 0]], np.int64, "square tray, but the action set is only closed under half turns")),
        (scene_from_options("allen-key", tray_mm=(200.0, 150.0)), False,
         (1, (100.0, 75.0), ident, np.int64, "symmetry reduction switched off")),
        (scene_from_options("allen-key", friction_spec="map:low:1"), True,
         (1, (100.0, 100.0), ident, np.int64, "friction map: the floor has no symmetry")),
        (scene_from_options("allen-key", actions="N,E"), True,
         (1, (100.0, 100.0), [[0, 1]], np.int64, "the action set is not closed under the tray's rotations")),
    ]
    for scene, enabled, want in cases:
        got = _fields(tray_symmetry(scene, enabled=enabled))
        assert got[:2] == want[:2] and got[3:] == want[3:]
        if want[2] is not None:
            assert got[2] == want[2]
    names = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")
    half = tray_symmetry(scene_from_options("allen-key", tray_mm=(200.0, 150.0)))
    assert [names[half.rotate_action(a, 1)] for a in range(8)] == ["S", "SW", "W", "NW", "N", "NE", "E", "SE"]


def test_square_means_within_a_nanometre_absolutely():
    """The tray is square when its sides differ by at most 1e-9 mm, with no relative tolerance."""
    def order(y):
        return tray_symmetry(scene_from_options("allen-key", tray_mm=(200.0, y))).order

    assert order(200.0 + 1e-10) == 4
    assert order(200.0 + 1e-7) == 2 and order(200.5) == 2


def test_rotated_theta_is_in_range_and_integer_poses_are_rotated_as_floats():
    sym = tray_symmetry(scene_from_options("allen-key"))
    # theta + a quarter turn = -2.2e-16: np.mod rounds it up to 2 pi itself, which must read 0
    theta = np.nextafter(-math.pi / 2, -math.inf)
    assert np.mod(theta + math.pi / 2, 2 * math.pi) == 2 * math.pi
    assert sym.rotate_poses([[100.0, 100.0, theta]], 1)[0, 2] == 0.0
    got = sym.rotate_poses([[150, 120, 0]], 1)
    assert got.dtype == np.float64 and got.tolist() == [[80.0, 150.0, math.pi / 2]]


def _exact_cover(sym, reps):
    """Brute force: every action is rotate_action(b, j) for exactly one (b in reps, j)."""
    hits = [sym.rotate_action(b, j) for b in reps for j in range(sym.order)]
    return sorted(hits) == list(range(sym.action_map.shape[1]))


def test_orbit_representatives_cover_every_action_once_in_any_action_order():
    """A hand-made half-turn group whose second action is the first one's image: the scan goes on
    past a covered action to the next orbit."""
    from transition_builder.symmetry import TraySymmetry

    sym = TraySymmetry(2, (0.0, 0.0), np.array([[0, 1, 2, 3], [1, 0, 3, 2]]), "hand-made")
    reps = sym.action_orbit_representatives()
    assert reps == [0, 2] and _exact_cover(sym, reps)
    for tray in ((200.0, 200.0), (200.0, 150.0)):
        built = tray_symmetry(scene_from_options("allen-key", tray_mm=tray))
        assert _exact_cover(built, built.action_orbit_representatives())


def test_a_group_of_another_order_is_refused_naming_the_order():
    """Only orders 1, 2 and 4 are rotated; a three-fold group is refused, not turned by a half turn."""
    from transition_builder.symmetry import TraySymmetry

    sym = TraySymmetry(3, (0.0, 0.0), np.zeros((3, 1), dtype=np.int64), "hand-made")
    for j in (1, 2):
        with pytest.raises(AssertionError) as info:
            sym.rotate_poses([[1.0, 0.0, 0.0]], j)
        assert info.value.args == (3,)
