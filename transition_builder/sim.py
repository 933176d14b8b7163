"""The PyBullet tray-tilt simulator: a batch of start poses and one action -> rest poses and status codes.

A tilt = gravity ``g (sin a, 0, -cos a)`` in a world whose +x axis is the action's downhill
direction (``a`` = tilt angle), stepped until the part is at rest (centroid speed below
``rest_speed_mm_s`` and yaw rate below ``rest_angular_speed_rad_s`` for ``dwell_s``; speeds are
mean speeds over each rest-test interval of ``substeps`` steps, so a contact that jitters
without moving the part counts as rest) or until ``max_time_s`` (``UNSETTLED``). The tray is then
levelled: the part stays where it came to rest, so the rest pose is read and mapped back to the
tray frame. With a tilt time (``Scene.tilt_time_s``) the tray starts level and rotates to its tilt
over that time, gravity following in steps of one rest-test interval, and the rest test starts once
the tilt is reached (docs/simulator.md, "The tilt's own motion"). A faulted trial is never returned
as a pose (NaN pose, status code from :mod:`transition_builder.status`). Sleeping is disabled and every joint is reset before a trial.

The design, in short (the measurements behind each choice, and the errors measured against
mechanics: ``docs/simulator.md``):

1. **Planar by construction**: the part is a fixed-base multibody chain (prismatic x, y, z and a
   revolute yaw) carrying the prism's convex parts; it cannot tip or ride over a wall (``TIPPED``
   only means "lifted off the floor"). Joint motors are disabled and damping is zero.
2. **Distributed Coulomb friction on one contact** (``SimSettings.contact``, default ``coulomb``):
   the prism floats above the floor and its weight rests on one small support sphere under the
   centroid. Before every friction update (every ``friction_substeps`` physics steps) the friction
   of uniform pressure over the footprint is integrated by quadrature at the twist predicted for
   the end of the step (:mod:`transition_builder._coulomb`): its component against the centroid's
   velocity and its torque become the sphere's lateral and spinning limits (Bullet's implicit
   contact, which also sticks), the rest is applied as an explicit force. Below a small speed the
   contact sticks. ``sphere`` keeps fixed limits (``mu``, ``mu`` x friction radius); ``legs:K`` puts
   the part on K point legs. A friction map gives every quadrature point (or leg, or the sphere) the
   coefficient of the tile under it.
3. **Downhill along world +x**: each action has its own world, rotated so that downhill is +x
   (Bullet's friction is anisotropic off the axes); poses are mapped in and out exactly.
4. **A centimetre world** with inset hulls: Bullet's fixed 0.001-unit collision margin is 0.01 mm.
5. **A 2 mm contact threshold, 100 solver iterations, 1/480 s steps and a rest test on mean
   velocities** every 1/60 s, so parts neither creep along walls nor jitter in corners; steps are
   1/240 s while the part is clear of every wall (``free_flight_step_factor``).
6. **No memory between trials**: the part is moved away and collision detection run before every
   trial, so an outcome does not depend on the trial before it.
"""
from __future__ import annotations

import math

import numpy as np

from transition_builder import status as st_codes
from transition_builder._bullet_world import BulletWorld
from transition_builder._tilt_contract import check_poses as _check_poses
from transition_builder._tilt_contract import ramp_fractions, valid_start
from transition_builder.friction import parse_friction
from transition_builder.scene import Scene
from transition_builder.sim_settings import SIMULATOR_VERSION

__all__ = ["TraySimulator", "SIMULATOR_VERSION", "valid_start", "ramp_fractions"]



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
        self._stale: set[int] = set()      # worlds to build again before their next use (fresh_start)
        st = scene.settings
        self._dt_check = st.check_interval_s
        self._dwell_checks = max(1, int(math.ceil(st.dwell_s / self._dt_check - 1e-9)))
        self._max_checks = int(math.ceil(st.max_time_s / self._dt_check - 1e-9))
        self._v_rest = st.rest_speed_mm_s / 1000.0
        self._w_rest = st.rest_angular_speed_rad_s
        half = 0.5 * math.hypot(scene.tray_x_mm, scene.tray_y_mm) / 1000.0
        self._r_out = half + scene.wall_thickness_mm / 1000.0     # centroid beyond this: escaped
        # tilt-time ramp: the slope of each rest-test interval from level to the tilt (empty: an
        # instant tilt, no ramp calls)
        self._ramp_slopes = math.radians(scene.tilt_deg) * ramp_fractions(scene.tilt_time_s, self._dt_check)
        self._ramp_checks = len(self._ramp_slopes) - 1 if len(self._ramp_slopes) else 0

    # ------------------------------------------------------------------ worlds
    def _world(self, action) -> BulletWorld:
        k = self.scene.action_index(action)
        w = self._worlds.get(k)
        if w is None:
            w = BulletWorld(self.scene, self.scene.downhill_angle(k))
            self._worlds[k] = w
        elif k in self._stale:
            w.rebuild()
        self._stale.discard(k)
        return w

    def prepare(self, actions=None):
        """Build the PyBullet worlds of ``actions`` (default: all) now rather than on first use,
        e.g. to keep their set-up out of a timing."""
        for a in (range(len(self.scene.actions)) if actions is None else actions):
            self._world(a)

    def fresh_start(self):
        """Make the next trial independent of every trial this simulator ran before.

        Some Bullet state survives the per-trial reset of :meth:`BulletWorld.set_pose` (which
        drops every contact): after certain runs of earlier trials a landing differed by up to
        1e-3 rad (measured on a uniform-friction scene, 2 of 126 builder tasks; up to 3e-4 mm on a
        friction map), and neither restoring a saved state nor re-applying the engine parameters
        removed it; resetting the physics server does. So every world is reset and built again
        (:meth:`BulletWorld.rebuild`, a few milliseconds), lazily: each world just before its next
        use, so a builder task, which tilts under one action, rebuilds one world and not eight (the
        worlds are separate physics servers; the results are the same as rebuilding all at once).
        Direct simulation and the builder call this at the start of every task, whose trials are
        fixed by the task list alone, so every result is the same for any number of workers and
        any executor.
        """
        self._stale.update(self._worlds)

    @property
    def friction_map(self) -> bool:
        """True when the scene's friction is a map (tile coefficients)."""
        return parse_friction(self.scene.friction).kind == "map"

    def close(self):
        """Disconnect every PyBullet world."""
        for w in self._worlds.values():
            w.close()
        self._worlds.clear()
        self._stale.clear()

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
    def _ramp(self, w: BulletWorld, i: int):
        """Set the tray's slope for rest-test interval ``i`` of a tilt-time ramp (:func:`ramp_fractions`
        of the tilt); from the first interval after the ramp on the slope stays the full tilt."""
        if i <= self._ramp_checks:
            w.set_slope(float(self._ramp_slopes[i]))

    def _run(self, w: BulletWorld, pose) -> tuple[tuple[float, float, float], int]:
        w.set_pose(pose)
        still = 0
        r_out2 = self._r_out ** 2
        lift = self.scene.settings.lift_tolerance_mm / 1000.0
        # rest test on the mean velocity over each check interval (the displacement since the last
        # check): a part resting on a sharp corner can jitter in yaw at the contact while its
        # pose does not change, and instantaneous velocities would never settle
        d_lin = self._v_rest * self._dt_check
        d_ang = self._w_rest * self._dt_check
        px, py, _, pyaw = w.state()[:4]
        ramp = self._ramp_checks
        for i in range(ramp + self._max_checks):
            if ramp:
                self._ramp(w, i)
            w.step()
            x, y, z, yaw, vx, vy, wz = w.state()
            if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw) and math.isfinite(vx)
                    and math.isfinite(vy) and math.isfinite(wz) and math.isfinite(z)):
                return None, st_codes.INVALID
            if x * x + y * y > r_out2 or z < -lift:
                return None, st_codes.ESCAPED
            dx, dy, dyaw = x - px, y - py, yaw - pyaw
            px, py, pyaw = x, y, yaw
            if i >= ramp and dx * dx + dy * dy < d_lin * d_lin and abs(dyaw) < d_ang:
                still += 1
                if still >= self._dwell_checks:
                    break
            else:
                still = 0
        else:
            return None, st_codes.UNSETTLED
        if w.lift_mm() > self.scene.settings.lift_tolerance_mm:
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
        for i in range(n):
            if not valid[i]:
                continue
            pose, code = self._run(w, p[i])
            if code == st_codes.OK:
                out[i] = pose
            status[i] = code
        # a landing must be a valid start of the next tilt; one outside the tray escaped
        landed = status == st_codes.OK
        escaped = landed & ~valid_start(self.scene, np.where(landed[:, None], out, 0.0))
        status[escaped] = st_codes.ESCAPED
        out[escaped] = np.nan
        return out, status

    def trajectory(self, pose, action, duration_s: float, twist=None):
        """Free-run one trial for ``duration_s`` (no rest test) and record it after every check interval.

        ``twist``: an initial tray-frame velocity ``(vx_mm_s, vy_mm_s, omega_rad_s)`` (default at rest).

        With a tilt time the tray rotates from level as in :meth:`tilt`.

        Returns ``(t, poses, z)``: times (s, from the start of the tilt), tray-frame poses (mm, rad;
        theta unwrapped, not reduced modulo 2 pi) and the height of the part above its resting
        height (mm). A lower-level view for mechanics tests.
        """
        p = _check_poses(pose)[0]
        if not valid_start(self.scene, p[None])[0]:
            raise ValueError(f"start pose {p.tolist()} is not inside the tray")
        w = self._world(action)
        w.set_pose(p, twist)
        k = int(math.ceil(duration_s / self._dt_check - 1e-9))
        t = np.arange(k + 1) * self._dt_check
        out = np.empty((k + 1, 3))
        z = np.empty(k + 1)
        x, y, zz, yaw = w.state()[:4]
        for i in range(k + 1):
            if i:
                if self._ramp_checks:
                    self._ramp(w, i - 1)
                w.step()
                x, y, zz, yaw = w.state()[:4]
            px, py, _ = w.to_tray(x, y, 0.0)
            out[i] = (px, py, yaw + w.phi)
            z[i] = w.lift_mm()
        return t, out, z
