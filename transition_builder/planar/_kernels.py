"""The planar engine's compiled kernels (private): a whole tilt, or a batch of them, in one call.

State ``(x, y, theta, vx, vy, omega)`` of the part's area centroid in the tray frame (mm, rad, mm/s,
rad/s), unit mass (every force here is per unit mass: gravity, floor friction and the walls all scale
with it). One physics step of ``dt``:

1. gravity along the action's downhill direction, ``g sin(a)``, is added to the velocity;
2. the contacts are gathered at the step's start: the floor (distributed Coulomb friction over the
   footprint's quadrature points, each reading the coefficient of its map tile, evaluated at the
   velocity at the step's start) and every outline vertex near one of the tray's four wall
   half-planes (the tray is convex, so vertices against walls are the only contacts possible);
3. one projected Gauss-Seidel solve at the velocity level (Erin Catto's sequential impulses,
   "Iterative dynamics with temporal coherence", GDC 2005) resolves them together: inelastic wall
   normals with speculative gaps, wall friction inside ``wall_mu`` times each normal impulse, and the
   floor: while the fastest point of the part moves faster than the stick speed, the kinetic
   friction wrench ``W`` scaled by ``lambda`` in ``[0, 1]`` (it may stop the part's motion along
   ``W`` but never reverse it); below it, static friction up to the static limits (the force
   ``mu_s N`` and the torque ``mu_s N rho``, rho the area-weighted mean radius), the stick rule of
   the PyBullet contact (:mod:`transition_builder._coulomb`);
4. the pose moves with the new velocity (semi-implicit Euler).

Every ``substeps`` steps the rest test of :class:`transition_builder.sim.TraySimulator` runs on the
displacement since the last test. Kernels take arrays and write into preallocated outputs; they own
no random numbers.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

#: indices into the kernels' parameter vector (filled by :mod:`transition_builder.planar.simulator`).
P_W, P_H, P_DX, P_DY, P_GSIN, P_GCOS, P_DT, P_SUB, P_DWELL, P_MAXCHK = 0, 1, 2, 3, 4, 5, 6, 7, 8, 9
P_DLIN, P_DANG, P_ROUT2, P_CX, P_CY, P_STICK, P_RATIO, P_WALLMU, P_K, P_RMAX = 10, 11, 12, 13, 14, 15, 16, 17, 18, 19
P_TILE, P_ITERS, P_WSUM, P_WRSUM, P_TOL, P_WARM, P_NPARAMS = 20, 21, 22, 23, 24, 25, 26

_OK, _ESCAPED, _UNSETTLED, _INVALID = 0, 2, 3, 4
#: wall contacts are gathered for vertices closer than this (mm) plus twice their travel in a step
_CONTACT_SLOP_MM = 1.0
#: share of a penetration pushed out per step (Baumgarte stabilisation)
_BAUMGARTE = 0.2
#: a part spinning so slowly that its fastest point's velocity turns by less than this (rad) slides
#: as in pure translation (no quadrature sum: every point moves alike)
_TRANSLATION_SHARE = 1e-9


@njit(cache=True)
def _point_mu(x, y, cs, sn, bx, by, mu_grid, inv_tile):
    """The floor's coefficient under the body point ``(bx, by)`` of a part at ``(x, y)``, rotation ``cs, sn``
    (tile ``(floor(x / tile), floor(y / tile))``, clamped to the map; ``inv_tile = 1 / tile``)."""
    nx = mu_grid.shape[0]
    ny = mu_grid.shape[1]
    if nx * ny == 1:
        return mu_grid[0, 0]
    px = x + cs * bx - sn * by
    py = y + sn * bx + cs * by
    ix = min(max(int(px * inv_tile), 0), nx - 1)      # int() truncates: negative positions clamp to 0 alike
    iy = min(max(int(py * inv_tile), 0), ny - 1)
    return mu_grid[ix, iy]


@njit(cache=True)
def _floor_wrench(s, geom, mu_grid, inv_tile, gn, r_max, out):
    """Kinetic floor friction per unit mass at the state ``s``: ``out = (fx, fy, tz)`` (mm/s^2, mm^2/s^2).

    Uniform pressure, quadrature over the footprint: ``-gN sum_i w_i mu_i u_i`` and its moment, ``u_i``
    the unit velocity of point ``i``. A pure translation on a uniform floor needs no sum (every point
    moves alike; the points' mean is the centroid, so the moment vanishes).
    """
    vx = s[3]
    vy = s[4]
    wz = s[5]
    uniform = mu_grid.shape[0] * mu_grid.shape[1] == 1
    sp = math.sqrt(vx * vx + vy * vy)
    if abs(wz) * r_max <= _TRANSLATION_SHARE * sp:
        # the spin changes no point's velocity direction by more than 1e-9 rad: a pure translation, every
        # point moving along u = v / |v|: force -gN (sum w_i mu_i) u, moment -gN (sum w_i mu_i r_i) x u
        if uniform:
            k = gn * mu_grid[0, 0] / sp
            out[0] = -k * vx
            out[1] = -k * vy
            out[2] = 0.0
            return
        ux = vx / sp
        uy = vy / sp
        cs = math.cos(s[2])
        sn = math.sin(s[2])
        msum = 0.0
        mx = 0.0
        my = 0.0
        for i in range(geom.shape[1]):
            bx = geom[0, i]
            by = geom[1, i]
            m = geom[2, i] * _point_mu(s[0], s[1], cs, sn, bx, by, mu_grid, inv_tile)
            msum += m
            mx += m * bx
            my += m * by
        rx = cs * mx - sn * my
        ry = sn * mx + cs * my
        out[0] = -gn * msum * ux
        out[1] = -gn * msum * uy
        out[2] = -gn * (rx * uy - ry * ux)
        return
    # in the body frame: point i moves at R^T v + omega x b_i, so no point is rotated; the sums are
    # turned back into the tray frame once
    cs = math.cos(s[2])
    sn = math.sin(s[2])
    bvx = cs * vx + sn * vy
    bvy = -sn * vx + cs * vy
    fx = 0.0
    fy = 0.0
    tz = 0.0
    for i in range(geom.shape[1]):
        bx = geom[0, i]
        by = geom[1, i]
        ux = bvx - wz * by
        uy = bvy + wz * bx
        sp = math.sqrt(ux * ux + uy * uy)
        if sp > 0.0:
            m = geom[2, i] / sp
            if not uniform:
                m *= _point_mu(s[0], s[1], cs, sn, bx, by, mu_grid, inv_tile)
            fx -= m * ux
            fy -= m * uy
            tz -= m * (bx * uy - by * ux)
    if uniform:
        m0 = gn * mu_grid[0, 0]
    else:
        m0 = gn
    out[0] = m0 * (cs * fx - sn * fy)
    out[1] = m0 * (sn * fx + cs * fy)
    out[2] = m0 * tz


@njit(cache=True)
def _static_limits(s, geom, mu_grid, inv_tile, ratio, p_lat, p_spin):
    """``(sum_i w_i mu_s,i, sum_i w_i mu_s,i r_i)``: the static force and torque limits per unit normal
    force (``p_lat = sum_i w_i``, ``p_spin = sum_i w_i r_i``: a uniform floor needs no sum)."""
    nx = mu_grid.shape[0]
    ny = mu_grid.shape[1]
    lat = 0.0
    spin = 0.0
    if nx * ny == 1:
        m = mu_grid[0, 0]
        return m * p_lat * ratio, m * p_spin * ratio
    else:
        cs = math.cos(s[2])
        sn = math.sin(s[2])
        for i in range(geom.shape[1]):
            m = geom[2, i] * _point_mu(s[0], s[1], cs, sn, geom[0, i], geom[1, i], mu_grid, inv_tile)
            lat += m
            spin += m * geom[3, i]
    return lat * ratio, spin * ratio


@njit(cache=True)
def _gather_walls(s, verts, p, dt, cn, cr, cgap, cslot):
    """Every outline vertex within reach of a wall: normals ``cn`` (into the tray), lever arms ``cr``
    (vertex minus centroid) and gaps ``cgap`` (mm, negative when penetrating). Returns the count."""
    cs = math.cos(s[2])
    sn = math.sin(s[2])
    reach = _CONTACT_SLOP_MM + 2.0 * dt * (math.sqrt(s[3] * s[3] + s[4] * s[4]) + abs(s[5]) * p[P_RMAX])
    W = p[P_W]
    H = p[P_H]
    nc = 0
    for j in range(verts.shape[0]):
        rx = cs * verts[j, 0] - sn * verts[j, 1]
        ry = sn * verts[j, 0] + cs * verts[j, 1]
        vx = s[0] + rx
        vy = s[1] + ry
        for w in range(4):
            if w == 0:
                gap, nx, ny = vx, 1.0, 0.0
            elif w == 1:
                gap, nx, ny = W - vx, -1.0, 0.0
            elif w == 2:
                gap, nx, ny = vy, 0.0, 1.0
            else:
                gap, nx, ny = H - vy, 0.0, -1.0
            if gap < reach:
                cn[nc, 0] = nx
                cn[nc, 1] = ny
                cr[nc, 0] = rx
                cr[nc, 1] = ry
                cgap[nc] = gap
                cslot[nc] = 4 * j + w
                nc += 1
    return nc


@njit(cache=True)
def _solve(s, nc, cn, cr, cgap, cslot, warm, lam, pre, wrench, mode, lim_lat, lim_spin, p, dt):
    """Projected Gauss-Seidel on the velocity ``s[3:6]``: wall normals and wall friction of the ``nc``
    contacts, and the floor (``mode`` 1: kinetic wrench ``wrench`` scaled in [0, 1]; ``mode`` 2:
    static friction up to ``lim_lat`` and ``lim_spin`` (impulses per unit mass); 0: no floor)."""
    k = p[P_K]
    inv_k = 1.0 / k
    wall_mu = p[P_WALLMU]
    iters = int(p[P_ITERS])
    tol = p[P_TOL]
    # warm start: every contact that was there in the last step starts from its last impulses
    for c in range(nc):
        q = cslot[c]
        lam[c, 0] = warm[q, 0]
        lam[c, 1] = warm[q, 1]
        if warm[q, 0] != 0.0 or warm[q, 1] != 0.0:
            nx = cn[c, 0]
            ny = cn[c, 1]
            rx = cr[c, 0]
            ry = cr[c, 1]
            ix = lam[c, 0] * nx - lam[c, 1] * ny
            iy = lam[c, 0] * ny + lam[c, 1] * nx
            s[3] += ix
            s[4] += iy
            s[5] += (rx * iy - ry * ix) / k
    lam_floor = 0.0
    acc_x = 0.0
    acc_y = 0.0
    acc_w = 0.0
    dpow = dt * (wrench[0] * wrench[0] + wrench[1] * wrench[1] + wrench[2] * wrench[2] / k)
    # per contact, once per step: the normal's and tangent's moment arms, effective masses and the
    # normal velocity aimed at (a gap may close in this step; a penetration opens at a share per step)
    for c in range(nc):
        nx = cn[c, 0]
        ny = cn[c, 1]
        rn = cr[c, 0] * ny - cr[c, 1] * nx
        rt = cr[c, 0] * nx + cr[c, 1] * ny
        gap = cgap[c]
        pre[c, 0] = rn
        pre[c, 1] = rt
        pre[c, 2] = 1.0 / (1.0 + rn * rn * inv_k)
        pre[c, 3] = 1.0 / (1.0 + rt * rt * inv_k)
        pre[c, 4] = -gap / dt if gap > 0.0 else -_BAUMGARTE * gap / dt
    for _ in range(iters):
        change = 0.0
        for c in range(nc):
            nx = cn[c, 0]
            ny = cn[c, 1]
            rn = pre[c, 0]
            vn = nx * s[3] + ny * s[4] + s[5] * rn
            d = (pre[c, 4] - vn) * pre[c, 2]
            new = max(lam[c, 0] + d, 0.0)
            d = new - lam[c, 0]
            lam[c, 0] = new
            s[3] += d * nx
            s[4] += d * ny
            s[5] += d * rn * inv_k
            change = max(change, abs(d))
            # wall friction along the tangent (-ny, nx), inside the cone of this normal impulse
            rt = pre[c, 1]
            vt = -ny * s[3] + nx * s[4] + s[5] * rt
            d = -vt * pre[c, 3]
            bound = wall_mu * lam[c, 0]
            new = min(max(lam[c, 1] + d, -bound), bound)
            d = new - lam[c, 1]
            lam[c, 1] = new
            s[3] -= d * ny
            s[4] += d * nx
            s[5] += d * rt * inv_k
            change = max(change, abs(d))
        if mode == 1 and dpow > 0.0:
            power = -(wrench[0] * s[3] + wrench[1] * s[4] + wrench[2] * s[5])
            new = min(max(lam_floor + power / dpow, 0.0), 1.0)
            d = new - lam_floor
            lam_floor = new
            s[3] += d * wrench[0] * dt
            s[4] += d * wrench[1] * dt
            s[5] += d * wrench[2] * dt / k
            change = max(change, abs(d) * math.sqrt(dpow / dt) * dt)
        elif mode == 2:
            nx_ = acc_x - s[3]
            ny_ = acc_y - s[4]
            mag = math.sqrt(nx_ * nx_ + ny_ * ny_)
            if mag > lim_lat:
                nx_ *= lim_lat / mag
                ny_ *= lim_lat / mag
            s[3] += nx_ - acc_x
            s[4] += ny_ - acc_y
            change = max(change, abs(nx_ - acc_x) + abs(ny_ - acc_y))
            acc_x = nx_
            acc_y = ny_
            nw = min(max(acc_w - s[5] * k, -lim_spin), lim_spin)
            s[5] += (nw - acc_w) / k
            change = max(change, abs(nw - acc_w) / max(p[P_RMAX], 1e-12))
            acc_w = nw
        if change < tol:
            break
    for q in range(warm.shape[0]):
        warm[q, 0] = 0.0
        warm[q, 1] = 0.0
    if p[P_WARM] > 0.0:
        for c in range(nc):
            warm[cslot[c], 0] = lam[c, 0]
            warm[cslot[c], 1] = lam[c, 1]


@njit(cache=True)
def _step(s, geom, verts, mu_grid, p, gsin, gcos, dt, cn, cr, cgap, cslot, warm, lam, pre, wrench):
    """One physics step of ``dt`` (module docstring), in place on ``s``."""
    inv_tile = 1.0 / p[P_TILE]
    vx0 = s[3]
    vy0 = s[4]
    w0 = s[5]
    fastest = math.sqrt(vx0 * vx0 + vy0 * vy0) + abs(w0) * p[P_RMAX]
    # floor: at the velocity of the step's start
    mode = 0
    lim_lat = 0.0
    lim_spin = 0.0
    if gcos > 0.0:
        if fastest < p[P_STICK]:
            mode = 2
            lat, spin = _static_limits(s, geom, mu_grid, inv_tile, p[P_RATIO], p[P_WSUM], p[P_WRSUM])
            lim_lat = lat * gcos * dt
            lim_spin = spin * gcos * dt
        else:
            mode = 1
            _floor_wrench(s, geom, mu_grid, inv_tile, gcos, p[P_RMAX], wrench)
    nc = _gather_walls(s, verts, p, dt, cn, cr, cgap, cslot)
    s[3] += gsin * p[P_DX] * dt
    s[4] += gsin * p[P_DY] * dt
    _solve(s, nc, cn, cr, cgap, cslot, warm, lam, pre, wrench, mode, lim_lat, lim_spin, p, dt)
    s[0] += s[3] * dt
    s[1] += s[4] * dt
    s[2] += s[5] * dt


@njit(cache=True)
def _tilt_one(s, geom, verts, mu_grid, p, ramp_sin, ramp_cos, cn, cr, cgap, cslot, warm, lam, pre, wrench, record):
    """One tilt from the state ``s`` (changed in place). With ``record`` of ``k + 1`` rows: free-run ``k``
    rest-test intervals and record the pose after each (row 0 the start); returns OK. Else run to
    rest and return the status code."""
    dt = p[P_DT]
    sub = int(p[P_SUB])
    n_ramp = ramp_sin.shape[0]
    ramp = n_ramp - 1 if n_ramp > 0 else 0
    free_run = record.shape[0] > 0
    for q in range(warm.shape[0]):
        warm[q, 0] = 0.0
        warm[q, 1] = 0.0
    if free_run:
        total = record.shape[0] - 1
        record[0, 0] = s[0]
        record[0, 1] = s[1]
        record[0, 2] = s[2]
    else:
        total = ramp + int(p[P_MAXCHK])
    dwell = int(p[P_DWELL])
    d_lin2 = p[P_DLIN] * p[P_DLIN]
    d_ang = p[P_DANG]
    r_out2 = p[P_ROUT2]
    px = s[0]
    py = s[1]
    pt = s[2]
    still = 0
    for i in range(total):
        if i < n_ramp:
            gsin = ramp_sin[i]
            gcos = ramp_cos[i]
        else:
            gsin = p[P_GSIN]
            gcos = p[P_GCOS]
        for _ in range(sub):
            _step(s, geom, verts, mu_grid, p, gsin, gcos, dt, cn, cr, cgap, cslot, warm, lam, pre, wrench)
        for q in range(6):
            if not math.isfinite(s[q]):
                return _INVALID
        ex = s[0] - p[P_CX]
        ey = s[1] - p[P_CY]
        if ex * ex + ey * ey > r_out2:
            return _ESCAPED
        if free_run:
            record[i + 1, 0] = s[0]
            record[i + 1, 1] = s[1]
            record[i + 1, 2] = s[2]
            continue
        dx = s[0] - px
        dy = s[1] - py
        da = s[2] - pt
        px = s[0]
        py = s[1]
        pt = s[2]
        if i >= ramp and dx * dx + dy * dy < d_lin2 and abs(da) < d_ang:
            still += 1
            if still >= dwell:
                return _OK
        else:
            still = 0
    return _OK if free_run else _UNSETTLED


@njit(cache=True)
def _scratch(m):
    """The work arrays of one trial of a part of ``m`` vertices (at most ``4 m`` wall contacts): contact
    normals, lever arms, gaps, impulses, slots, per-contact constants, warm starts, the floor's wrench and
    the state."""
    return (np.empty((4 * m, 2)), np.empty((4 * m, 2)), np.empty(4 * m), np.empty((4 * m, 2)),
            np.empty(4 * m, dtype=np.int64), np.empty((4 * m, 5)), np.zeros((4 * m, 2)), np.zeros(3), np.empty(6))


@njit(cache=True)
def _tilt_batch(starts, valid, geom, verts, mu_grid, p, ramp_sin, ramp_cos, out, status):
    """Tilt every valid start pose (rows of ``starts``, at rest) to rest: poses into ``out`` (theta
    unwrapped; NaN where faulted), codes into ``status``. Trials share nothing but the inputs."""
    cn, cr, cgap, lam, cslot, pre, warm, wrench, s = _scratch(verts.shape[0])
    no_record = np.empty((0, 3))
    for t in range(starts.shape[0]):
        out[t, 0] = np.nan
        out[t, 1] = np.nan
        out[t, 2] = np.nan
        if not valid[t]:
            status[t] = _INVALID
            continue
        s[0] = starts[t, 0]
        s[1] = starts[t, 1]
        s[2] = starts[t, 2]
        s[3] = 0.0
        s[4] = 0.0
        s[5] = 0.0
        code = _tilt_one(s, geom, verts, mu_grid, p, ramp_sin, ramp_cos, cn, cr, cgap, cslot, warm, lam, pre, wrench, no_record)
        status[t] = code
        if code == _OK:
            out[t, 0] = s[0]
            out[t, 1] = s[1]
            out[t, 2] = s[2]


@njit(cache=True)
def _free_run(start, twist, geom, verts, mu_grid, p, ramp_sin, ramp_cos, record):
    """Free-run one trial from ``start`` with the tray-frame ``twist`` and record it (``record`` rows:
    the pose after every rest-test interval, row 0 the start). Returns the status code."""
    cn, cr, cgap, lam, cslot, pre, warm, wrench, s = _scratch(verts.shape[0])
    for q in range(3):
        s[q] = start[q]
        s[q + 3] = twist[q]
    return _tilt_one(s, geom, verts, mu_grid, p, ramp_sin, ramp_cos, cn, cr, cgap, cslot, warm, lam, pre, wrench, record)
