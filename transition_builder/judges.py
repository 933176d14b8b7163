"""Mechanics judges of the floor contact: free sliding on a level floor, engine against Coulomb's law.

A flat part given a twist on a level floor slides and spins to a stop under its floor friction.
Distributed Coulomb friction under uniform pressure fixes that motion completely, so a direct
numerical integration of it (:func:`transition_builder._coulomb.integrate_free_sliding`: about
1,000 quadrature points, RK4 at 10 microseconds) is the ground truth for any contact model of the
simulator. Closed forms check the integration itself: pure sliding stops at ``v0 / (mu g)``; a
uniform disk spinning in place stops at ``3 R omega0 / (4 mu g)``; a disk sliding and spinning
stops sliding and spinning at the same instant, ``v / (R omega)`` tending to about 0.653 (Farkas,
Bartels, Unger and Wolf, PRL 90, 2003; Weidman and Malhotra, PRL 95, 2005).

The engine runs with the tray almost level (tilt 1e-6 degrees) and the part started from the
given pose and twist, at a time step ``refine`` times finer than the scene's default (same
rest-test interval), so that the engine's own integrator error (about ``v0 dt / 2``) stays below
the judges' tolerance. Used by ``tests/transition_builder/test_sim_mechanics.py`` and ``python -m benchmarks contact``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from transition_builder._coulomb import integrate_free_sliding

__all__ = ["FreeSlide", "engine_free_slide", "reference_free_slide", "disk_shape_spec", "rotate_start",
           "isotropy_error", "judges_table", "JUDGE_TARGETS", "TABLE_SLIDES", "engine_incline", "kinetic_distance_mm",
           "onset_slope_deg", "pair_judges", "pair_judge_slopes", "PAIR_JUDGE_TARGETS", "InclineRun",
           "simultaneous_stop", "corner_wedge", "wedge_drift", "NEW_JUDGE_TARGETS", "STOP_RATIOS", "engine_judges"]

#: tilt of the "level" tray of the judges (degrees; a scene's tilt must be positive).
LEVEL_TILT_DEG = 1e-6


def disk_shape_spec(radius_mm: float = 20.0, sides: int = 96) -> str:
    """A regular polygon standing in for a uniform disk, as a ``polygon:`` shape spec."""
    ang = 2 * math.pi * (np.arange(sides) + 0.5) / sides
    return "polygon:" + ";".join(f"{radius_mm * math.cos(a):.6f},{radius_mm * math.sin(a):.6f}" for a in ang)


@dataclass(frozen=True)
class FreeSlide:
    """Outcome of one free slide.

    Attributes
    ----------
    final : ndarray (3,)
        Final pose ``(x_mm, y_mm, theta_rad)`` (theta unwrapped).
    t_slide, t_spin : float
        When the centroid's speed and the yaw rate fell below 0.1% of their largest values (s).
    ratio_late : float
        ``v / (R omega)`` (``R`` = largest distance from the centroid to the outline) when the
        fastest point's speed has fallen to 5% of its start; NaN if the part never spun.
    """

    final: np.ndarray
    t_slide: float
    t_spin: float
    ratio_late: float


def _summarise(t, pose, vel, r_max) -> FreeSlide:
    speed = np.hypot(vel[:, 0], vel[:, 1])
    spin = np.abs(vel[:, 2])

    def stop_time(x):
        if x.max() <= 0.0:
            return 0.0
        moving = np.nonzero(x > 1e-3 * x.max())[0]
        return float(t[moving[-1] + 1]) if moving[-1] + 1 < len(t) else float(t[-1])

    fastest = speed + spin * r_max
    late = np.nonzero(fastest <= 0.05 * fastest[0])[0]
    ratio = float("nan")
    if len(late) and spin[late[0]] > 0:
        ratio = float(speed[late[0]] / (r_max * spin[late[0]]))
    return FreeSlide(np.asarray(pose[-1], dtype=float), stop_time(speed), stop_time(spin), ratio)


def engine_free_slide(shape_spec: str, pose, twist, contact: str = "coulomb", refine: int = 16,
                      mu: float = 0.3, duration_s: float = 1.0, **settings) -> FreeSlide:
    """The simulator's free slide: start at tray-frame ``pose`` (mm, rad) with ``twist``
    (mm/s, mm/s, rad/s) on a level floor of coefficient ``mu``, run ``duration_s`` at ``1/refine``
    of the default time step (same rest-test interval).

    Returns
    -------
    FreeSlide
        Final pose, stopping times and late ``v / (R omega)``; velocities are the mean over each
        rest-test interval.
    """
    from transition_builder.scene import scene_from_options
    from transition_builder.sim_settings import SimSettings
    from transition_builder.simulators import make_simulator
    base = SimSettings(contact=contact, **settings)
    # the trajectory is recorded every ``substeps`` steps: as few as the contact allows, for a fine record
    settings = dict(settings, time_step_s=base.time_step_s / refine, substeps=base.friction_substeps)
    sc = scene_from_options(shape_spec, mu, tilt_deg=LEVEL_TILT_DEG, contact=contact, **settings)
    sim = make_simulator(sc)
    try:
        t, poses, _ = sim.trajectory(pose, "E", duration_s, twist=twist)
    finally:
        sim.close()
    vel = np.diff(poses, axis=0) / np.diff(t)[:, None]
    return _summarise(t[1:], poses[1:], vel, sc.shape.radius_mm)


def reference_free_slide(shape_spec: str, pose, twist, mu: float = 0.3, dt: float = 1e-5,
                         n_points: int = 1000, stop_speed: float = 1e-4) -> FreeSlide:
    """The ground truth of :func:`engine_free_slide`: a direct integration of distributed Coulomb
    friction (uniform pressure) from the same start.

    Returns
    -------
    FreeSlide
        Final pose and stopping times (``ratio_late`` from the integration sampled every 1 ms).
        The integration stops once the fastest point moves slower than ``stop_speed`` (m/s; RK4
        chatters about a stop by about ``mu g dt``, far below it).
    """
    from transition_builder.shapes import parse_shape
    shape = parse_shape(shape_spec)
    verts = np.asarray(shape.vertices, float) / 1000.0
    k = shape.inertia_kg_m2 / shape.mass_kg
    state = np.array([pose[0] / 1000.0, pose[1] / 1000.0, pose[2], twist[0] / 1000.0, twist[1] / 1000.0,
                      twist[2]], float)
    # record the motion on a 1 ms grid (each piece integrated from the last)
    rec_t, rec_pose, rec_vel = [0.0], [state[:3].copy()], [state[3:].copy()]
    t = 0.0
    step = 1e-3
    while True:
        state, dt_used = integrate_free_sliding(verts, k, state[:3], state[3:], mu=mu, dt=dt, t_max=step,
                                                n_points=n_points, stop_speed=stop_speed)
        t += dt_used
        rec_t.append(t)
        rec_pose.append(state[:3].copy())
        rec_vel.append(state[3:].copy())
        if dt_used < step - 0.5 * dt or t > 10.0:
            break
    pose_a = np.array(rec_pose)
    pose_a[:, :2] *= 1000.0
    vel = np.array(rec_vel)
    vel[:, :2] *= 1000.0
    return _summarise(np.array(rec_t), pose_a, vel, shape.radius_mm)


def rotate_start(pose, twist, angle: float, centre=(100.0, 100.0)):
    """The same free slide turned by ``angle`` (rad) about the tray point ``centre``: pose and
    twist rotated (the yaw rate unchanged)."""
    c, s = math.cos(angle), math.sin(angle)
    x, y = pose[0] - centre[0], pose[1] - centre[1]
    p = (centre[0] + c * x - s * y, centre[1] + s * x + c * y, pose[2] + angle)
    tw = (c * twist[0] - s * twist[1], s * twist[0] + c * twist[1], twist[2])
    return p, tw


def isotropy_error(shape_spec: str, pose, twist, angle: float = math.pi / 4, contact: str = "coulomb",
                   refine: int = 16, **kw) -> tuple[float, float]:
    """How far a contact model is from isotropic: slide from ``(pose, twist)`` and from the same
    start turned by ``angle``, turn the second outcome back, and compare. Returns the relative
    differences ``(|d1 - d2| / |d1|, |a1 - a2| / max(|a1|, 1 degree))`` of the displacements ``d``
    and rotations ``a``."""
    a = engine_free_slide(shape_spec, pose, twist, contact=contact, refine=refine, **kw)
    p2, tw2 = rotate_start(pose, twist, angle)
    b = engine_free_slide(shape_spec, p2, tw2, contact=contact, refine=refine, **kw)
    c, s = math.cos(-angle), math.sin(-angle)
    d1 = a.final[:2] - np.asarray(pose[:2])
    d2r = b.final[:2] - np.asarray(p2[:2])
    d2 = np.array([c * d2r[0] - s * d2r[1], s * d2r[0] + c * d2r[1]])
    r1 = a.final[2] - pose[2]
    r2 = b.final[2] - p2[2]
    return (float(np.hypot(*(d1 - d2)) / np.hypot(*d1)),
            float(abs(r1 - r2) / max(abs(r1), math.radians(1.0))))


#: the free slides of the judges' table: (shape, start pose (mm, rad), twist (mm/s, rad/s)).
TABLE_SLIDES = (("disk", (100.0, 100.0, 0.0), (200.0, 100.0, 8.0)),
                ("disk", (100.0, 100.0, 0.0), (-150.0, 250.0, -12.0)),
                ("allen-key", (100.0, 100.0, 0.3), (300.0, 200.0, 6.0)),
                ("allen-key", (100.0, 100.0, 1.0), (-200.0, 250.0, -5.0)),
                ("allen-key", (100.0, 100.0, 4.0), (50.0, -300.0, 10.0)))


def judges_table(contacts=("coulomb", "sphere", "legs:4", "legs:25"), mu: float = 0.3, refine: int = 16,
                 **settings) -> dict:
    """Every judge for every contact model: ``{contact: {judge: value}}``; ``settings`` (simulator
    settings such as ``contact_pairs``) apply to every engine run.

    Judges (targets of the default contact in brackets): ``slide_mm`` / ``slide_deg``, the largest
    distance and angle between the engine's and the integration's final poses over
    :data:`TABLE_SLIDES` [0.2 mm, 0.5 degrees]; ``disk_stop_gap``, ``|t_slide - t_spin| / t_slide``
    of the first disk slide [2%]; ``disk_ratio_error``, relative error of its late ``v / (R omega)``
    [5%]; ``pure_slide_error`` and ``pure_spin_error``, relative errors of the stopping times
    ``v0 / (mu g)`` and ``I omega0 / (mu m g rho)`` [2%]; ``isotropy_slide`` / ``isotropy_turn``, the
    relative change of the key's displacement and rotation when its start is turned by 45 degrees [1%].
    """
    from transition_builder._bullet_world import friction_radius_mm
    from transition_builder.shapes import parse_shape
    disk = disk_shape_spec()
    spec = {"disk": disk, "allen-key": "allen-key"}
    refs = [reference_free_slide(spec[s], p, tw, mu=mu) for s, p, tw in TABLE_SLIDES]
    dshape = parse_shape(disk)
    w0, v0 = 10.0, 300.0
    spin_law = dshape.inertia_kg_m2 / dshape.mass_kg * w0 / (mu * 9.81 * friction_radius_mm(dshape) / 1000.0)
    slide_law = v0 / 1000.0 / (mu * 9.81)
    out = {}
    for contact in contacts:
        kw = {"contact": contact, "mu": mu, "refine": refine, **settings}
        runs = [engine_free_slide(spec[s], p, tw, **kw) for s, p, tw in TABLE_SLIDES]
        d_mm = [float(np.hypot(*(e.final[:2] - r.final[:2]))) for e, r in zip(runs, refs)]
        d_deg = [abs(math.degrees(e.final[2] - r.final[2])) for e, r in zip(runs, refs)]
        disk_run = runs[0]
        slide = engine_free_slide(disk, (100.0, 100.0, 0.0), (0.6 * v0, 0.8 * v0, 0.0), **kw)
        spin = engine_free_slide(disk, (100.0, 100.0, 0.0), (0.0, 0.0, w0), **kw)
        iso = isotropy_error("allen-key", *TABLE_SLIDES[2][1:], **kw)
        out[contact] = {
            "slide_mm": max(d_mm), "slide_deg": max(d_deg),
            "disk_stop_gap": abs(disk_run.t_slide - disk_run.t_spin) / disk_run.t_slide,
            "disk_ratio_error": (abs(disk_run.ratio_late / refs[0].ratio_late - 1.0)
                                 if math.isfinite(disk_run.ratio_late) else float("inf")),
            "pure_slide_error": abs(slide.t_slide / slide_law - 1.0),
            "pure_spin_error": abs(spin.t_spin / spin_law - 1.0),
            "isotropy_slide": iso[0], "isotropy_turn": iso[1]}
    return out


#: the default contact's targets of :func:`judges_table` (a judge passes at or below its target).
JUDGE_TARGETS = {"slide_mm": 0.2, "slide_deg": 0.5, "disk_stop_gap": 0.02, "disk_ratio_error": 0.05,
                 "pure_slide_error": 0.02, "pure_spin_error": 0.02, "isotropy_slide": 0.01, "isotropy_turn": 0.01}


# ---------------------------------------------------------------------------------------------------
# Static and kinetic friction on an incline (issue 40): closed forms of a block on a slope.
#
# A flat part on a floor tilted by ``a`` with static coefficient ``mu_s`` and kinetic ``mu_k``:
# released at rest it stays when ``tan a <= mu_s``; sliding downhill it accelerates at
# ``g (sin a - mu_k cos a)`` (uniform pressure, pure translation: the torque of the distributed
# friction about the centroid vanishes, so it does not turn); released at rest with ``tan a > mu_s``
# it starts at once and follows the kinetic law; on a tray whose tilt grows slowly from level it
# starts when the slope passes ``atan(mu_s)``.

#: the friction pair of the static/kinetic judges (atan: 26.57 and 16.70 degrees).
PAIR_JUDGE_FRICTION = "0.5/0.3"
#: the ramped tray of the onset judge: to ``atan(mu_s)`` + 13.4 degrees in 4 s (40 degrees for 0.5/0.3;
#: 10 degrees/s, 0.17 degree per rest test).
PAIR_JUDGE_RAMP_S = 4.0


def pair_judge_slopes(mu_s: float, mu_k: float) -> tuple[float, float, float]:
    """The judges' slopes (degrees) for a pair: midway between the two friction angles (the hold and
    the kinetic slide; 21.6 for 0.5/0.3), 3.4 degrees above the static angle (the break-away; 30.0),
    and the ramp's end, 13.4 above it (40.0)."""
    a_s, a_k = math.degrees(math.atan(mu_s)), math.degrees(math.atan(mu_k))
    return 0.5 * (a_s + a_k), a_s + 3.435, a_s + 13.435
#: the incline judges' tray (mm; long enough for half a second of sliding) and start (mm, rad).
PAIR_JUDGE_TRAY_MM = (700.0, 300.0)
PAIR_JUDGE_START = (60.0, 150.0, 0.4)


@dataclass(frozen=True)
class InclineRun:
    """One run on the incline: times (s), downhill distance (mm), rotation (rad, unwrapped) and the
    slope applied during each recorded interval (degrees)."""

    t: np.ndarray
    distance: np.ndarray
    rotation: np.ndarray
    slope_deg: np.ndarray


def engine_incline(shape_spec: str, friction, tilt_deg: float, duration_s: float, v0_mm_s: float = 0.0,
                   tilt_time_s: float = 0.0, refine: int = 1, start=PAIR_JUDGE_START,
                   tray_mm=PAIR_JUDGE_TRAY_MM, engine: str = "pybullet") -> InclineRun:
    """The simulator on an incline: the part starts at ``start`` (tray frame, action ``E``: downhill
    is +x) at rest or sliding downhill at ``v0_mm_s``, on a floor of ``friction`` (a number or a
    pair) tilted by ``tilt_deg`` (reached over ``tilt_time_s``), run for ``duration_s`` at
    ``1/refine`` of the default step (same rest-test interval), in ``engine``."""
    from transition_builder.scene import scene_from_options
    from transition_builder.sim_settings import SimSettings
    from transition_builder.simulators import make_simulator
    sc = scene_from_options(shape_spec, friction, tilt_deg=tilt_deg, tray_mm=tray_mm, tilt_time_s=tilt_time_s,
                            actions="E", engine=engine, **SimSettings().finer_step(refine))
    sim = make_simulator(sc)
    try:
        t, poses, _ = sim.trajectory(start, "E", duration_s, twist=(v0_mm_s, 0.0, 0.0))
    finally:
        sim.close()
    dt = sc.settings.check_interval_s
    slope = np.full(len(t), float(tilt_deg))
    if tilt_time_s:
        # record k ends interval k - 1, whose slope was the tilt at that interval's midpoint
        slope[1:] = tilt_deg * np.minimum((np.arange(len(t) - 1) + 0.5) * dt / tilt_time_s, 1.0)
        slope[0] = 0.0
    return InclineRun(t, poses[:, 0] - poses[0, 0], poses[:, 2] - poses[0, 2], slope)


def kinetic_distance_mm(t, tilt_deg: float, mu_k: float, v0_mm_s: float = 0.0, g: float = 9.81) -> np.ndarray:
    """Closed form: ``v0 t + g (sin a - mu_k cos a) t^2 / 2`` (mm) of a block sliding downhill."""
    a = math.radians(tilt_deg)
    return v0_mm_s * np.asarray(t) + 0.5 * g * 1000.0 * (math.sin(a) - mu_k * math.cos(a)) * np.asarray(t) ** 2


def _law_error(run: InclineRun, tilt_deg: float, mu_k: float, v0: float, t_from: float) -> float:
    """Largest relative error of the downhill distance against the kinetic law from ``t_from`` on."""
    law = kinetic_distance_mm(run.t, tilt_deg, mu_k, v0)
    k = run.t >= t_from
    return float(np.max(np.abs(run.distance[k] / law[k] - 1.0)))


def onset_slope_deg(run: InclineRun, threshold_mm: float = 0.05) -> float:
    """The slope (degrees) during the interval in which the part first moved more than
    ``threshold_mm`` downhill; NaN if it never did."""
    k = np.nonzero(run.distance > threshold_mm)[0]
    return float(run.slope_deg[k[0]]) if len(k) else float("nan")


def pair_judges(friction: str = PAIR_JUDGE_FRICTION, shapes=("allen-key", "rectangle:40x20"),
                refine: int = 4, engine: str = "pybullet") -> dict:
    """The static/kinetic judges for every shape: ``{shape: {judge: value}}``.

    Judges (targets in :data:`PAIR_JUDGE_TARGETS`; slopes from :func:`pair_judge_slopes`):
    ``hold_mm`` / ``hold_deg``, the largest displacement and rotation in 2 s of a part released at
    rest on a slope midway between the friction angles; ``slide_error``, the largest relative error of the distance
    against ``v0 t + g (sin a - mu_k cos a) t^2 / 2`` from 0.1 s to 0.4 s, released downhill at 100
    mm/s on the same slope; ``break_error``, the same from rest on a slope above the static angle
    (3.4 degrees above it); ``onset_deg``, how far from ``atan(mu_s)`` the part starts to slide on a
    tray tilting from level to 13.4 degrees past it over 4 s.

    ``refine`` (default 4: a quarter of the default step) keeps the engine's first-order integration
    error of a uniformly accelerated slide, ``dt / t`` (1.8% at 0.1 s at the default step), below
    the 2% target, as :func:`judges_table` runs at 1/16 of the step. The window ends at 0.4 s
    because Bullet caps every joint's speed at 100 world units per second (1 m/s in this centimetre
    world, ``btMultiBody``'s default maximum coordinate velocity), which a part reaches after
    0.42 s at 30 degrees on 0.5/0.3: docs/simulator.md.
    """
    from transition_builder.friction import parse_friction
    spec = parse_friction(friction)
    mu_k, mu_s = spec.mu, spec.static_mu
    a_hold, a_break, a_ramp = pair_judge_slopes(mu_s, mu_k)
    out = {}
    for shape in shapes:
        kw = {"refine": refine, "engine": engine}
        hold = engine_incline(shape, friction, a_hold, 2.0, **kw)
        slide = engine_incline(shape, friction, a_hold, 0.4, v0_mm_s=100.0, **kw)
        brk = engine_incline(shape, friction, a_break, 0.4, **kw)
        ramp = engine_incline(shape, friction, a_ramp, PAIR_JUDGE_RAMP_S * 0.9, tilt_time_s=PAIR_JUDGE_RAMP_S, **kw)
        out[shape] = {
            "hold_mm": float(np.max(np.abs(hold.distance))),
            "hold_deg": float(np.degrees(np.max(np.abs(hold.rotation)))),
            "slide_error": _law_error(slide, a_hold, mu_k, 100.0, 0.1),
            "break_error": _law_error(brk, a_break, mu_k, 0.0, 0.1),
            "onset_deg": abs(onset_slope_deg(ramp) - math.degrees(math.atan(mu_s)))}
    return out


#: targets of :func:`pair_judges` (a judge passes at or below its target).
PAIR_JUDGE_TARGETS = {"hold_mm": 0.1, "hold_deg": 0.1, "slide_error": 0.02, "break_error": 0.02, "onset_deg": 0.5}


# ---------------------------------------------------------------------------------------------------
# Two judges added with the planar engine (docs/simulator.md, "The planar engine"): both engines face them.

#: the simultaneous-stop judge's starts: a disk at the tray's centre with ``v0 / (R omega0)`` of 1/4, 1 and 4
#: (R = 20 mm; v0 = 200 mm/s along 30 degrees).
STOP_RATIOS = (0.25, 1.0, 4.0)


def simultaneous_stop(engine: str = "pybullet", contact: str = "coulomb", refine: int = 16,
                      mu: float = 0.3, ratios=STOP_RATIOS) -> float:
    """The largest ``|t_slide - t_spin| / max(t_slide, t_spin)`` of a uniform disk sliding and spinning on
    a level floor, over starts with ``v0 / (R omega0)`` in ``ratios``.

    Under uniform Coulomb pressure a disk stops sliding and spinning at the same instant, whatever its
    start (Farkas, Bartels, Unger and Wolf, "Frictional coupling between sliding and spinning motion",
    PRL 90, 2003). A contact whose force and torque limits are independent (the ``sphere`` contact, a
    "box" limit surface) stops one before the other. Target: 2% (:data:`NEW_JUDGE_TARGETS`).
    """
    disk = disk_shape_spec()
    r = 20.0
    worst = 0.0
    for k in ratios:
        v0 = 200.0
        twist = (v0 * math.cos(math.pi / 6), v0 * math.sin(math.pi / 6), v0 / (k * r))
        run = engine_free_slide(disk, (100.0, 100.0, 0.0), twist, contact=contact, refine=refine, mu=mu,
                                duration_s=1.0, engine=engine)
        worst = max(worst, abs(run.t_slide - run.t_spin) / max(run.t_slide, run.t_spin))
    return float(worst)


#: the corner judge: the part, the tilt (into the south-west corner) and how long the rest is watched (s).
WEDGE_SHAPE = "triangle:1"
WEDGE_WATCH_S = 2.0


def wedge_drift(sim, starts, action: str = "SW", watch_s: float = WEDGE_WATCH_S) -> tuple[float, float, int]:
    """Tilt ``sim`` toward ``action`` from every start, then keep the tray tilted for ``watch_s`` from each rest
    pose: ``(largest drift (mm), largest turn (degrees), trials that did not come to rest)``, the drift and
    turn over the watch's second half (the rest test stops a part moving slower than 1 mm/s; the first
    half lets that motion end).

    ``sim`` is any simulator (``tilt``, ``trajectory``): a part wedged in a corner by gravity is held by the
    walls and by static friction, so once at rest it must not creep (no stale contact, no solver drift).
    """
    from transition_builder.status import OK
    rest, status = sim.tilt(starts, action)
    drift, turn = 0.0, 0.0
    for pose in rest[status == OK]:
        t, poses, _ = sim.trajectory(pose, action, watch_s)
        late = poses[t >= watch_s / 2]            # the first half settles what the rest test left moving
        drift = max(drift, float(np.max(np.hypot(late[:, 0] - late[0, 0], late[:, 1] - late[0, 1]))))
        turn = max(turn, float(np.degrees(np.max(np.abs(late[:, 2] - late[0, 2])))))
    return drift, turn, int(np.sum(status != OK))


def corner_wedge(engine: str = "pybullet", shape: str = WEDGE_SHAPE, n_starts: int = 6, seed: int = 11) -> dict:
    """The corner judge on ``engine``: ``{"drift_mm", "turn_deg", "not_at_rest"}`` of ``shape`` tilted into
    the south-west corner from ``n_starts`` uniform starts (seed ``seed``), each watched for
    :data:`WEDGE_WATCH_S` after it came to rest. Targets in :data:`NEW_JUDGE_TARGETS`."""
    from transition_builder.sampling import sample_start_poses
    from transition_builder.scene import scene_from_options
    from transition_builder.simulators import make_simulator
    sc = scene_from_options(shape, engine=engine)
    starts = sample_start_poses(sc.shape, sc.tray_x_mm, sc.tray_y_mm, n_starts, np.random.default_rng(seed))
    sim = make_simulator(sc)
    try:
        drift, turn, bad = wedge_drift(sim, starts)
    finally:
        sim.close()
    return {"drift_mm": drift, "turn_deg": turn, "not_at_rest": bad}


def engine_judges(engine: str = "pybullet") -> dict:
    """Every free-sliding judge of the ``coulomb`` contact (:func:`judges_table`) and the two judges of
    this section, on ``engine``: ``{judge: value}`` (targets: :data:`JUDGE_TARGETS`, :data:`NEW_JUDGE_TARGETS`)."""
    table = dict(judges_table(contacts=("coulomb",), engine=engine)["coulomb"])
    table["simultaneous_stop"] = simultaneous_stop(engine)
    table.update(corner_wedge(engine))
    return table


#: targets of the two new judges (a judge passes at or below its target).
NEW_JUDGE_TARGETS = {"simultaneous_stop": 0.02, "drift_mm": 0.01, "turn_deg": 0.01, "not_at_rest": 0}
