"""Tests for the tray's rotation group (transition_builder.symmetry): its order, the rotation of
poses and actions, and the orbit representatives."""
from __future__ import annotations

import math

import numpy as np
import pytest

from transition_builder.scene import scene_from_options
from transition_builder.symmetry import tray_symmetry


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
