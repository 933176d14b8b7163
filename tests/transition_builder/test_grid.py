"""Tests for transition_builder.grid: voxel bins, theta modulo symmetry, bin offsets."""
from __future__ import annotations

import math

import numpy as np
import pytest

from transition_builder.grid import ReportGrid, parse_grid


def test_parse_grid():
    assert parse_grid("4x4x4") == (4, 4, 4)
    assert parse_grid(" 3X5x2 ") == (3, 5, 2)
    for bad in ["4x4", "4x4x0", "axbxc", "4x4x4x4", "-1x4x4", "", "4.5x4x4"]:
        with pytest.raises(ValueError, match="grid"):
            parse_grid(bad)


def test_xy_bins_and_edges():
    g = ReportGrid(200, 100, 4, 2, 4)
    poses = np.array([[0, 0, 0], [49.999, 49.999, 0], [50, 50, 0], [200, 100, 0], [150.0, 99.0, 0]])
    ix, iy, _ = g.bin_indices(poses)
    assert ix.tolist() == [0, 0, 1, 3, 3]  # x == a goes to the last bin
    assert iy.tolist() == [0, 0, 1, 1, 1]
    assert g.n_voxels == 32


def test_voxel_index_layout_and_centres_roundtrip():
    g = ReportGrid(200, 200, 3, 5, 7, symmetry_order=1)
    idx = np.arange(g.n_voxels)
    centres = g.centres(idx)
    np.testing.assert_array_equal(g.voxel_index(centres), idx)
    ix, iy, it = g.unravel(idx)
    np.testing.assert_array_equal((ix * 5 + iy) * 7 + it, idx)


def test_default_offset_centres_axis_angles():
    g = ReportGrid(200, 200, 4, 4, 4)  # 90-degree bins
    assert g.theta_offset == pytest.approx(math.pi / 4)
    angles = np.array([0, 90, 180, 270]) * math.pi / 180
    eps = 1e-9
    for a, expected in zip(angles, range(4)):
        poses = np.array([[100, 100, a - eps], [100, 100, a], [100, 100, a + eps]]) % [1e9, 1e9, 2 * math.pi]
        # round-off around an axis angle never changes the bin
        assert g.bin_indices(poses)[2].tolist() == [expected] * 3
    # bin 0 covers [-45, 45) degrees
    t = np.radians([-44.9, 44.9, 45.0, 134.9, 135.0, 314.9, 315.0, 359.99])
    poses = np.column_stack([np.full(t.size, 100.0), np.full(t.size, 100.0), t])
    assert g.bin_indices(poses)[2].tolist() == [0, 0, 1, 1, 2, 3, 0, 0]


def test_zero_offset_gives_paper_edges():
    g = ReportGrid(200, 200, 4, 4, 4, theta_offset=0.0)
    t = np.radians([0.0, 89.99, 90.0, 179.99, 180.0, 270.0, 359.99])
    poses = np.column_stack([np.full(t.size, 100.0), np.full(t.size, 100.0), t])
    assert g.bin_indices(poses)[2].tolist() == [0, 0, 1, 1, 2, 3, 3]
    # an axis angle sits on an edge: round-off flips its bin (why the default is centred)
    flip = g.bin_indices(np.array([[100, 100, math.pi / 2 - 1e-12], [100, 100, math.pi / 2 + 1e-12]]))[2]
    assert flip[0] != flip[1]


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_theta_modulo_symmetry(k):
    g = ReportGrid(200, 200, 4, 4, 6, symmetry_order=k)
    rng = np.random.default_rng(k)
    poses = np.column_stack([rng.uniform(0, 200, 500), rng.uniform(0, 200, 500), rng.uniform(-10, 10, 500)])
    base = g.voxel_index(poses)
    for j in range(1, k + 1):
        shifted = poses + [0, 0, 2 * math.pi * j / k]
        np.testing.assert_array_equal(g.voxel_index(shifted), base)
    # theta bins are equally wide over one period: uniform theta fills them equally
    t = np.linspace(0, 2 * math.pi, 6000 * k, endpoint=False) + 1e-7
    its = g.bin_indices(np.column_stack([np.full(t.size, 1.0), np.full(t.size, 1.0), t]))[2]
    assert np.bincount(its, minlength=6).tolist() == [1000 * k] * 6


def test_symmetric_shape_pose_equivalence_by_brute_force():
    # a 2-fold symmetric grid must identify theta and theta + pi, and nothing else
    g1 = ReportGrid(100, 100, 1, 1, 8, symmetry_order=1)
    g2 = ReportGrid(100, 100, 1, 1, 4, symmetry_order=2)
    t = np.linspace(0.01, 2 * math.pi - 0.01, 997)
    poses = np.column_stack([np.full(t.size, 5.0), np.full(t.size, 5.0), t])
    b1 = g1.bin_indices(poses)[2]
    b2 = g2.bin_indices(poses)[2]
    np.testing.assert_array_equal(b1 % 4, b2)  # same bin width, period folded


def test_rejects_nan_and_out_of_tray():
    g = ReportGrid(200, 200, 4, 4, 4)
    with pytest.raises(ValueError, match="not finite"):
        g.voxel_index(np.array([[1.0, 2.0, np.nan]]))
    with pytest.raises(ValueError, match="outside the tray"):
        g.voxel_index(np.array([[201.0, 2.0, 0.0]]))
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        g.voxel_index(np.zeros((3, 2)))
    # round-off just outside the tray is tolerated and clipped
    assert g.voxel_index(np.array([[-1e-9, 200 + 1e-9, 0.0]]))[0] == g.voxel_index(np.array([[0, 200, 0.0]]))[0]


def test_constructor_validation():
    with pytest.raises(ValueError, match="positive"):
        ReportGrid(0, 200, 4, 4, 4)
    with pytest.raises(ValueError, match="positive integer"):
        ReportGrid(200, 200, 4, 0, 4)
    with pytest.raises(ValueError, match="positive integer"):
        ReportGrid(200, 200, 4, 4, 4, symmetry_order=0)
    with pytest.raises(ValueError, match="finite"):
        ReportGrid(200, 200, 4, 4, 4, theta_offset=float("nan"))


def test_counts_and_entropy():
    g = ReportGrid(200, 200, 2, 2, 1)
    poses = np.array([[10, 10, 0], [10, 10, 1], [150, 150, 2], [150, 10, 3]])
    assert g.counts(poses).tolist() == [2, 0, 1, 1]  # index = ix * ny + iy
    assert g.entropy_bits(poses) == pytest.approx(1.5)
    assert g.entropy_bits(np.zeros((0, 3))) == 0.0


def test_grid_boundaries_and_messages():
    from transition_builder.grid import ReportGrid, parse_grid

    assert parse_grid("1x1x1") == (1, 1, 1)                    # one voxel is a grid
    with pytest.raises(ValueError, match="at least 1"):
        parse_grid("0x2x2")
    with pytest.raises(ValueError, match=r"^bad grid '2000000x2000000x2': too many voxels$"):
        parse_grid("2000000x2000000x2")
    for label in ("nx", "ny", "ntheta", "symmetry_order"):
        kw = {"nx": 2, "ny": 2, "ntheta": 2, "symmetry_order": 1, label: 0}
        with pytest.raises(ValueError, match=label):
            ReportGrid(200.0, 100.0, kw["nx"], kw["ny"], kw["ntheta"], symmetry_order=kw["symmetry_order"])
    g = ReportGrid.from_spec("4x2x3", 200.0, 100.0)
    assert (g.nx, g.ny, g.ntheta) == (4, 2, 3)
    assert ReportGrid(**{**g.to_dict()}).to_dict() == g.to_dict()
    # the edge tolerance is relative to the tray (1e-6 of 200 mm = 0.2 um): inside it a pose on
    # the wall is binned, beyond it refused, naming the axis
    assert g.bin_indices([[200.0 + 1e-4, 50.0, 0.0]])[0][0] == 3
    with pytest.raises(ValueError, match=r"^pose 0: x = 200.001 mm lies outside the tray \[0, 200\]$"):
        g.bin_indices([[200.001, 50.0, 0.0]])
    with pytest.raises(ValueError, match=r"^pose 1: y = "):
        g.bin_indices([[10.0, 50.0, 0.0], [10.0, -1.0, 0.0]])
    c = g.centres(np.arange(g.n_voxels))
    assert c.shape == (g.n_voxels, 3)
    np.testing.assert_array_equal(g.voxel_index(c), np.arange(g.n_voxels))      # each centre in its voxel


# ----------------------------------------------------------------------------- whole messages, boundaries, defaults
def _message(fn, *args, **kw):
    with pytest.raises(ValueError) as info:
        fn(*args, **kw)
    return str(info.value)


def test_parse_grid_voxel_limit_is_2_to_the_40():
    assert parse_grid("5x5x5") == (5, 5, 5)                               # 125 voxels
    assert parse_grid("1024x1024x1048576") == (1024, 1024, 1048576)      # exactly 2^40
    assert _message(parse_grid, "1025x1024x1048576") == "bad grid '1025x1024x1048576': too many voxels"
    assert _message(parse_grid, 444) == "bad grid 444: expected AxBxG, e.g. 4x4x4"


def test_constructor_messages_name_each_argument():
    assert _message(ReportGrid, 0, 200, 4, 4, 4) == "tray x size must be a positive number of mm, got 0"
    assert _message(ReportGrid, 200, -1.0, 4, 4, 4) == "tray y size must be a positive number of mm, got -1.0"
    assert ReportGrid(0.5, 0.25, 1, 1, 1).tray_y_mm == 0.25                 # a tray under 1 mm is still a size
    args = {"nx": 2, "ny": 2, "ntheta": 2, "symmetry_order": 1}
    for label in args:
        kw = {**args, label: 0}
        assert _message(ReportGrid, 200.0, 100.0, kw["nx"], kw["ny"], kw["ntheta"],
                        symmetry_order=kw["symmetry_order"]) == f"grid {label} must be a positive integer, got 0"


def test_from_spec_passes_symmetry_and_offset():
    g = ReportGrid.from_spec("4x4x4", 200.0, 200.0)
    assert g.symmetry_order == 1 and g.theta_offset == pytest.approx(math.pi / 4)
    h = ReportGrid.from_spec("4x4x4", 200.0, 200.0, symmetry_order=2, theta_offset=0.0)
    assert h.symmetry_order == 2 and h.theta_offset == 0.0 and h.theta_period == pytest.approx(math.pi)


def test_reduce_theta_never_returns_the_period():
    """np.mod of a tiny negative angle rounds up to the period itself: reduced to 0."""
    g = ReportGrid(200, 200, 4, 4, 4)
    assert np.mod(-1e-20, 2 * math.pi) == 2 * math.pi                     # the round-up this guards against
    out = g.reduce_theta(np.array([-1e-20, 1.0]))
    assert out.dtype == np.float64 and out.tolist() == [0.0, 1.0]


def test_one_pose_and_the_first_bad_pose():
    g = ReportGrid(200, 200, 4, 4, 4)
    assert [int(a[0]) for a in g.bin_indices([150.0, 20.0, 0.0])] == [3, 0, 0]          # a single (3,) pose
    assert _message(g.bin_indices, [[1.0, 2.0, 0.0], [1.0, np.inf, 0.0]]) == \
        "pose 1 is not finite (NaN or infinity); drop faulted trials first"


def test_edge_tolerance_boundaries_and_the_pose_named():
    """Exactly at -tol and at size + tol a pose is inside; the message names the first pose beyond."""
    g = ReportGrid(200, 100, 4, 2, 4)
    tol_x, tol_y = 1e-6 * 200.0, 1e-6 * 100.0
    ix, iy, _ = g.bin_indices([[-tol_x, 100.0 + tol_y, 0.0], [200.0 + tol_x, -tol_y, 0.0]])
    assert ix.tolist() == [0, 3] and iy.tolist() == [1, 0]
    for xs in ([-tol_x, 250.0], [10.0, 0.0, 250.0], [200.0 + tol_x, 250.0], [200.0, 250.0]):
        poses = [[x, 50.0, 0.0] for x in xs]
        bad = len(xs) - 1
        assert _message(g.bin_indices, poses) == f"pose {bad}: x = 250 mm lies outside the tray [0, 200]"


def test_unravel_range():
    g = ReportGrid(200, 100, 4, 2, 3)
    assert [a.tolist() for a in g.unravel([0, 23])] == [[0, 3], [0, 1], [0, 2]]
    for bad in ([-1], [24], [0, 24]):
        assert _message(g.unravel, bad) == "voxel index out of range [0, 24)"


def test_counts_are_int64_over_every_voxel():
    g = ReportGrid(200, 200, 2, 2, 1)
    c = g.counts([[10, 10, 0], [10, 10, 1]])
    assert c.dtype == np.int64 and c.tolist() == [2, 0, 0, 0]


def test_float32_poses_and_angles_are_binned_in_float64():
    """A float32 pose is binned by its value, not by float32 arithmetic: y = 57.1428566 (float32) lies
    below the edge 400/7 of bin 3 of 7 on a 100 mm tray, which float32 products would round onto."""
    g = ReportGrid(100, 100, 3, 7, 6, symmetry_order=2)
    p = np.array([[13.0, 400 / 7, 0.5]], dtype=np.float32)
    y = float(p[0, 1])
    assert 3 < y * 7 / 100 < 4 - 1e-8                                 # inside bin 3 in exact arithmetic
    assert g.bin_indices(p)[1].tolist() == [3]
    t = g.reduce_theta(np.array([7.0], dtype=np.float32))            # 7 - 2 pi (period pi), in float64
    assert t.dtype == np.float64 and abs(float(t[0]) - (7.0 - 2 * math.pi)) < 1e-12


def test_no_voxel_indices_and_index_arrays_of_any_shape():
    g = ReportGrid(200, 100, 4, 2, 3)
    assert [a.tolist() for a in g.unravel([])] == [[], [], []]
    assert g.centres([]).shape == (0, 3)
    idx = np.arange(8)
    np.testing.assert_array_equal(g.centres(idx.reshape(2, 4)), g.centres(idx).reshape(2, 4, 3))


def test_entropy_of_one_pose_is_zero_and_one_bad_pose_is_refused():
    g = ReportGrid(200, 200, 4, 4, 4)
    assert g.entropy_bits([[10.0, 10.0, 0.0]]) == 0.0 and g.entropy_bits(np.zeros((0, 3))) == 0.0
    assert _message(g.entropy_bits, [[np.nan, 10.0, 0.0]]) == \
        "pose 0 is not finite (NaN or infinity); drop faulted trials first"
    assert _message(g.entropy_bits, [[250.0, 10.0, 0.0]]) == "pose 0: x = 250 mm lies outside the tray [0, 200]"
