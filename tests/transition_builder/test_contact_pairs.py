"""SimSettings.contact_pairs: the pairs left out never carry a force, so landings agree with every
pair tested (within the step-convergence tolerance of 1 mm / 1 degree); the setting is part of a
scene's content hash only when not its legacy value, ``all``."""
from __future__ import annotations

import math

import numpy as np
import pytest

from transition_builder.sampling import sample_start_poses
from transition_builder.scene import scene_from_options
from transition_builder.sim import TraySimulator
from transition_builder.sim_settings import SimSettings


def test_needed_pairs_land_where_all_pairs_land():
    starts = sample_start_poses(scene_from_options("allen-key").shape, 200.0, 200.0, 40, np.random.default_rng(41))
    out = {}
    for pairs in ("all", "needed"):
        with TraySimulator(scene_from_options("allen-key", contact_pairs=pairs)) as sim:
            out[pairs] = [sim.tilt(starts, a) for a in ("E", "NE", "N")]
    for (ra, sa), (rb, sb) in zip(out["all"], out["needed"]):
        assert np.array_equal(sa, sb)
        ok = sa == 0
        d = np.hypot(*(ra[ok, :2] - rb[ok, :2]).T)
        th = np.abs((ra[ok, 2] - rb[ok, 2] + math.pi) % (2 * math.pi) - math.pi)
        assert np.all(d <= 1.0) and np.all(th <= math.radians(1.0))


def test_contact_pairs_enters_the_content_hash_only_when_not_the_legacy_value():
    """``needed`` is the default (seventh session) and is recorded; ``all``, the physics of every
    scene before, is left out, so those scenes keep their keys, and a saved dict without it reads
    back as ``all``."""
    default = scene_from_options("allen-key")
    assert default.settings.to_dict()["contact_pairs"] == "needed"
    assert scene_from_options("allen-key", contact_pairs="needed").content_hash() == default.content_hash()
    legacy = scene_from_options("allen-key", contact_pairs="all")
    assert "contact_pairs" not in legacy.settings.to_dict()
    assert legacy.content_hash() != default.content_hash()
    for sc in (default, legacy):
        assert SimSettings.from_dict(sc.settings.to_dict()) == sc.settings
    with pytest.raises(ValueError, match="contact_pairs"):
        SimSettings(contact_pairs="some")
