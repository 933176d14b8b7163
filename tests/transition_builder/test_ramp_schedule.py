"""The tilt-time ramp's schedule (``ramp_fractions``), value by value on cases worked by hand: the
slope of each rest-test interval is the tilt at the interval's midpoint, clipped at the full tilt,
and the full tilt from the interval after the ramp on (docs/simulator.md, "The tilt's own motion")."""

import math

import numpy as np
import pytest

from transition_builder.sim import ramp_fractions


def test_a_ramp_of_whole_intervals_takes_each_midpoint():
    # 0.4 s in intervals of 0.1 s: k = 4 ramp intervals at midpoints 0.05, 0.15, 0.25, 0.35 s,
    # then the full tilt
    np.testing.assert_allclose(ramp_fractions(0.4, 0.1), [0.125, 0.375, 0.625, 0.875, 1.0], rtol=0, atol=1e-15)


def test_the_midpoint_past_the_tilt_time_is_clipped_to_the_full_tilt():
    # 1.03 s at 0.1 s: k = ceil(10.3) = 11; interval 10's midpoint 1.05 s is past the tilt time, so
    # it takes the full tilt (1.05 / 1.03 = 1.019 unclipped)
    f = ramp_fractions(1.03, 0.1)
    assert f.size == 12
    assert f[9] == pytest.approx(0.95 / 1.03, abs=1e-15)
    assert f[10] == 1.0 and f[11] == 1.0
    assert np.all(np.diff(f) >= 0) and f.max() == 1.0


def test_a_tilt_time_of_one_and_a_half_intervals():
    # 0.15 s at 0.1 s: k = 2; midpoints 0.05 s (1/3 of the tilt) and 0.15 s (the full tilt)
    np.testing.assert_allclose(ramp_fractions(0.15, 0.1), [1 / 3, 1.0, 1.0], rtol=0, atol=1e-15)


def test_a_ramp_shorter_than_one_interval_is_one_interval():
    # 0.05 s at 0.1 s: k = 1; its midpoint (0.05 s) is the tilt time itself, so the full tilt at once
    np.testing.assert_array_equal(ramp_fractions(0.05, 0.1), [1.0, 1.0])
    np.testing.assert_allclose(ramp_fractions(0.2, 0.1), [0.25, 0.75, 1.0], rtol=0, atol=1e-15)


def test_an_instant_tilt_has_no_ramp():
    assert ramp_fractions(0.0, 0.1).size == 0


@pytest.mark.parametrize("tilt_time, dt, message", [
    (-0.1, 0.1, "tilt_time_s must be a number >= 0, got -0.1"),
    (math.nan, 0.1, "tilt_time_s must be a number >= 0, got nan"),
    (0.3, 0.0, "check_interval_s must be a positive number, got 0.0"),
    (0.3, -1.0, "check_interval_s must be a positive number, got -1.0"),
    (0.3, math.inf, "check_interval_s must be a positive number, got inf")])
def test_bad_arguments_are_refused_with_the_argument_named(tilt_time, dt, message):
    with pytest.raises(ValueError) as err:
        ramp_fractions(tilt_time, dt)
    assert str(err.value) == message
