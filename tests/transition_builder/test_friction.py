"""Friction specs and maps."""
from __future__ import annotations

import numpy as np
import pytest

from transition_builder.friction import MAP_LEVELS, friction_map, parse_friction


def test_uniform():
    spec = parse_friction("0.25")
    mu, tile = friction_map(spec, 200, 200)
    assert mu.shape == (1, 1) and mu[0, 0] == 0.25 and tile >= 200


@pytest.mark.parametrize("level", list(MAP_LEVELS))
def test_map_amplitude_mean_and_seed(level):
    a, tile = friction_map(parse_friction(f"map:{level}:3"), 200, 200)
    b, _ = friction_map(parse_friction(f"map:{level}:3"), 200, 200)
    c, _ = friction_map(parse_friction(f"map:{level}:4"), 200, 200)
    assert a.shape == (20, 20) and tile == 10.0
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert np.isclose(a.mean(), 0.3)
    assert np.isclose(np.abs(a - 0.3).max(), MAP_LEVELS[level])
    assert a.min() > 0 and a.max() < np.tan(np.radians(30.0))
    # spatially smooth: neighbouring tiles differ much less than the full range
    assert np.abs(np.diff(a, axis=0)).mean() < 0.25 * (a.max() - a.min())


def test_levels_are_ordered():
    amp = [np.ptp(friction_map(parse_friction(f"map:{lv}:1"), 200, 200)[0]) for lv in ("low", "medium", "high")]
    assert amp[0] < amp[1] < amp[2]


def test_non_square_tray_covers_it():
    mu, tile = friction_map(parse_friction("map:low:1"), 205, 120)
    assert mu.shape == (21, 12)


@pytest.mark.parametrize("bad", ["", "x", "map:", "map:low", "map:low:1:2:3", "map:low:1:x", "map:low:1:0.3/0.5", "map:foo:1", "map:low:-1",
                                 "-0.1", "inf", None, [0.3]])
def test_bad_specs(bad):
    with pytest.raises(ValueError):
        parse_friction(bad)
