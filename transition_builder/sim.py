"""The PyBullet tray-tilt simulator: a batch of start poses and one action -> rest poses and status codes.

HOW THE MECHANICS ARE MADE RIGHT
--------------------------------
(To be completed with the measured errors.)
"""
from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np

from transition_builder import status as st_codes
from transition_builder._bullet_world import BulletWorld
from transition_builder.scene import Scene

__all__ = ["TraySimulator", "simulate", "SIMULATOR_VERSION", "valid_start"]

#: bump when the simulator's model changes in a way that changes results (part of the scene hash).
SIMULATOR_VERSION = "planar-chain-1"


def valid_start(scene: Scene, poses) -> np.ndarray:
    """True for every pose that is finite and whose outline lies inside the tray (collision-free)."""
    p = np.asarray(poses, dtype=np.float64)
    fin = np.all(np.isfinite(p), axis=1)
    ok = np.zeros(len(p), dtype=bool)
    if fin.any():
        v = scene.shape.placed(p[fin])
        tol = 1e-9
        inside = ((v[..., 0] >= -tol) & (v[..., 0] <= scene.tray_x_mm + tol)
                  & (v[..., 1] >= -tol) & (v[..., 1] <= scene.tray_y_mm + tol)).all(axis=1)
        ok[fin] = inside
    return ok


def _check_poses(poses) -> np.ndarray:
    p = np.asarray(poses, dtype=np.float64)
    if p.ndim == 1 and p.shape == (3,):
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"poses must be an (n, 3) array of (x_mm, y_mm, theta_rad); got shape {p.shape}")
    return p


class TraySimulator:
    """A tray-tilt simulator that keeps its PyBullet worlds alive between calls.

    One DIRECT-mode world per action, built on first use. Not thread-safe; one per process.

    Parameters
    ----------
    scene : Scene

    Examples
    --------
    >>> from transition_builder.scene import scene_from_options
    >>> with TraySimulator(scene_from_options("allen-key")) as sim:        # doctest: +SKIP
    ...     rest, status = sim.tilt([[100.0, 100.0, 0.3]], "E")
    """

    def __init__(self, scene: Scene):
        if not isinstance(scene, Scene):
            raise ValueError(f"TraySimulator needs a Scene, got {type(scene).__name__}")
        self.scene = scene
        self._worlds: dict[int, BulletWorld] = {}
        st = scene.settings
        self._dt_check = st.check_interval_s
        self._dwell_checks = max(1, int(math.ceil(st.dwell_s / self._dt_check - 1e-9)))
        self._max_checks = int(math.ceil(st.max_time_s / self._dt_check - 1e-9))
        self._v_rest = st.rest_speed_mm_s / 1000.0
        self._w_rest = st.rest_angular_speed_rad_s
        half = 0.5 * math.hypot(scene.tray_x_mm, scene.tray_y_mm) / 1000.0
        self._r_out = half + scene.wall_thickness_mm / 1000.0     # centroid beyond this: escaped
        self.steps_taken = 0

    # ------------------------------------------------------------------ worlds
    def _world(self, action) -> BulletWorld:
        k = self.scene.action_index(action)
        w = self._worlds.get(k)
        if w is None:
            w = BulletWorld(self.scene, self.scene.downhill_angle(k))
            self._worlds[k] = w
        return w

    def close(self):
        """Disconnect every PyBullet world."""
        for w in self._worlds.values():
            w.close()
        self._worlds.clear()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass

    # ------------------------------------------------------------------ one trial
    def _run(self, w: BulletWorld, pose) -> tuple[tuple[float, float, float], int]:
        w.set_pose(pose)
        still = 0
        r_out2 = self._r_out ** 2
        lift = self.scene.settings.lift_tolerance_mm / 1000.0
        for _ in range(self._max_checks):
            w.step()
            x, y, z, yaw, vx, vy, wz = w.state()
            if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw) and math.isfinite(vx)
                    and math.isfinite(vy) and math.isfinite(wz) and math.isfinite(z)):
                return None, st_codes.INVALID
            if x * x + y * y > r_out2 or z < -lift:
                return None, st_codes.ESCAPED
            if vx * vx + vy * vy < self._v_rest ** 2 and abs(wz) < self._w_rest:
                still += 1
                if still >= self._dwell_checks:
                    break
            else:
                still = 0
        else:
            return None, st_codes.UNSETTLED
        self.steps_taken += 0
        if abs(z) > lift:
            return None, st_codes.TIPPED
        return w.to_tray(x, y, yaw), st_codes.OK

    def tilt(self, poses, action) -> tuple[np.ndarray, np.ndarray]:
        """Tilt the tray toward ``action`` from every start pose; return ``(rest_poses, status)``.

        Parameters
        ----------
        poses : array_like (n, 3)
            Start poses ``(x_mm, y_mm, theta_rad)`` in the tray frame.
        action : str or int
            Action name (``"NE"``) or index into ``scene.actions``.

        Returns
        -------
        rest_poses : ndarray (n, 3)
            Rest pose of every trial, theta in ``[0, 2 pi)``; NaN where the trial faulted.
        status : ndarray (n,) int8
            :mod:`transition_builder.status` codes. A start pose that is not finite or not inside
            the tray is ``INVALID``; a part that left the tray ``ESCAPED``; lifted off the floor
            ``TIPPED``; still moving after ``max_time_s`` ``UNSETTLED``.
        """
        p = _check_poses(poses)
        w = self._world(action)
        n = len(p)
        out = np.full((n, 3), np.nan)
        status = np.full(n, st_codes.INVALID, dtype=np.int8)
        valid = valid_start(self.scene, p)
        sc = self.scene
        tol = sc.settings.escape_tolerance_mm
        for i in range(n):
            if not valid[i]:
                continue
            pose, code = self._run(w, p[i])
            if code == st_codes.OK:
                v = sc.shape.placed(pose)
                if (v[:, 0].min() < -tol or v[:, 1].min() < -tol or v[:, 0].max() > sc.tray_x_mm + tol
                        or v[:, 1].max() > sc.tray_y_mm + tol):
                    code = st_codes.ESCAPED
                else:
                    out[i] = pose
            status[i] = code
        return out, status

    def trajectory(self, pose, action, duration_s: float):
        """Free-run one trial for ``duration_s`` (no rest test) and record it after every check interval.

        Returns ``(t, poses, z)``: times (s, from the start of the tilt), tray-frame poses (mm, rad;
        theta unwrapped, not reduced modulo 2 pi) and the height of the part above its resting
        height (mm). A lower-level view for mechanics tests.
        """
        p = _check_poses(pose)[0]
        if not valid_start(self.scene, p[None])[0]:
            raise ValueError(f"start pose {p.tolist()} is not inside the tray")
        w = self._world(action)
        w.set_pose(p)
        k = int(math.ceil(duration_s / self._dt_check - 1e-9))
        t = np.arange(k + 1) * self._dt_check
        out = np.empty((k + 1, 3))
        z = np.empty(k + 1)
        x, y, zz, yaw = w.state()[:4]
        for i in range(k + 1):
            if i:
                w.step()
                x, y, zz, yaw = w.state()[:4]
            px, py, _ = w.to_tray(x, y, 0.0)
            out[i] = (px, py, yaw + w.phi)
            z[i] = zz * 1000.0
        return t, out, z


_SIMULATORS: "OrderedDict[str, TraySimulator]" = OrderedDict()


def simulate(scene: Scene, poses, action) -> tuple[np.ndarray, np.ndarray]:
    """Tilt the tray toward ``action`` from every start pose: ``(rest_poses (n, 3), status (n,) int8)``.

    Convenience form of :meth:`TraySimulator.tilt` that keeps the last few simulators of this
    process alive (keyed by the scene's content hash). Faulted trials have NaN poses.
    """
    if not isinstance(scene, Scene):
        raise ValueError(f"simulate needs a Scene, got {type(scene).__name__}")
    key = scene.content_hash()
    sim = _SIMULATORS.get(key)
    if sim is None:
        sim = TraySimulator(scene)
        _SIMULATORS[key] = sim
        while len(_SIMULATORS) > 2:
            _SIMULATORS.popitem(last=False)[1].close()
    else:
        _SIMULATORS.move_to_end(key)
    return sim.tilt(poses, action)
