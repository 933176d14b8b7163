"""SimSettings.part_links: the prism as one compound link (``compound``) or as the yaw link's own
shape (``yaw-compound``) is the same geometry, so landings agree with today's chain of one link per
convex part to the documented tolerance (docs/builder.md, "A lighter multibody": at least 95% of
landings within 1 mm / 1 degree, the step convergence's tolerance; the hulls are read back from
OBJ text, so sensitive tilts move as under any floating-point change); the setting is part of a
scene's content hash only when not the default."""
from __future__ import annotations

import math

import numpy as np
import pytest

from transition_builder._bullet_world import BulletWorld
from transition_builder.sampling import sample_start_poses
from transition_builder.scene import scene_from_options
from transition_builder.sim import TraySimulator
from transition_builder.sim_settings import SimSettings


def _landings(starts, **settings):
    with TraySimulator(scene_from_options("allen-key", contact_pairs="needed", **settings)) as sim:
        out = [sim.tilt(starts, a) for a in ("E", "NE", "N")]
    return np.concatenate([r for r, _ in out]), np.concatenate([s for _, s in out])


@pytest.mark.parametrize("links", ["compound", "yaw-compound"])
def test_compound_prism_lands_where_the_per_part_chain_lands(links):
    starts = sample_start_poses(scene_from_options("allen-key").shape, 200.0, 200.0, 40, np.random.default_rng(41))
    ra, sa = _landings(starts)
    rb, sb = _landings(starts, part_links=links)
    assert np.mean(sa == sb) >= 0.95
    ok = (sa == 0) & (sb == 0)
    d = np.hypot(*(ra[ok, :2] - rb[ok, :2]).T)
    th = np.abs((ra[ok, 2] - rb[ok, 2] + math.pi) % (2 * math.pi) - math.pi)
    assert ok.sum() >= 100
    assert np.mean((d <= 1.0) & (th <= math.radians(1.0))) >= 0.95


@pytest.mark.parametrize("links, n_links, support", [("per-part", 6, 3), ("compound", 5, 3), ("yaw-compound", 5, 4)])
def test_layout_of_the_chain(links, n_links, support):
    sc = scene_from_options("allen-key", part_links=links)
    w = BulletWorld(sc, 0.0)
    try:
        assert w.n_links == n_links
        assert w.support_links == [support]
        # the part rests on its support sphere: the prism floats above the floor and touches nothing
        w.set_pose((100.0, 100.0, 0.3))
        for _ in range(10):
            w.step()
        assert abs(w.lift_mm()) < 0.05
    finally:
        w.close()


def test_part_links_enters_the_content_hash_only_when_not_the_default():
    default = scene_from_options("allen-key")
    assert "part_links" not in default.settings.to_dict()
    assert scene_from_options("allen-key", part_links="per-part").content_hash() == default.content_hash()
    compound = scene_from_options("allen-key", part_links="compound")
    assert compound.content_hash() != default.content_hash()
    assert SimSettings.from_dict(compound.settings.to_dict()).part_links == "compound"
    with pytest.raises(ValueError, match="part_links"):
        SimSettings(part_links="single")
