"""The tray's rotational symmetry: rotations about the tray centre that map the scene onto itself.

A square tray with uniform friction is invariant under rotations by 90 degrees about its centre; a
rectangular one under 180 degrees; a friction map breaks the symmetry. If ``R`` is such a rotation
and ``tilt(p, a)`` the rest pose reached from pose ``p`` under action ``a``, then

    tilt(R p, R a) = R tilt(p, a),

so the landings of one pose under every action give the landings of its rotated copies for free
(the builder simulates one representative per orbit; docs/builder.md). Measured on 6,000 rotated
allen-key landings: N-type tilts agree within 0.004 mm, diagonal ones within 0.01 mm for 93% and
always in the same report cell (the tray's own round-off amplified by near-critical starts).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from transition_builder.scene import ACTION_ANGLES_DEG, Scene

__all__ = ["TraySymmetry", "tray_symmetry"]


@dataclass(frozen=True)
class TraySymmetry:
    """The cyclic group of tray rotations used by a build.

    Attributes
    ----------
    order : int
        Group order ``G`` (1, 2 or 4); rotation ``j`` turns by ``j * 360 / G`` degrees.
    centre : tuple of float
        Tray centre (mm).
    action_map : ndarray (G, n_actions) int64
        ``action_map[j, a]`` = index of the action that rotation ``j`` makes of action ``a``.
    reason : str
        Why this order was chosen (for reports).
    """

    order: int
    centre: tuple
    action_map: np.ndarray
    reason: str

    def angle(self, j: int) -> float:
        """Rotation angle (rad) of group element ``j``."""
        return 2.0 * math.pi * (j % self.order) / self.order

    def rotate_poses(self, poses, j: int) -> np.ndarray:
        """Poses ``(n, 3)`` rotated by element ``j`` about the tray centre; theta in ``[0, 2 pi)``."""
        p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
        j %= self.order
        if j == 0:
            return p.copy()
        cx, cy = self.centre
        dx, dy = p[:, 0] - cx, p[:, 1] - cy
        out = np.empty_like(p)
        if self.order == 4 and j in (1, 3):       # exact for quarter turns (no cos/sin round-off)
            s = 1.0 if j == 1 else -1.0
            out[:, 0] = cx - s * dy
            out[:, 1] = cy + s * dx
        elif (self.order == 4 and j == 2) or self.order == 2:
            out[:, 0] = cx - dx
            out[:, 1] = cy - dy
        else:  # pragma: no cover - orders are 1, 2, 4
            raise AssertionError(self.order)
        th = np.mod(p[:, 2] + self.angle(j), 2.0 * math.pi)
        out[:, 2] = np.where(th >= 2.0 * math.pi, 0.0, th)
        return out

    def rotate_action(self, a: int, j: int) -> int:
        """Index of the action that rotation ``j`` (possibly negative) makes of action ``a``."""
        return int(self.action_map[j % self.order, a])

    def action_orbit_representatives(self) -> list[int]:
        """Actions ``B`` such that every action is ``rotate_action(b, j)`` for exactly one ``(b, j)``."""
        covered: set[int] = set()
        reps = []
        for a in range(self.action_map.shape[1]):
            if a in covered:
                continue
            reps.append(a)
            covered.update(int(self.action_map[j, a]) for j in range(self.order))
        return reps


def _action_map(scene: Scene, order: int) -> np.ndarray | None:
    names = scene.actions
    index = {round(ACTION_ANGLES_DEG[n] % 360.0, 6): i for i, n in enumerate(names)}
    out = np.empty((order, len(names)), dtype=np.int64)
    for j in range(order):
        for a, n in enumerate(names):
            key = round((ACTION_ANGLES_DEG[n] + 360.0 * j / order) % 360.0, 6)
            if key not in index:
                return None
            out[j, a] = index[key]
    return out


def tray_symmetry(scene: Scene, enabled: bool = True) -> TraySymmetry:
    """The largest rotation group of ``scene``: 4 for a square tray with uniform friction, 2 for a
    rectangular one, 1 with a friction map, when ``enabled`` is False, or when the action set is
    not closed under the rotations."""
    centre = (0.5 * scene.tray_x_mm, 0.5 * scene.tray_y_mm)
    ident = np.arange(len(scene.actions), dtype=np.int64)[None, :]
    if not enabled:
        return TraySymmetry(1, centre, ident, "symmetry reduction switched off")
    if scene.friction.kind != "uniform":
        return TraySymmetry(1, centre, ident, "friction map: the floor has no symmetry")
    square = math.isclose(scene.tray_x_mm, scene.tray_y_mm, rel_tol=0.0, abs_tol=1e-9)
    for order in ((4, 2) if square else (2,)):
        amap = _action_map(scene, order)
        if amap is not None:
            kind = "square tray, uniform friction" if order == 4 else "rectangular tray, uniform friction"
            if square and order == 2:
                kind = "square tray, but the action set is only closed under half turns"
            return TraySymmetry(order, centre, amap, kind)
    return TraySymmetry(1, centre, ident, "the action set is not closed under the tray's rotations")
