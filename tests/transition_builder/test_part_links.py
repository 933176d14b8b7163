"""SimSettings.part_links: the prism as one compound link (``compound``) or as the yaw link's own
shape (``yaw-compound``), and the part as the multibody's free base (``floating``), are the same
geometry and mass, so landings agree with today's chain of one link per convex part to the
documented tolerance (docs/builder.md, "A lighter multibody": at least 95% of
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


@pytest.mark.parametrize("links", ["compound", "yaw-compound", "floating"])
def test_compound_prism_lands_where_the_per_part_chain_lands(links):
    starts = sample_start_poses(scene_from_options("allen-key").shape, 200.0, 200.0, 40, np.random.default_rng(41))
    ra, sa = _landings(starts, part_links="per-part")     # the chain of slides and hinge
    rb, sb = _landings(starts, part_links=links)
    assert np.mean(sa == sb) >= 0.95
    ok = (sa == 0) & (sb == 0)
    d = np.hypot(*(ra[ok, :2] - rb[ok, :2]).T)
    th = np.abs((ra[ok, 2] - rb[ok, 2] + math.pi) % (2 * math.pi) - math.pi)
    assert ok.sum() >= 100
    assert np.mean((d <= 1.0) & (th <= math.radians(1.0))) >= 0.95


@pytest.mark.parametrize("links, n_links, support", [("per-part", 6, 3), ("compound", 5, 3), ("yaw-compound", 5, 4),
                                                     ("floating", 2, -1)])
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


def test_floating_part_stays_flat_and_reads_its_yaw_like_the_hinge():
    """The free base's roll and pitch stay far below a degree while it slides into a wall and along
    it; its yaw reads like the chain's hinge angle, continuous past pi (a quaternion alone would
    give -pi + 0.01 for pi + 0.01), so the rest test never sees a jump of 2 pi."""
    import pybullet as pb
    sc = scene_from_options("allen-key", part_links="floating")
    w = BulletWorld(sc, 0.0)
    try:
        w.set_pose((150.0, 100.0, 0.3), twist=(400.0, 300.0, 0.0))
        worst = 0.0
        for _ in range(120):
            w.step()
            q = pb.getBasePositionAndOrientation(w.body, physicsClientId=w.cid)[1]
            worst = max(worst, *np.abs(pb.getEulerFromQuaternion(q)[:2]))
        x, y = w.to_tray(*w.state()[:2], 0.3)[:2]
        assert x == pytest.approx(200.0 - 46.51, abs=0.5)  # at rest against the east wall (the key reaches 46.51 mm east)
        assert y > 105.0                                     # after sliding north along it
        assert worst < math.radians(0.1)
        w.set_pose((100.0, 100.0, math.pi + 0.01))
        for _ in range(5):
            w.step()
            assert w.state()[3] == pytest.approx(math.pi + 0.01, abs=1e-3)
    finally:
        w.close()


def test_floating_reads_as_per_part_with_legs():
    """The legs hang from the chain's slides, so ``floating`` (the default) means ``per-part`` with
    ``legs:K``; a default scene switched to legs is the legacy legs scene (same key)."""
    assert SimSettings(part_links="floating", contact="legs:4").part_links == "per-part"
    legs = scene_from_options("allen-key").with_settings(contact="legs:4")
    assert legs.settings.part_links == "per-part" and "part_links" not in legs.settings.to_dict()
    assert legs.content_hash() == scene_from_options("allen-key", contact="legs:4", part_links="per-part").content_hash()


def test_part_links_enters_the_content_hash_only_when_not_the_legacy_value():
    default = scene_from_options("allen-key")
    assert default.settings.to_dict()["part_links"] == "floating"
    legacy = scene_from_options("allen-key", part_links="per-part")
    assert "part_links" not in legacy.settings.to_dict()
    assert legacy.content_hash() != default.content_hash()
    compound = scene_from_options("allen-key", part_links="compound")
    assert len({compound.content_hash(), default.content_hash(), legacy.content_hash()}) == 3
    for sc in (default, legacy, compound):
        assert SimSettings.from_dict(sc.settings.to_dict()) == sc.settings
    with pytest.raises(ValueError, match="part_links"):
        SimSettings(part_links="single")
