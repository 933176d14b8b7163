"""The planar tilt simulator: the interface of :class:`transition_builder.sim.TraySimulator`, in compiled code.

A flat part in a convex tray moves in the tray's plane only, so its state is ``(x, y, theta, vx, vy,
omega)``; the floor's friction is the distributed Coulomb friction the PyBullet contact computes too
(:mod:`transition_builder._coulomb`'s quadrature points and stick rule), and the walls are four
half-planes the outline's vertices cannot cross. :mod:`transition_builder.planar._kernels` runs a
whole batch of tilts in one compiled call; this class validates input, maps the scene to the
kernels' arrays once, and keeps PyBullet's conventions: the same rest test (mean velocities over
each rest-test interval of ``substeps`` steps, ``dwell_s``), time limit, tilt-time ramp
(:func:`transition_builder.sim.ramp_fractions`), fault codes (:mod:`transition_builder.status`; a
landing outside the tray is ``ESCAPED``, never a pose) and frame (docs/commands.md). Process noise
stays outside the engine, as for PyBullet. The planar part cannot tip: ``TIPPED`` never occurs.

Settings that only PyBullet has (solver iterations, world scale, contact pairs, links, long steps,
support sphere, contact threshold) do not change a planar result; the time step, the rest test,
the footprint's quadrature points, the stick speed and the friction do.

References
----------
Goyal, Ruina and Papadopoulos, "Planar sliding with dry friction", Wear 143 (1991) (the floor's
friction wrench); Catto, "Iterative dynamics with temporal coherence", GDC 2005 (sequential impulses).
"""
from __future__ import annotations

import math

import numpy as np

from transition_builder import status as st_codes
from transition_builder._coulomb import footprint_points
from transition_builder._tilt_contract import check_poses, ramp_fractions, valid_start
from transition_builder.friction import friction_map
from transition_builder.planar import _kernels as K
from transition_builder.scene import Scene

__all__ = ["PlanarSimulator", "G_MM_S2", "SOLVER_ITERATIONS", "SOLVER_TOLERANCE_MM_S"]

#: gravity (mm/s^2), the value PyBullet's worlds use (9.81 m/s^2)
G_MM_S2 = 9810.0
#: most sequential-impulse iterations per step (the solve ends earlier once nothing changes)
SOLVER_ITERATIONS = 20
#: the solve ends once no impulse changes a velocity by more than this (mm/s)
SOLVER_TOLERANCE_MM_S = 1e-4


def _wrap(theta: np.ndarray) -> np.ndarray:
    th = np.mod(theta, 2.0 * math.pi)
    th[th >= 2.0 * math.pi] = 0.0          # -tiny % 2pi rounds to 2pi
    return th


class PlanarSimulator:
    """A tray-tilt simulator for flat parts in compiled code (the ``planar`` engine).

    Parameters
    ----------
    scene : Scene

    Examples
    --------
    >>> from transition_builder.scene import scene_from_options
    >>> sim = PlanarSimulator(scene_from_options("rectangle:40x20", engine="planar"))
    >>> rest, status = sim.tilt([[100.0, 100.0, 0.0]], "E")
    >>> int(status[0]), round(float(rest[0, 0]), 3)          # flush against the east wall
    (0, 180.0)
    """

    def __init__(self, scene: Scene):
        if not isinstance(scene, Scene):
            raise ValueError(f"PlanarSimulator needs a Scene, got {type(scene).__name__}")
        self.scene = scene
        st = scene.settings
        shape = scene.shape
        pts, w = footprint_points(shape.vertices, st.footprint_points)
        r = np.hypot(pts[:, 0], pts[:, 1])
        self._geom = np.ascontiguousarray(np.vstack([pts[:, 0], pts[:, 1], w, r]))
        self._verts = np.ascontiguousarray(shape.vertices, dtype=np.float64)
        mu, tile = friction_map(scene.friction, scene.tray_x_mm, scene.tray_y_mm)
        self._mu = np.ascontiguousarray(mu, dtype=np.float64)
        a = math.radians(scene.tilt_deg)
        dt_check = st.check_interval_s
        p = np.zeros(K.P_NPARAMS)
        p[K.P_W], p[K.P_H] = scene.tray_x_mm, scene.tray_y_mm
        p[K.P_GSIN], p[K.P_GCOS] = G_MM_S2 * math.sin(a), G_MM_S2 * math.cos(a)
        p[K.P_DT], p[K.P_SUB] = st.time_step_s, st.substeps
        p[K.P_DWELL] = max(1, int(math.ceil(st.dwell_s / dt_check - 1e-9)))
        p[K.P_MAXCHK] = int(math.ceil(st.max_time_s / dt_check - 1e-9))
        p[K.P_DLIN] = st.rest_speed_mm_s * dt_check
        p[K.P_DANG] = st.rest_angular_speed_rad_s * dt_check
        r_out = 0.5 * math.hypot(scene.tray_x_mm, scene.tray_y_mm) + scene.wall_thickness_mm
        p[K.P_ROUT2] = r_out * r_out
        p[K.P_CX], p[K.P_CY] = scene.tray_x_mm / 2.0, scene.tray_y_mm / 2.0
        p[K.P_STICK] = st.stick_speed_mm_s
        p[K.P_RATIO] = scene.friction.static_ratio
        p[K.P_WALLMU] = scene.effective_wall_mu
        p[K.P_K] = shape.inertia_kg_m2 / shape.mass_kg * 1e6          # polar inertia per mass, mm^2
        p[K.P_RMAX] = shape.radius_mm
        p[K.P_TILE] = tile
        p[K.P_ITERS] = SOLVER_ITERATIONS
        p[K.P_TOL] = SOLVER_TOLERANCE_MM_S
        p[K.P_WARM] = 1.0          # each wall contact starts from its impulses of the step before
        p[K.P_WSUM] = float(np.sum(w))
        p[K.P_WRSUM] = float(np.sum(w * r))
        self._params = p
        slopes = a * ramp_fractions(scene.tilt_time_s, dt_check)
        self._ramp_sin = np.ascontiguousarray(G_MM_S2 * np.sin(slopes))
        self._ramp_cos = np.ascontiguousarray(G_MM_S2 * np.cos(slopes))

    # the interface of TraySimulator: nothing to build, reset or close
    def prepare(self, actions=None):
        """Nothing to build (kept for the interface of :class:`transition_builder.sim.TraySimulator`)."""

    def fresh_start(self):
        """Nothing survives between trials in this engine: every trial starts from its pose alone."""

    def close(self):
        """Nothing to release."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    @property
    def friction_map(self) -> bool:
        """True when the scene's friction is a map (tile coefficients)."""
        return self._mu.size > 1

    def _params_for(self, action) -> np.ndarray:
        phi = self.scene.downhill_angle(self.scene.action_index(action))
        p = self._params.copy()
        p[K.P_DX], p[K.P_DY] = math.cos(phi), math.sin(phi)
        return p

    def tilt(self, poses, action) -> tuple[np.ndarray, np.ndarray]:
        """Tilt the tray toward ``action`` from every start pose; return ``(rest_poses, status)``.

        The same contract as :meth:`transition_builder.sim.TraySimulator.tilt`: rest poses with theta
        in ``[0, 2 pi)``, NaN where a trial faulted; ``status`` int8 codes (a start that is not finite
        or not inside the tray is ``INVALID``; a landing outside it ``ESCAPED``; still moving after
        ``max_time_s`` ``UNSETTLED``).
        """
        p = check_poses(poses)
        params = self._params_for(action)
        n = len(p)
        out = np.empty((n, 3))
        status = np.empty(n, dtype=np.int8)
        valid = np.ascontiguousarray(valid_start(self.scene, p))
        K._tilt_batch(np.where(valid[:, None], p, 0.0), valid, self._geom, self._verts, self._mu, params,
                      self._ramp_sin, self._ramp_cos, out, status)
        landed = status == st_codes.OK
        out[landed, 2] = _wrap(out[landed, 2])
        escaped = landed & ~valid_start(self.scene, np.where(landed[:, None], out, 0.0))
        status[escaped] = st_codes.ESCAPED
        out[escaped] = np.nan
        return out, status

    def trajectory(self, pose, action, duration_s: float, twist=None):
        """Free-run one trial for ``duration_s`` (no rest test) and record it after every rest-test
        interval; ``twist`` an initial tray-frame velocity ``(vx_mm_s, vy_mm_s, omega_rad_s)``.

        Returns ``(t, poses, z)`` as :meth:`transition_builder.sim.TraySimulator.trajectory` does
        (theta unwrapped; ``z`` is zero: a planar part never leaves the floor).
        """
        p = check_poses(pose)[0]
        if not valid_start(self.scene, p[None])[0]:
            raise ValueError(f"start pose {p.tolist()} is not inside the tray")
        dt = self.scene.settings.check_interval_s
        k = int(math.ceil(duration_s / dt - 1e-9))
        record = np.zeros((k + 1, 3))
        tw = np.zeros(3) if twist is None else np.asarray(twist, dtype=np.float64).reshape(3)
        code = K._free_run(p, tw, self._geom, self._verts, self._mu, self._params_for(action),
                           self._ramp_sin, self._ramp_cos, record)
        if code != st_codes.OK:
            raise RuntimeError(f"the free run ended with status {st_codes.STATUS_NAMES[code]}")
        return np.arange(k + 1) * dt, record, np.zeros(k + 1)
