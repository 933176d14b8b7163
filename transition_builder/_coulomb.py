"""Distributed Coulomb friction of a flat part on the floor (private helper of the simulator).

Under uniform pressure, Coulomb's law on every area element ``dA`` of a part sliding with twist
``(v, omega)`` gives the friction force ``-mu N (1/A) int u(r) dA`` and the torque about the
centroid ``-mu N (1/A) int r x u(r) dA``, with ``u(r)`` the unit velocity of the point ``r``
(Goyal, Ruina and Papadopoulos, "Planar sliding with dry friction", Wear 143, 1991: the set of these
wrenches is the limit surface). Here the integrals are quadratures over equal-area points of the
footprint (:func:`footprint_points`); on a friction map every point carries the coefficient of the
tile under it.

The kernel :func:`_contact_update` is called before every friction update by
:class:`transition_builder._bullet_world.BulletWorld` (contact ``coulomb``): its results set the
lateral and spinning friction limits of the single implicit contact under the centroid and the
explicit force that one contact cannot give (the part of the friction force perpendicular to the
centroid's velocity). :func:`integrate_free_sliding` is the judges' ground truth and keeps its own
quadrature loop on purpose: the judge shares no code with the contact it judges. See
docs/simulator.md.
"""
from __future__ import annotations

import functools
import math

import numpy as np
import shapely
from numba import njit

__all__ = ["footprint_points", "integrate_free_sliding"]


def footprint_points(vertices, n_target: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """Equal-area quadrature points of a polygon: the centres of the square cells of a grid (side
    ``sqrt(area / n_target)``) whose centre lies inside, shifted so that their mean is exactly the
    origin (the part's area centroid). Returns ``(points (n, 2) in the vertices' units, weights
    (n,) summing to 1)``; ``n`` is close to ``n_target``. Cached per outline.
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    p, w = _points_of_outline(v.tobytes(), len(v), int(n_target))
    return p.copy(), w.copy()


@functools.lru_cache(maxsize=64)
def _points_of_outline(vertex_bytes: bytes, n_vertices: int, n_target: int):
    v = np.frombuffer(vertex_bytes, dtype=np.float64).reshape(n_vertices, 2)
    poly = shapely.Polygon(v)
    h = math.sqrt(poly.area / n_target)
    lo, hi = v.min(axis=0), v.max(axis=0)
    xs = np.arange(lo[0] + h / 2, hi[0], h)
    ys = np.arange(lo[1] + h / 2, hi[1], h)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel()])
    pts = pts[shapely.intersects_xy(poly, pts[:, 0], pts[:, 1])]
    pts = pts - pts.mean(axis=0)
    w = np.full(len(pts), 1.0 / len(pts))
    return np.ascontiguousarray(pts), w


#: resolution of the friction limits and of the explicit force per unit normal force.
_QUANTUM = 1e9


@njit(cache=True)
def _contact_update(x, y, yaw, vx, vy, wz, mem, geom, mu_grid, params, out):
    """Everything the coupled contact needs before one physics step, in one call.

    ``(x, y, yaw, vx, vy, wz)``: the part's state in the world (downhill) frame, world units.
    ``mem``: ``[vx, vy, wz, seen]`` of the previous step, updated here; from the second step of a
    trial on, the friction is evaluated at the twist predicted for the end of the step,
    ``2 v - v_prev`` (Bullet's contacts solve for the end-of-step velocity). ``geom``: rows
    ``bx, by, weight, radius`` of the quadrature points (body frame, world units). ``mu_grid``: the
    floor's coefficients on square tiles; ``params``: ``[tile (mm), a, b, c, d, cx, cy]`` (the world
    -> tray map, mm), ``stick_speed``, ``r_max`` (world units), ``static_ratio``. Below
    ``stick_speed`` of its fastest point the contact sticks: its limits are those of the static
    coefficients, the kinetic ones times ``static_ratio`` (``MU_S / MU_K``; exactly 1 for one
    coefficient, which leaves every result bit for bit as before). Writes into ``out``: ``[lateral
    limit, spinning limit (world length), explicit fx, explicit fy]``, all per unit normal force.
    """
    if mem[3] > 0.0:
        px0 = mem[0]
        py0 = mem[1]
        pw0 = mem[2]
        mem[0] = vx
        mem[1] = vy
        mem[2] = wz
        vx = 2.0 * vx - px0
        vy = 2.0 * vy - py0
        wz = 2.0 * wz - pw0
    else:
        mem[0] = vx
        mem[1] = vy
        mem[2] = wz
        mem[3] = 1.0
    tile = params[0]
    a = params[1]
    b = params[2]
    c = params[3]
    d = params[4]
    cx = params[5]
    cy = params[6]
    stick_speed = params[7]
    r_max = params[8]
    n = geom.shape[1]
    cs = math.cos(yaw)
    sn = math.sin(yaw)
    nx = mu_grid.shape[0]
    ny = mu_grid.shape[1]
    uniform = nx * ny == 1
    mu0 = mu_grid[0, 0]
    speed = math.sqrt(vx * vx + vy * vy)
    stick = speed + abs(wz) * r_max < stick_speed
    fx = 0.0
    fy = 0.0
    tz = 0.0
    lat_box = 0.0
    spin_box = 0.0
    for i in range(n):
        bx = geom[0, i]
        by = geom[1, i]
        px = cs * bx - sn * by
        py = sn * bx + cs * by
        if uniform:
            m = mu0
        else:
            wx = x + px
            wy = y + py
            tx = a * wx + b * wy + cx
            ty = c * wx + d * wy + cy
            ix = min(max(int(tx // tile), 0), nx - 1)
            iy = min(max(int(ty // tile), 0), ny - 1)
            m = mu_grid[ix, iy]
        m *= geom[2, i]
        if stick:
            lat_box += m
            spin_box += m * geom[3, i]
            continue
        ux = vx - wz * py
        uy = vy + wz * px
        s = math.sqrt(ux * ux + uy * uy)
        if s > 0.0:
            k = m / s
            ux *= k
            uy *= k
            fx -= ux
            fy -= uy
            tz -= px * uy - py * ux
    if stick:
        # static friction: the wrench that holds the footprint is bounded by the static limits
        ratio = params[9]
        if ratio != 1.0:
            lat_box *= ratio
            spin_box *= ratio
        out[0] = lat_box
        out[1] = spin_box
        out[2] = 0.0
        out[3] = 0.0
        return
    # the implicit contact opposes the centroid's velocity: it takes the component of the force
    # along -v (never one along +v); the rest is applied explicitly
    along = 0.0
    if speed > 0.0:
        along = -(fx * vx + fy * vy) / speed
    if along > 0.0:
        out[0] = along
        out[2] = fx + along * vx / speed
        out[3] = fy + along * vy / speed
    else:
        out[0] = 0.0
        out[2] = fx
        out[3] = fy
    out[1] = abs(tz)
    # round-off of a pure translation (limits equal to the last bits, a perpendicular force of
    # 1e-17) is not passed on: the caller skips engine calls that would change nothing
    out[0] = math.floor(out[0] * _QUANTUM + 0.5) / _QUANTUM
    out[1] = math.floor(out[1] * _QUANTUM + 0.5) / _QUANTUM
    if abs(out[2]) < 1.0 / _QUANTUM and abs(out[3]) < 1.0 / _QUANTUM:
        out[2] = 0.0
        out[3] = 0.0


@njit(cache=True)
def _integrate(state, bx, by, weights, mu, g, inv_m, inv_i, dt, t_max, stop_speed, r_max, out_t):
    """Classical Runge-Kutta (RK4) integration of a flat part sliding on a level floor under
    distributed Coulomb friction, until the fastest point moves slower than ``stop_speed``
    (then the part is at rest for good) or ``t_max``. ``state`` = (x, y, theta, vx, vy, omega) is
    updated in place; ``out_t[0]`` receives the stopping time (``t_max`` if still moving)."""
    k = np.empty((4, 6))
    s = np.empty(6)
    t = 0.0
    while t < t_max:
        if math.sqrt(state[3] ** 2 + state[4] ** 2) + abs(state[5]) * r_max < stop_speed:
            break
        for j in range(4):
            if j == 0:
                for q in range(6):
                    s[q] = state[q]
            else:
                h = dt if j == 3 else 0.5 * dt
                for q in range(6):
                    s[q] = state[q] + h * k[j - 1, q]
            c = math.cos(s[2])
            sn = math.sin(s[2])
            fx = 0.0
            fy = 0.0
            tz = 0.0
            for i in range(bx.shape[0]):
                px = c * bx[i] - sn * by[i]
                py = sn * bx[i] + c * by[i]
                ux = s[3] - s[5] * py
                uy = s[4] + s[5] * px
                sp = math.sqrt(ux * ux + uy * uy)
                if sp > 0.0:
                    w = weights[i] * mu[i] / sp
                    fx -= w * ux
                    fy -= w * uy
                    tz -= w * (px * uy - py * ux)
            k[j, 0] = s[3]
            k[j, 1] = s[4]
            k[j, 2] = s[5]
            k[j, 3] = g * fx          # per unit mass: mu g times the mean unit direction
            k[j, 4] = g * fy
            k[j, 5] = g * tz * inv_i / inv_m
        for q in range(6):
            state[q] += dt / 6.0 * (k[0, q] + 2.0 * k[1, q] + 2.0 * k[2, q] + k[3, q])
        t += dt
    out_t[0] = t


def integrate_free_sliding(vertices, inertia_per_mass: float, pose, twist, mu: float = 0.3, g: float = 9.81,
                           n_points: int = 1000, dt: float = 1e-5, t_max: float = 5.0,
                           stop_speed: float = 1e-5):
    """Ground truth for free sliding: integrate a flat part's motion on a level floor under
    distributed Coulomb friction (uniform pressure, quadrature over about ``n_points`` equal-area
    points, RK4 at step ``dt``) until it stops.

    Parameters
    ----------
    vertices : array_like (k, 2)
        Outline in the body frame (m), area centroid at the origin.
    inertia_per_mass : float
        Polar moment of inertia about the centroid divided by the mass (m^2).
    pose : (float, float, float)
        Start ``(x, y, theta)`` (m, m, rad).
    twist : (float, float, float)
        Start ``(vx, vy, omega)`` (m/s, m/s, rad/s).
    mu, g : float
        Friction coefficient and gravity (m/s^2).
    n_points, dt, t_max, stop_speed
        Quadrature size, step (s), time limit (s), and the speed of the fastest point (m/s)
        below which the part is taken to have stopped.

    Returns
    -------
    final : ndarray (6,)
        ``(x, y, theta, vx, vy, omega)`` when it stopped (or at ``t_max``).
    t_stop : float
        Stopping time (s).

    References
    ----------
    Goyal, Ruina and Papadopoulos, "Planar sliding with dry friction", Wear 143 (1991).
    """
    pts, w = footprint_points(vertices, n_points)
    bx = np.ascontiguousarray(pts[:, 0])
    by = np.ascontiguousarray(pts[:, 1])
    state = np.array(list(pose) + list(twist), dtype=np.float64)
    out_t = np.zeros(1)
    r_max = float(np.hypot(bx, by).max())
    _integrate(state, bx, by, w, np.full(len(w), float(mu)), float(g), 1.0, 1.0 / float(inertia_per_mass),
               float(dt), float(t_max), float(stop_speed), r_max, out_t)
    return state, float(out_t[0])
