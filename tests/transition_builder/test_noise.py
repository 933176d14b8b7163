"""Tests for transition_builder.noise (process noise) and its use in direct Monte Carlo."""
from __future__ import annotations

import math

import numpy as np
import pytest

from transition_builder.noise import (
    CONTACT_TOLERANCE_MM,
    MAX_REDRAWS,
    NoiseSpec,
    noise_rng,
    parse_noise,
    penetration_mm,
    perturb_pose,
    perturb_poses,
)
from transition_builder.scene import scene_from_options


@pytest.fixture(scope="module")
def scene():
    return scene_from_options("allen-key")


# ---------------------------------------------------------------------------------- parsing

@pytest.mark.parametrize("spec, kind, mm, deg, text", [
    (None, "none", 0.0, 0.0, "none"),
    ("none", "none", 0.0, 0.0, "none"),
    (" NONE ", "none", 0.0, 0.0, "none"),
    ("pose:0.5,0.5", "pose", 0.5, 0.5, "pose:0.5,0.5"),
    ("pose: 1 , 2.25", "pose", 1.0, 2.25, "pose:1,2.25"),
    ("POSE:0,3", "pose", 0.0, 3.0, "pose:0,3"),
    ("pose:0.1234567891,1e-3", "pose", 0.1234567891, 0.001, "pose:0.1234567891,0.001"),
    ("pose:0,0", "pose", 0.0, 0.0, "none"),
])
def test_parse_noise_good(spec, kind, mm, deg, text):
    n = parse_noise(spec)
    assert (n.kind, n.sigma_mm, n.sigma_deg) == (kind, mm, deg)
    assert str(n) == text
    assert parse_noise(str(n)).to_dict() == n.to_dict()  # the canonical text round-trips
    assert n.is_zero == (mm == 0.0 and deg == 0.0)
    assert parse_noise(n) is n


def test_zero_pose_noise_is_none():
    z = parse_noise("pose:0,0")
    assert z.is_zero and str(z) == "none" and z.to_dict() == parse_noise("none").to_dict()
    assert parse_noise("pose:0.5,0").to_dict() == {"kind": "pose", "sigma_mm": 0.5, "sigma_deg": 0.0}
    assert not parse_noise("pose:0,1").is_zero


@pytest.mark.parametrize("spec", ["pose:x", "pose:1", "pose:1,2,3", "pose:-1,0", "pose:0,-0.5", "pose:nan,1",
                                  "pose:inf,0", "gauss:1,1", "", "pose", "pose:,", 0.5, ["pose", 1, 1]])
def test_parse_noise_bad(spec):
    with pytest.raises(ValueError) as exc:
        parse_noise(spec)
    msg = str(exc.value)
    assert len(msg.splitlines()) == 1
    assert "none or pose:SIGMA_MM,SIGMA_DEG" in msg


def test_noise_spec_validation():
    with pytest.raises(ValueError, match="unknown noise kind"):
        NoiseSpec("gauss", 1.0, 1.0)
    with pytest.raises(ValueError, match="non-negative"):
        NoiseSpec("pose", -1.0, 0.0)
    with pytest.raises(ValueError, match="takes no sigmas"):
        NoiseSpec("none", 1.0, 0.0)


def test_noise_rng_streams():
    a = noise_rng(3, 5, 1).standard_normal(4)
    np.testing.assert_array_equal(a, noise_rng(3, 5, 1).standard_normal(4))
    assert not np.array_equal(a, noise_rng(3, 5, 2).standard_normal(4))
    assert not np.array_equal(a, noise_rng(4, 5, 1).standard_normal(4))
    assert not np.array_equal(noise_rng(3).standard_normal(4), np.random.default_rng(3).standard_normal(4))
    for bad in ((-1,), (1, -2), (1, 2.0), (True,)):
        with pytest.raises(ValueError, match="non-negative integers"):
            noise_rng(*bad)


# ---------------------------------------------------------------------------------- perturbation

def test_perturbation_statistics_in_the_open(scene):
    """Away from the walls every first draw is accepted: the sample sd matches sigma (10%)."""
    noise = parse_noise("pose:0.8,3")
    p = np.array([100.0, 100.0, 1.0])
    assert penetration_mm(scene, p) == 0.0
    rng = noise_rng(0, 1)
    out = np.empty((2000, 3))
    for i in range(2000):
        out[i], redraws = perturb_pose(scene, p, noise, rng)
        assert redraws == 0
    d = out - p
    sd = d.std(axis=0, ddof=1)
    assert abs(sd[0] / 0.8 - 1) < 0.1 and abs(sd[1] / 0.8 - 1) < 0.1
    assert abs(sd[2] / math.radians(3) - 1) < 0.1
    assert np.all(np.abs(d.mean(axis=0)) < 3 * sd / math.sqrt(2000) + 1e-12)
    assert abs(np.corrcoef(d[:, 0], d[:, 1])[0, 1]) < 0.1


def _touching_west_wall(scene, theta, y=100.0, depth=0.0):
    """A pose whose leftmost vertex lies exactly ``depth`` mm beyond x = 0."""
    v = scene.shape.placed(np.array([0.0, y, theta]))
    return np.array([-v[:, 0].min() - depth, y, theta])


@pytest.mark.parametrize("depth", [0.0, 0.015])
def test_perturbation_never_pushes_into_a_wall(scene, depth):
    noise = parse_noise("pose:1,5")
    rng = noise_rng(1, 2)
    for theta in (0.0, 0.7, 2.0, 4.5):
        p = _touching_west_wall(scene, theta, depth=depth)
        before = penetration_mm(scene, p)
        assert before == pytest.approx(depth, abs=1e-9)
        moved = total_redraws = 0
        for _ in range(300):
            q, redraws = perturb_pose(scene, p, noise, rng)
            assert penetration_mm(scene, q) <= max(before, 0.0) + CONTACT_TOLERANCE_MM + 1e-12
            assert 0.0 <= q[2] < 2 * math.pi
            moved += not np.array_equal(q, p)
            total_redraws += redraws
        assert moved == 300          # a part against a wall can still move away or along it
        assert total_redraws > 50    # and candidates into the wall were redrawn


def test_perturbation_gives_up_and_keeps_the_pose(scene):
    p = np.array([100.0, 100.0, 1.0])
    q, redraws = perturb_pose(scene, p, parse_noise("pose:1e6,0"), noise_rng(0))
    np.testing.assert_array_equal(q, p)
    assert redraws == MAX_REDRAWS + 1


def test_zero_noise_draws_nothing(scene):
    p = np.array([37.5, 120.25, 6.2])
    rng = noise_rng(0)
    state = rng.bit_generator.state
    for spec in (None, "none", "pose:0,0"):
        q, redraws = perturb_pose(scene, p, spec, rng)
        np.testing.assert_array_equal(q, p)
        assert redraws == 0
    assert rng.bit_generator.state == state
    np.testing.assert_array_equal(perturb_poses(scene, [p, p], "pose:0,0", [rng, rng]), [p, p])
    assert rng.bit_generator.state == state


def test_perturb_poses_rows_and_nan(scene):
    noise = parse_noise("pose:0.5,2")
    poses = np.array([[100.0, 100.0, 0.01], [np.nan] * 3, [80.0, 90.0, 6.28]])
    rngs = [noise_rng(5, t, 1) for t in range(3)]
    nan_state = rngs[1].bit_generator.state
    out = perturb_poses(scene, poses, noise, rngs)
    assert np.all(np.isnan(out[1])) and rngs[1].bit_generator.state == nan_state
    for t in (0, 2):
        np.testing.assert_array_equal(out[t], perturb_pose(scene, poses[t], noise, noise_rng(5, t, 1))[0])
        assert not np.array_equal(out[t], poses[t])
    assert np.all((out[[0, 2], 2] >= 0) & (out[[0, 2], 2] < 2 * math.pi))
    with pytest.raises(ValueError, match="one generator per pose"):
        perturb_poses(scene, poses, noise, rngs[:2])


# ---------------------------------------------------------------------------------- direct Monte Carlo

SEQ = ["NE", "S", "W"]


@pytest.fixture(scope="module")
def runs(scene):
    from analysis.montecarlo import run_direct

    out = {"none": run_direct(scene, SEQ, 24, seed=2, workers=1)}
    out["zero"] = run_direct(scene, SEQ, 24, seed=2, workers=1, noise="pose:0,0")
    out["noisy"] = run_direct(scene, SEQ, 24, seed=2, workers=1, noise="pose:0.5,0.5")
    out["again"] = run_direct(scene, SEQ, 24, seed=2, workers=1, noise=parse_noise("pose:0.5,0.5"))
    out["two"] = run_direct(scene, SEQ, 24, seed=2, workers=2, noise="pose:0.5,0.5")
    return out


def test_zero_noise_is_bit_identical_to_none(runs):
    a, b = runs["none"], runs["zero"]
    assert np.array_equal(a.poses, b.poses, equal_nan=True)
    assert np.array_equal(a.status, b.status)
    assert a.to_dict()["noise"] == b.to_dict()["noise"] == "none"


def test_noise_reproducible_and_independent_of_workers(runs):
    a = runs["noisy"]
    for other in (runs["again"], runs["two"]):
        assert np.array_equal(a.poses, other.poses, equal_nan=True)
        assert np.array_equal(a.status, other.status)
        assert np.array_equal(a.entropy_bits, other.entropy_bits)
    assert a.to_dict()["noise"] == "pose:0.5,0.5"
    # the starts are the same, the rest poses are not
    np.testing.assert_array_equal(a.poses[:, 0], runs["none"].poses[:, 0])
    assert not np.array_equal(a.poses[:, 1:], runs["none"].poses[:, 1:], equal_nan=True)


def test_rest_poses_against_walls_stay_out_of_them(scene, runs):
    """Rest poses from the simulator (touching walls) are never pushed deeper than the tolerance."""
    noise = parse_noise("pose:1,5")
    rest = runs["none"].poses[:, 1]
    rest = rest[np.all(np.isfinite(rest), axis=1)]
    before = np.array([penetration_mm(scene, p) for p in rest])
    assert np.all(before < 0.1) and np.any(before > 0)  # in contact, a little penetration
    for t, p in enumerate(rest):
        rng = noise_rng(9, t)
        for _ in range(50):
            q, _ = perturb_pose(scene, p, noise, rng)
            assert penetration_mm(scene, q) <= before[t] + CONTACT_TOLERANCE_MM + 1e-12
    assert runs["noisy"].faults["invalid"] == 0  # perturbed poses are valid starts


def test_noise_needs_an_integer_seed(scene):
    from analysis.montecarlo import run_direct

    with pytest.raises(ValueError, match="non-negative integer seed"):
        run_direct(scene, ["E"], 4, seed=-1, workers=1, noise="pose:1,1", start_poses=[[100, 100, 0]] * 4)
