"""Tests for pose snapping (transition_builder.snapping): the nearest representative within
tolerance, in the same report cell and with the same wall contacts; and the recentring density
(transition_builder._density) it is built on."""
from __future__ import annotations

import math

import numpy as np
import pytest

from transition_builder.grid import ReportGrid
from transition_builder.shapes import parse_shape
from transition_builder.snapping import PoseIndex, wall_contacts


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
