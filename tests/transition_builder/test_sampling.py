"""Tests for transition_builder.sampling: start poses uniform over the free configuration space."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from transition_builder.grid import ReportGrid
from transition_builder.sampling import is_collision_free, sample_start_poses
from transition_builder.shapes import parse_shape

A, B = 200.0, 200.0


@pytest.fixture(scope="module")
def key():
    return parse_shape("allen-key")


@pytest.fixture(scope="module")
def key_poses(key):
    return sample_start_poses(key, A, B, 20000, np.random.default_rng(1))


def _free_ranges(shape, theta):
    """For each theta: the exact interval of free x and of free y of the centroid."""
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    vx, vy = shape.vertices[:, 0], shape.vertices[:, 1]
    x = c * vx - s * vy
    y = s * vx + c * vy
    return -x.min(axis=1), A - x.max(axis=1), -y.min(axis=1), B - y.max(axis=1)


def _brute_force_voxel_probabilities(shape, grid, n_theta=20000):
    """Exact free C-space volume per voxel by quadrature over theta (midpoint rule)."""
    theta = (np.arange(n_theta) + 0.5) * 2 * math.pi / n_theta
    x0, x1, y0, y1 = _free_ranges(shape, theta)
    ex = np.linspace(0, A, grid.nx + 1)
    ey = np.linspace(0, B, grid.ny + 1)
    lx = np.clip(np.minimum(x1[:, None], ex[None, 1:]) - np.maximum(x0[:, None], ex[None, :-1]), 0, None)
    ly = np.clip(np.minimum(y1[:, None], ey[None, 1:]) - np.maximum(y0[:, None], ey[None, :-1]), 0, None)
    it = grid.bin_indices(np.column_stack([np.zeros(n_theta), np.zeros(n_theta), theta]))[2]
    vol = np.zeros(grid.shape)
    for j in range(grid.ntheta):
        sel = it == j
        vol[:, :, j] = lx[sel].T @ ly[sel]
    return (vol / vol.sum()).ravel()


def test_all_poses_collision_free(key, key_poses):
    assert key_poses.shape == (20000, 3)
    assert np.all((key_poses[:, 2] >= 0) & (key_poses[:, 2] < 2 * math.pi))
    v = key.placed(key_poses)
    assert v[..., 0].min() >= 0 and v[..., 0].max() <= A
    assert v[..., 1].min() >= 0 and v[..., 1].max() <= B
    assert np.all(is_collision_free(key, key_poses, A, B))


@pytest.mark.parametrize("spec", ["allen-key", "rectangle:150x20"])
def test_theta_density_matches_free_area(spec):
    # the theta marginal is proportional to the free area at that theta (KS test against it)
    shape = parse_shape(spec)
    poses = sample_start_poses(shape, A, B, 20000, np.random.default_rng(11))
    grid_t = np.linspace(0, 2 * math.pi, 4001)
    mid = 0.5 * (grid_t[1:] + grid_t[:-1])
    x0, x1, y0, y1 = _free_ranges(shape, mid)
    dens = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    cdf_vals = np.concatenate([[0], np.cumsum(dens)]) / dens.sum()

    def cdf(t):
        return np.interp(t, grid_t, cdf_vals)

    assert stats.kstest(poses[:, 2], cdf).pvalue > 1e-3
    if spec.startswith("rectangle"):
        # a long rod has much less room diagonally: uniform theta must be rejected
        # (chi-square on 36 theta bins; the density has period pi/2, which a KS test barely sees)
        counts = np.bincount((poses[:, 2] / (2 * math.pi) * 36).astype(int), minlength=36)
        assert stats.chisquare(counts).pvalue < 1e-6


def test_x_marginal_matches_brute_force(key, key_poses):
    theta = (np.arange(20000) + 0.5) * 2 * math.pi / 20000
    x0, x1, y0, y1 = _free_ranges(key, theta)
    w = np.clip(y1 - y0, 0, None)  # weight of each theta slice in the x marginal

    def cdf(x):
        x = np.atleast_1d(x)[:, None]
        covered = np.clip(np.minimum(x, x1[None, :]) - x0[None, :], 0, None)
        return (covered * w[None, :]).sum(axis=1) / (np.clip(x1 - x0, 0, None) * w).sum()

    assert stats.kstest(key_poses[:2000, 0], cdf).pvalue > 1e-3


def test_voxel_histogram_matches_brute_force(key, key_poses):
    grid = ReportGrid(A, B, 4, 4, 4)
    p = _brute_force_voxel_probabilities(key, grid)
    counts = grid.counts(key_poses)
    expected = p * len(key_poses)
    keep = expected > 5
    chi2 = stats.chisquare(counts[keep], expected[keep] * counts[keep].sum() / expected[keep].sum())
    assert chi2.pvalue > 1e-3


def test_initial_entropy_near_log2_occupied(key):
    # SPEC/issue sanity check: M = 10,000 uniform starts on the 4x4x4 grid
    poses = sample_start_poses(key, A, B, 10000, np.random.default_rng(7))
    grid = ReportGrid(A, B, 4, 4, 4)
    counts = grid.counts(poses)
    occupied = int((counts > 0).sum())
    h = grid.entropy_bits(poses)
    assert occupied == 64
    assert abs(h - math.log2(occupied)) < 0.5
    # and it agrees with the exact voxel probabilities (brute-force quadrature)
    p = _brute_force_voxel_probabilities(key, grid)
    h_exact = -np.sum(p[p > 0] * np.log2(p[p > 0]))
    assert abs(h - h_exact) < 0.02


def test_deterministic_for_seed(key):
    a = sample_start_poses(key, A, B, 500, np.random.default_rng(3))
    b = sample_start_poses(key, A, B, 500, 3)
    np.testing.assert_array_equal(a, b)
    c = sample_start_poses(key, A, B, 500, 4)
    assert not np.array_equal(a, c)


def test_margin_and_small_tray():
    rect = parse_shape("rectangle:40x20")
    p = sample_start_poses(rect, 60, 60, 2000, 0, margin_mm=2.0)
    v = rect.placed(p)
    assert v[..., 0].min() >= 2 and v[..., 0].max() <= 58
    assert v[..., 1].min() >= 2 and v[..., 1].max() <= 58


def test_errors(key):
    with pytest.raises(ValueError, match="does not fit"):
        sample_start_poses(parse_shape("rectangle:300x10"), A, B, 10, 0)
    with pytest.raises(ValueError, match="barely fits"):
        sample_start_poses(parse_shape("rectangle:199.99x199.99"), A, B, 10, 0)
    with pytest.raises(ValueError, match="non-negative integer"):
        sample_start_poses(key, A, B, -1, 0)
    assert sample_start_poses(key, A, B, 0, 0).shape == (0, 3)
