"""The PyBullet tray-tilt simulator: a batch of start poses and one action -> rest poses and status codes.

A tilt = gravity ``g (sin a, 0, -cos a)`` in a world whose +x axis is the action's downhill
direction (``a`` = tilt angle), stepped until the part is at rest (centroid speed below
``rest_speed_mm_s`` and yaw rate below ``rest_angular_speed_rad_s`` for ``dwell_s``; speeds are
mean speeds over each rest-test interval of ``substeps`` steps, so a contact that jitters
without moving the part counts as rest) or until ``max_time_s`` (``UNSETTLED``). The tray is then
levelled: the part stays where it came to rest, so the rest pose is read and mapped back to the
tray frame. A faulted trial is never returned as a pose (NaN pose, status code from
:mod:`transition_builder.status`). Sleeping is disabled and every joint is reset before a trial.

How the mechanics are made right
--------------------------------
Measured with a naive set-up first (a free body, or a joint chain on a box floor, world-fixed
tray, gravity rotated toward the action), as in docs/simulator.md: a 40 x 40 x 5 mm plate with
mu = 0.3 on a 30 degree tilt slid 9-17% too far with 100-230 degrees of spurious rotation in a
naive x/y/z/yaw joint chain (Bullet's box-box manifold put all the weight on one corner, whose
friction then spun the part), and free bodies tip and jump walls. Six decisions fix it:

1. **Planar by construction.** The part is a fixed-base multibody chain: prismatic x, prismatic
   y, prismatic z, revolute yaw (the part's mass and exact z inertia about its centroid), with the
   prism's convex parts as fixed child links. It cannot roll or pitch, so it cannot tip or ride
   over a wall (``TIPPED`` then only means "lifted off the floor"). Default joint motors are
   disabled (``force=0``: a velocity motor on the z slide would carry weight and remove friction)
   and all damping is zero. The intermediate links weigh 1e-4 of the part.
2. **One well-defined floor contact.** The prism floats ``floor_clearance_mm`` above the floor,
   farther than the contact threshold, so it only ever touches the walls; the weight rests on one
   small sphere under the centroid (a sphere-box contact is a single exact point with a vertical
   normal). Its lateral friction gives ``mu N`` opposite the centroid's velocity; its spinning
   friction, set to the part's friction radius ``(1/A) int |r| dA``, gives the friction torque of
   uniform pressure for spinning in place. Bullet combines spinning friction as
   ``spin_A * lateral_B + spin_B * lateral_A`` (setting the floor's spinning friction too froze
   every rotation), and lateral friction as the product: the floor has lateral friction 1 and the
   support sphere carries ``mu`` (and ``mu`` x friction radius). A friction map (``map:LEVEL:SEED``)
   sets the sphere's coefficient to the tile under it before every physics step; separate tile
   bodies, each with its own friction, made the small sphere catch on tile seams (Bullet's
   speculative contact with the next tile's edge braked a sliding block by up to 57 mm in
   0.35 s). On a map a sliding block follows x'' = g (sin a - mu(x) cos a) within 1.2%.
3. **Downhill along world +x.** Each action has its own world in which the tray is rotated about
   its centre so that the downhill direction is +x (Bullet's friction is otherwise anisotropic
   for off-axis sliding, docs/simulator.md). Poses are mapped in and out exactly.
4. **A centimetre world.** PyBullet gives every convex hull a fixed collision margin of 0.001
   world units; in a metre world that is 1 mm (a part rested 0.97 mm off the wall and its outline
   was inflated by 1 mm). The world is built at 100 units per metre, where the margin is 0.01 mm,
   and the convex parts are inset by it: rest poses touch the wall within 0.001 mm.
5. **A tight contact threshold and a robust rest test.** With Bullet's contacts kept up to 8 mm
   apart, stale wall contacts made parts creep along walls at about 1 mm/s (3% of allen-key tilts
   at 10 solver iterations never settled) and sharp triangle corners jitter (4% of second tilts of
   ``triangle:1``); at 2 mm and with the rest test on mean velocities both are gone for the key,
   even at 10 iterations. A triangle wedged between two walls still crept (about 1 mm/s, never
   settling) in 7 of 16 four-tilt test sequences at 30 iterations, 3 at 50, none at 100: 100 are
   used (Bullet stops iterating once the residual is small, so they cost little in free slides).
6. **No memory between trials.** Before every trial the part is moved 1 m away and collision
   detection is run, which drops cached contacts and their warm-start impulses: a trial's outcome
   does not depend on the trial before it (bit-identical in any batch order and across processes).

Measured (``tests/test_sim_mechanics.py``, ``tests/test_sim_faults.py``; pybullet 3.2.7, 1/240 s):

- free slide, 40 x 40 mm block, mu = 0.3, each of the 8 directions x yaws 0, 30, 45 deg: the
  acceleration fitted to distance vs time over 0.3 s is within 0.03% of g (sin a - mu cos a)
  (the same in all 24 cases), sideways drift < 0.01 mm over 107 mm, no rotation; mu = 0.7 >
  tan 30 deg: no motion (< 1e-3 mm);
- a slender 80 x 10 mm rectangle (mu = 0.1) tilted into a wall from 8 yaws rests flush within 0.03
  deg, touching the wall. At mu = 0.3 a part that meets a wall nearly end-on can rest on a corner:
  the gravity torque toward flush is then smaller than the floor-friction torque - true Coulomb
  behaviour, not an engine artefact;
- rotating pose and action by 90 degrees: rest poses agree within 0.51 mm / 0.69 deg (worst of 400
  allen-key tilts), median below 0.001 mm (each direction has its own rotated world, so round-off
  differs and a few near-critical trials amplify it);
- faults: 0 in 20,000 random allen-key tilts from uniform start poses; 0 in 14,400 tilts of
  8-tilt random sequences of the 15 paper-style triangles, two rectangles and the key;
- speed (``python -m benchmarks sim``, shared 2-core machine at load 2.6-3.6): 310-330 allen-key
  tilts/s per core (CPU time), about 105 physics steps per tilt; the naive free body measured
  side by side: 410-460 tilts/s with 0.7-2% faults;
- against a 1/480 s reference, 93% of random allen-key tilts rest within 1 mm and 1 degree of the
  reference pose (median 0.05 mm); the rest reach a different resting configuration from a
  near-critical start (sensitivity, not drift). Contact thresholds 2, 4 and 8 mm agree equally.

Known limitation: with a single contact the friction force and torque are limited independently
(a "box" limit surface), which over-resists rotation about a far point (a part pivoting on a
wall corner) compared with distributed Coulomb friction. ``SimSettings(support_points=K)`` with
K > 1 replaces the sphere by K legs (independent prismatic-z links under K equal-area cells, each
carrying its cell's weight), i.e. distributed point-contact Coulomb friction; it passes the same
slide tests but is 2-3x slower (about 140 tilts/s with K = 4). On 400 and 1,000 random allen-key tilts
the two models rest within 1 mm / 1 deg of each other for 56-59% (the key ends flush against a
wall after 25% vs 32% of tilts): where a part comes to rest after pivoting is sensitive to the
friction model, and the paper's Simscape contact model is a third, different choice.
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
SIMULATOR_VERSION = "planar-chain-2"


def valid_start(scene: Scene, poses) -> np.ndarray:
    """True for every pose that is finite and whose outline lies inside the tray (collision-free).

    An outline may poke ``settings.escape_tolerance_mm`` into a wall: rest poses sit in contact
    (a few hundredths of a millimetre of penetration) and must be valid starts of the next tilt.
    """
    p = np.asarray(poses, dtype=np.float64)
    fin = np.all(np.isfinite(p), axis=1)
    ok = np.zeros(len(p), dtype=bool)
    if fin.any():
        v = scene.shape.placed(p[fin])
        tol = scene.settings.escape_tolerance_mm
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
        # rest test on the mean velocity over each check interval (the displacement since the last
        # check): a part resting on a sharp corner can jitter in yaw at the contact while its
        # pose does not change, and instantaneous velocities would never settle
        d_lin = self._v_rest * self._dt_check
        d_ang = self._w_rest * self._dt_check
        px, py, _, pyaw = w.state()[:4]
        for _ in range(self._max_checks):
            w.step()
            x, y, z, yaw, vx, vy, wz = w.state()
            if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw) and math.isfinite(vx)
                    and math.isfinite(vy) and math.isfinite(wz) and math.isfinite(z)):
                return None, st_codes.INVALID
            if x * x + y * y > r_out2 or z < -lift:
                return None, st_codes.ESCAPED
            dx, dy, dyaw = x - px, y - py, yaw - pyaw
            px, py, pyaw = x, y, yaw
            if dx * dx + dy * dy < d_lin * d_lin and abs(dyaw) < d_ang:
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
            z[i] = w.lift_mm()
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
