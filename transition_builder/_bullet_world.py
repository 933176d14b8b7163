"""One PyBullet world for one tilt direction (private helper of :mod:`transition_builder.sim`).

The world is built in the *downhill frame* of its action: the tray is rotated about its centre so
that the action's downhill direction is the world +x axis, and gravity is
``g (sin a, 0, -cos a)``. See :mod:`transition_builder.sim` for why.

The part is a planar joint chain on a fixed base: prismatic x, prismatic y, prismatic z, revolute
yaw (the part's mass and z inertia), then fixed child links: one per convex part of the prism
(it floats ``floor_clearance_mm`` above the floor, farther than the contact threshold, so it only
ever touches walls) and one support sphere under the centroid (the only floor contact; it carries
the part's weight, its lateral and its spinning friction). ``SimSettings.part_links`` chooses
other layouts of the same part: the prism as one compound link, or the part as the multibody's free
base with no slide or hinge links (docs/builder.md, "A lighter multibody").
"""
from __future__ import annotations

import functools
import math
import os
import tempfile

import numpy as np
import shapely

from transition_builder._quiet import quiet_stderr

with quiet_stderr():    # PyBullet prints its build banner on the C-level stderr at import
    import pybullet as pb

from transition_builder._coulomb import _contact_update, footprint_points
from transition_builder.friction import friction_map, parse_friction
from transition_builder.sim_settings import parse_contact

G = 9.81
#: PyBullet's collision margin of a convex hull made from vertices, in world units.
BULLET_HULL_MARGIN_UNITS = 0.001
_EPS_MASS_FRACTION = 1e-4      # mass of each massless-in-spirit link, relative to the part
#: ``part_links="floating"``: roll and pitch inertia of the free base, relative to its yaw inertia
#: (large enough that wall contacts above the centroid tilt the part by far less than a degree: at
#: 1e6 a key thrown into a wall at 0.5 m/s rolled 1.2 degrees, at 1e8 under 0.1)
_ROLL_INERTIA_FACTOR = 1e8
_FLOOR_T_MM = 10.0              # floor slab thickness (mm)
J_X, J_Y, J_Z, J_YAW = 0, 1, 2, 3
_JOINTS = (J_X, J_Y, J_Z, J_YAW)


def _in_outline(vertices, pts) -> np.ndarray:
    """True for every point of ``pts`` (n, 2) in the closed polygon ``vertices`` (its outline counts
    as inside: grid rows can lie exactly on an edge)."""
    return shapely.intersects_xy(shapely.Polygon(vertices), pts[:, 0], pts[:, 1])


def friction_radius_mm(shape, n: int = 400) -> float:
    """Area-weighted mean distance from the centroid, ``(1/A) int |r| dA`` (mm).

    A part spinning in place about its centroid on a floor of coefficient ``mu`` (uniform
    pressure) feels the friction torque ``mu * N * friction_radius``. Midpoint rule on an
    ``n x n`` grid over the bounding box (computed once per outline: half a world's build time).
    """
    v = np.asarray(shape.vertices, dtype=np.float64)
    return _friction_radius_of_outline(v.tobytes(), len(v), n)


@functools.lru_cache(maxsize=256)
def _friction_radius_of_outline(vertex_bytes: bytes, n_vertices: int, n: int) -> float:
    v = np.frombuffer(vertex_bytes, dtype=np.float64).reshape(n_vertices, 2)
    lo, hi = v.min(axis=0), v.max(axis=0)
    xs = lo[0] + (np.arange(n) + 0.5) * (hi[0] - lo[0]) / n
    ys = lo[1] + (np.arange(n) + 0.5) * (hi[1] - lo[1]) / n
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel()])
    inside = _in_outline(v, pts)
    r = np.hypot(pts[inside, 0], pts[inside, 1])
    return float(r.mean())


def support_cells(shape, k: int, n: int = 160, iters: int = 40):
    """Split the part into ``k`` cells of nearly equal area (Lloyd's k-means on a grid of points
    inside the polygon; deterministic). Returns cell centroids (k, 2) in mm and area weights (k,)
    summing to 1; the weighted centroid is the part's centroid (the origin) by construction.

    Computed once per outline and ``k`` (a world is built again before every task, and the
    k-means took most of a 4-leg build's time); the arrays returned are copies.
    """
    v = np.ascontiguousarray(shape.vertices, dtype=np.float64)
    c, w = _support_cells_of_outline(v.tobytes(), len(v), int(k), int(n), int(iters))
    return c.copy(), w.copy()


@functools.lru_cache(maxsize=64)
def _support_cells_of_outline(vertex_bytes: bytes, n_vertices: int, k: int, n: int, iters: int):
    v = np.frombuffer(vertex_bytes, dtype=np.float64).reshape(n_vertices, 2)
    lo, hi = v.min(axis=0), v.max(axis=0)
    h = max(hi - lo) / n
    xs = np.arange(lo[0] + h / 2, hi[0], h)
    ys = np.arange(lo[1] + h / 2, hi[1], h)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel()])
    pts = pts[_in_outline(v, pts)]
    # farthest-point initialisation from the centroid
    c = [pts[np.argmax(np.hypot(pts[:, 0], pts[:, 1]))]]
    for _ in range(1, k):
        d = np.min([np.hypot(*(pts - q).T) for q in c], axis=0)
        c.append(pts[np.argmax(d)])
    c = np.array(c)
    for _ in range(iters):
        lab = np.argmin(((pts[:, None, :] - c[None]) ** 2).sum(-1), axis=1)
        c = np.array([pts[lab == i].mean(axis=0) if np.any(lab == i) else c[i] for i in range(k)])
    lab = np.argmin(((pts[:, None, :] - c[None]) ** 2).sum(-1), axis=1)
    w = np.bincount(lab, minlength=k).astype(float)
    w /= w.sum()
    c = c - (w[:, None] * c).sum(axis=0)        # exact centre of mass at the centroid
    return c, w


def inset_convex(poly, d: float) -> np.ndarray:
    """Move every edge of a CCW convex polygon inward by ``d`` (mitred corners).

    Bullet inflates a convex hull by its collision margin, so the inset hull plus the margin is
    the true outline (with corners rounded by ``d``). A part too thin to inset is returned as is.
    """
    v = np.asarray(poly, float)
    m = len(v)
    e = np.roll(v, -1, axis=0) - v
    nrm = np.column_stack([e[:, 1], -e[:, 0]]) / np.hypot(e[:, 0], e[:, 1])[:, None]   # outward
    off = (nrm * v).sum(axis=1) - d                 # edge i: nrm_i . x = off_i
    out = np.empty_like(v)
    for i in range(m):                              # vertex i = edges i-1 and i
        a = np.array([nrm[i - 1], nrm[i]])
        out[i] = np.linalg.solve(a, [off[i - 1], off[i]])
    # valid iff still convex, CCW, and every inset vertex is inside the original by >= d
    e2 = np.roll(out, -1, axis=0) - out
    cross = e[:, 0] * e2[:, 1] - e[:, 1] * e2[:, 0]
    same_dir = (e * e2).sum(axis=1) > 0
    if not (np.all(same_dir) and np.all(cross > -1e-12)):
        return v
    return out


def _hull_obj(vertices) -> str:
    """Wavefront OBJ text of a prism given as its bottom ring then its top ring of vertices."""
    n = len(vertices) // 2
    lines = [f"v {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in vertices]
    lines.append("f " + " ".join(str(n - i) for i in range(n)))
    lines.append("f " + " ".join(str(n + 1 + i) for i in range(n)))
    lines += [f"f {i + 1} {(i + 1) % n + 1} {n + (i + 1) % n + 1} {n + i + 1}" for i in range(n)]
    return "\n".join(lines) + "\n"


def _compound_of_hulls(hulls, cid: int) -> int:
    """One compound collision shape of convex hulls (each a list of vertices, world units).

    ``pybullet.createCollisionShapeArray`` takes meshes only as files, so each hull is written to
    an OBJ file in a private temporary directory, removed once Bullet has read it (Bullet builds the
    convex hull of each file's vertices, with the same margin as a hull made from vertices)."""
    with tempfile.TemporaryDirectory(prefix="kruskal-hull-") as tmp:
        files = []
        for k, v in enumerate(hulls):
            path = os.path.join(tmp, f"hull{k}.obj")
            with open(path, "w") as fh:
                fh.write(_hull_obj(v))
            files.append(path)
        return pb.createCollisionShapeArray([pb.GEOM_MESH] * len(files), fileNames=files,
                                            meshScales=[[1.0, 1.0, 1.0]] * len(files), physicsClientId=cid)


def _check_hull_margin(body: int, link: int, cid: int):
    """Raise if the collision margin PyBullet gave the hull of ``link`` is not
    ``BULLET_HULL_MARGIN_UNITS`` (the hulls are inset by that margin, so another would move every
    wall contact)."""
    margin = pb.getDynamicsInfo(body, link, physicsClientId=cid)[11]
    if abs(margin - BULLET_HULL_MARGIN_UNITS) > 1e-12:
        raise RuntimeError(f"PyBullet's convex-hull margin is {margin} world units, "
                           f"expected {BULLET_HULL_MARGIN_UNITS}")


def _rot(phi):
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s], [s, c]])


class BulletWorld:
    """A DIRECT-mode PyBullet world holding the tray (in the downhill frame of ``phi``) and the part."""

    def __init__(self, scene, phi: float):
        self.scene = scene
        self.phi = float(phi)
        st = scene.settings
        self.R = _rot(-self.phi)              # tray frame -> world (downhill) frame
        self.centre = np.array([scene.tray_x_mm, scene.tray_y_mm]) / 2.0
        self.mm = st.world_units_per_m / 1000.0     # world units per millimetre
        self.inv_scale = 1.0 / st.world_units_per_m  # metres per world unit
        self.cid = cid = pb.connect(pb.DIRECT)
        try:
            self._build(scene, st, cid)
        except Exception:
            pb.disconnect(cid)
            raise

    # ------------------------------------------------------------------ construction
    def _world_xy(self, p_mm):
        """Tray-frame point(s) (mm) -> world xy (m)."""
        return ((np.asarray(p_mm, float) - self.centre) @ self.R.T) * self.mm

    def _quat(self, yaw):
        return pb.getQuaternionFromEuler([0.0, 0.0, yaw])

    def _build(self, scene, st, cid):
        """Reset the physics server and build everything (the same PyBullet calls in the same
        order every time: results depend on it)."""
        self._after = None       # joint states read after the last physics step (coulomb contact)
        self._configure_engine(scene, st, cid)
        mu = self._build_tray(scene, cid)
        leg_xy = self._build_part(scene, st, cid)
        self._set_supports(scene.shape, mu, leg_xy)

    def _configure_engine(self, scene, st, cid):
        """Time step, solver, contact threshold and the tilted gravity of this world."""
        a = math.radians(scene.tilt_deg)
        pb.resetSimulation(physicsClientId=cid)
        # the coulomb contact updates its friction once per call of ``friction_substeps`` steps (on a
        # map as well); the sphere or legs on a friction map get the tile's coefficient before every
        # step; otherwise one call runs ``substeps`` steps
        self.substeps = st.substeps
        self.contact = parse_contact(st.contact)
        if self.contact.kind == "coulomb":
            n_sub = st.friction_substeps
        else:
            n_sub = 1 if parse_friction(scene.friction).kind == "map" else st.substeps
        self.normal_force = scene.shape.mass_kg * G * st.world_units_per_m * math.cos(a)
        pb.setPhysicsEngineParameter(
            fixedTimeStep=st.time_step_s * n_sub, numSubSteps=n_sub,
            numSolverIterations=st.solver_iterations, deterministicOverlappingPairs=1,
            solverResidualThreshold=st.solver_residual_threshold,
            contactBreakingThreshold=st.contact_threshold_mm * self.mm, physicsClientId=cid)
        g = G * st.world_units_per_m
        pb.setGravity(g * math.sin(a), 0.0, -g * math.cos(a), physicsClientId=cid)

    def set_slope(self, a_rad: float):
        """Tilt this world's tray to ``a_rad`` (radians, about the axis normal to its downhill
        direction): gravity ``g (sin a, 0, -cos a)`` and the normal force of the ``coulomb`` contact
        follow. The tilt-time ramp of :class:`transition_builder.sim.TraySimulator` calls this; an
        instant tilt never does (the world keeps the scene's tilt set at build)."""
        st = self.scene.settings
        g = G * st.world_units_per_m
        pb.setGravity(g * math.sin(a_rad), 0.0, -g * math.cos(a_rad), physicsClientId=self.cid)
        self.normal_force = self.scene.shape.mass_kg * G * st.world_units_per_m * math.cos(a_rad)

    def _build_tray(self, scene, cid) -> np.ndarray:
        """The floor slab and the four walls, in the downhill frame; returns the friction grid."""
        yaw_tray = -self.phi
        q_tray = self._quat(yaw_tray)
        W, H = scene.tray_x_mm, scene.tray_y_mm
        T, WH = scene.wall_thickness_mm, scene.wall_height_mm

        # the floor: one slab (no seams) of lateral friction 1. The floor coefficient is carried by
        # the part's support contact(s), and Bullet multiplies the two. A friction map is applied
        # by updating the support's coefficient to the map value under it before every step
        # (separate tile bodies made the support sphere catch on the tile seams: Bullet's
        # speculative contacts with the next tile's edge braked a 10 x 10 mm block by up to 57 mm
        # over 0.35 s on map:high:2).
        mu, tile = friction_map(scene.friction, W, H)
        self.mu_grid = mu
        self.tile_mm = tile
        self.has_map = mu.size > 1
        cs = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[(W / 2 + T) * self.mm, (H / 2 + T) * self.mm,
                                                               _FLOOR_T_MM * self.mm / 2], physicsClientId=cid)
        wx, wy = self._world_xy((W / 2, H / 2))
        self.floor = pb.createMultiBody(0, cs, basePosition=[wx, wy, -_FLOOR_T_MM * self.mm / 2],
                                        baseOrientation=q_tray, physicsClientId=cid)
        pb.changeDynamics(self.floor, -1, lateralFriction=1.0, spinningFriction=0.0, rollingFriction=0.0,
                          restitution=0.0, physicsClientId=cid)

        # walls (east, west, north, south), full outer length so corners are closed
        wall_mu = scene.effective_wall_mu
        walls = [((W + T / 2, H / 2), (T / 2, H / 2 + T)), ((-T / 2, H / 2), (T / 2, H / 2 + T)),
                 ((W / 2, H + T / 2), (W / 2 + T, T / 2)), ((W / 2, -T / 2), (W / 2 + T, T / 2))]
        self.walls = []
        for (cx, cy), (hx, hy) in walls:
            cs = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[hx * self.mm, hy * self.mm, WH * self.mm / 2],
                                         physicsClientId=cid)
            wx, wy = self._world_xy((cx, cy))
            b = pb.createMultiBody(0, cs, basePosition=[wx, wy, WH * self.mm / 2], baseOrientation=q_tray,
                                   physicsClientId=cid)
            pb.changeDynamics(b, -1, lateralFriction=wall_mu, restitution=0.0, physicsClientId=cid)
            self.walls.append(b)
        return mu

    def _prism_shapes(self, scene, st, cid) -> list:
        """The prism's collision shape(s): one convex hull per convex part (``part_links="per-part"``),
        (also ``floating``), or one compound of those hulls (``compound``, ``yaw-compound``). Each hull is inset by
        Bullet's margin and spans ``floor_clearance_mm`` to that plus the part's thickness above the
        floor, in the frame of the support sphere's centre."""
        shape = scene.shape
        r = st.support_radius_mm * self.mm
        z0 = st.floor_clearance_mm * self.mm - r          # prism bottom relative to the sphere centre
        t = shape.thickness_mm * self.mm
        margin_mm = BULLET_HULL_MARGIN_UNITS / self.mm
        hulls = []
        for part in shape.convex_parts:
            p2 = inset_convex(np.asarray(part, float), margin_mm) * self.mm
            hulls.append([[x, y, z0] for x, y in p2] + [[x, y, z0 + t] for x, y in p2])
        if st.part_links in ("per-part", "floating"):
            return [pb.createCollisionShape(pb.GEOM_MESH, vertices=v, physicsClientId=cid) for v in hulls]
        return [_compound_of_hulls(hulls, cid)]

    def _build_part(self, scene, st, cid) -> np.ndarray:
        """The part as a planar joint chain; returns the support legs' offsets (world units; empty
        for the single support sphere).

        ``part_links="per-part"`` (the default): x, y, z slides, the yaw hinge (the part's mass and
        z inertia; the support sphere is its collision shape), one fixed child link per convex part.
        ``compound``: the same with one fixed child link holding all convex parts as one compound
        shape. ``yaw-compound``: the compound is the yaw link's own shape and the support sphere a
        fixed child link. With ``legs:K`` the legs are prismatic-z children in every layout."""
        shape = scene.shape
        m = shape.mass_kg
        eps = m * _EPS_MASS_FRACTION
        r = st.support_radius_mm * self.mm
        part_shapes = self._prism_shapes(scene, st, cid)
        sph = pb.createCollisionShape(pb.GEOM_SPHERE, radius=r, physicsClientId=cid)
        legs = self.contact.kind == "legs"
        self.floating = st.part_links == "floating"
        self._get_states = self._base_states if self.floating else pb.getJointStates
        self._force_link = -1 if self.floating else J_YAW
        if self.floating:
            return self._build_floating(shape, st, cid, part_shapes, sph)
        on_yaw = st.part_links == "yaw-compound"
        izz = shape.inertia_kg_m2 * st.world_units_per_m ** 2
        tiny = izz * _EPS_MASS_FRACTION
        if legs:
            # K legs: prismatic-z links under the centroids of K equal-area cells, each carrying its
            # cell's mass; the hinge link keeps the rest of the z inertia; no global z freedom.
            pts, w = support_cells(shape, self.contact.legs)
            leg_m = m * w
            leg_xy = pts * self.mm
            yaw_m = eps
            yaw_I = max(izz - float(np.sum(leg_m * np.sum(leg_xy ** 2, axis=1))), tiny)
            yaw_shape = part_shapes.pop() if on_yaw else -1
        elif on_yaw:
            # the prism is the hinge link's shape; the sphere a fixed child of negligible mass
            leg_m, leg_xy, yaw_m, yaw_I = np.array([eps]), np.zeros((1, 2)), m, izz
            yaw_shape = part_shapes.pop()
        else:
            # the sphere is the hinge link's own collision shape (one link fewer to step)
            leg_m, leg_xy, yaw_m, yaw_I, yaw_shape = np.zeros(0), np.zeros((0, 2)), m, izz, sph
        n_parts, n_sup = len(part_shapes), len(leg_m)
        n = 4 + n_parts + n_sup
        masses = [eps, eps, eps, yaw_m] + [eps] * n_parts + [float(v) for v in leg_m]
        shapes = [-1, -1, -1, yaw_shape] + part_shapes + [sph] * n_sup
        parents = [0, 1, 2, 3] + [4] * (n_parts + n_sup)      # parent = link index + 1 (0 = base)
        types = ([pb.JOINT_PRISMATIC, pb.JOINT_PRISMATIC, pb.JOINT_FIXED if legs else pb.JOINT_PRISMATIC,
                  pb.JOINT_REVOLUTE] + [pb.JOINT_FIXED] * n_parts
                 + [pb.JOINT_PRISMATIC if legs else pb.JOINT_FIXED] * n_sup)
        axes = [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1]] + [[0, 0, 1]] * (n_parts + n_sup)
        positions = [[0, 0, 0]] * (4 + n_parts) + [[float(x), float(y), 0.0] for x, y in leg_xy]
        self.body = ob = pb.createMultiBody(
            baseMass=0, baseCollisionShapeIndex=-1, basePosition=[0, 0, r],
            linkMasses=masses, linkCollisionShapeIndices=shapes, linkVisualShapeIndices=[-1] * n,
            linkPositions=positions, linkOrientations=[[0, 0, 0, 1]] * n,
            linkInertialFramePositions=[[0, 0, 0]] * n, linkInertialFrameOrientations=[[0, 0, 0, 1]] * n,
            linkParentIndices=parents, linkJointTypes=types, linkJointAxis=axes,
            useMaximalCoordinates=False, physicsClientId=cid)
        self.n_links = n
        self.legs = legs
        self.support_links = list(range(4 + n_parts, n)) if (legs or on_yaw) else [J_YAW]
        self.prism_links = [J_YAW] if on_yaw else list(range(4, 4 + n_parts))
        self._configure_links(ob, n, yaw_I, tiny, cid)
        self._filter_pairs(st, ob, range(n), cid)
        return leg_xy

    def _filter_pairs(self, st, ob, links, cid):
        """``contact_pairs="needed"``: the prism never touches the floor, the supports never touch a
        wall: no collision tests for those pairs (``links``: the part's links, in order)."""
        if st.contact_pairs != "needed":
            return
        for link in links:
            if link in self.prism_links:
                pb.setCollisionFilterPair(self.floor, ob, -1, link, 0, physicsClientId=cid)
            elif link in self.support_links:
                for wall in self.walls:
                    pb.setCollisionFilterPair(wall, ob, -1, link, 0, physicsClientId=cid)

    def _build_floating(self, shape, st, cid, part_shapes, sph) -> np.ndarray:
        """``part_links="floating"``: the part as a free (floating) base whose shape is the support
        sphere, carrying the part's mass, its z inertia and a roll and pitch inertia
        ``_ROLL_INERTIA_FACTOR`` times larger (so it stays flat), with one fixed child link per
        convex part. No slide or hinge links: the base's six degrees of freedom replace the four
        joints of the chain. Never with ``legs:K`` (:class:`SimSettings` reads ``floating`` as
        ``per-part`` there)."""
        m = shape.mass_kg
        eps = m * _EPS_MASS_FRACTION
        izz = shape.inertia_kg_m2 * st.world_units_per_m ** 2
        tiny = izz * _EPS_MASS_FRACTION
        r = st.support_radius_mm * self.mm
        n = len(part_shapes)
        self._base_z = r
        self._yaw_prev = 0.0
        self.body = ob = pb.createMultiBody(
            baseMass=m, baseCollisionShapeIndex=sph, basePosition=[0, 0, r],
            linkMasses=[eps] * n, linkCollisionShapeIndices=part_shapes, linkVisualShapeIndices=[-1] * n,
            linkPositions=[[0, 0, 0]] * n, linkOrientations=[[0, 0, 0, 1]] * n,
            linkInertialFramePositions=[[0, 0, 0]] * n, linkInertialFrameOrientations=[[0, 0, 0, 1]] * n,
            linkParentIndices=[0] * n, linkJointTypes=[pb.JOINT_FIXED] * n, linkJointAxis=[[0, 0, 1]] * n,
            useMaximalCoordinates=False, physicsClientId=cid)
        self.n_links = n
        self.legs = False
        self.support_links = [-1]
        self.prism_links = list(range(n))
        for j in range(-1, n):
            inertia = [izz * _ROLL_INERTIA_FACTOR, izz * _ROLL_INERTIA_FACTOR, izz] if j < 0 else [tiny] * 3
            pb.changeDynamics(ob, j, linearDamping=0.0, angularDamping=0.0, jointDamping=0.0,
                              restitution=0.0, lateralFriction=1.0, spinningFriction=0.0, rollingFriction=0.0,
                              localInertiaDiagonal=inertia, physicsClientId=cid)
        _check_hull_margin(ob, 0, cid)
        pb.changeDynamics(ob, -1, activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING, physicsClientId=cid)
        self._filter_pairs(st, ob, range(-1, n), cid)
        return np.zeros((0, 2))

    def _base_states(self, ob, joints=None, physicsClientId=0):
        """The floating base's state in the joint-state layout of the chain: ((x, vx), (y, vy),
        (z, vz), (yaw, yaw rate)), z relative to the resting height, yaw continuous (unwrapped
        against the last value read) like the chain's hinge angle."""
        pos, q = pb.getBasePositionAndOrientation(ob, physicsClientId=physicsClientId)
        lin, ang = pb.getBaseVelocity(ob, physicsClientId=physicsClientId)
        qx, qy, qz, qw = q
        yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
        prev = self._yaw_prev
        yaw = prev + (yaw - prev + math.pi) % (2.0 * math.pi) - math.pi
        self._yaw_prev = yaw
        return ((pos[0], lin[0]), (pos[1], lin[1]), (pos[2] - self._base_z, lin[2]), (yaw, ang[2]))

    def _configure_links(self, ob, n, yaw_I, tiny, cid):
        """Free joints (no motors, no damping), no restitution, friction 1 (the supports' friction is
        set by :meth:`_set_supports`), the hinge's inertia; checks the hulls' collision margin."""
        pb.changeDynamics(ob, -1, linearDamping=0.0, angularDamping=0.0, physicsClientId=cid)
        for j in range(n):
            pb.setJointMotorControl2(ob, j, pb.VELOCITY_CONTROL, targetVelocity=0.0, force=0.0,
                                     physicsClientId=cid)
            pb.changeDynamics(ob, j, linearDamping=0.0, angularDamping=0.0, jointDamping=0.0,
                              restitution=0.0, lateralFriction=1.0, spinningFriction=0.0, rollingFriction=0.0,
                              localInertiaDiagonal=[yaw_I] * 3 if j == J_YAW else [tiny, tiny, tiny],
                              physicsClientId=cid)
        if self.scene.settings.part_links == "per-part":     # a compound's own margin is 0
            _check_hull_margin(ob, self.prism_links[0], cid)
        pb.changeDynamics(ob, -1, activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING, physicsClientId=cid)

    def _set_supports(self, shape, mu, leg_xy):
        """Friction of the support contact(s) and the frame conversions the map lookup uses."""
        legs = self.legs
        # a single contact under the centroid: its spinning friction gives the friction torque of
        # uniform pressure for spinning in place (Bullet combines spinning friction as
        # spin_A * lateral_B + spin_B * lateral_A; the floor's spinning friction stays 0)
        self.spin_radius = 0.0 if legs else friction_radius_mm(shape) * self.mm
        self.leg_offsets = [(float(x), float(y)) for x, y in leg_xy] if legs else [(0.0, 0.0)]
        self._mu_now = [None] * len(self.support_links)
        for k in range(len(self.support_links)):
            self._set_support_mu(k, float(mu.flat[0]))
        c, sn = math.cos(self.phi), math.sin(self.phi)
        self._to_tray = (c / self.mm, -sn / self.mm, sn / self.mm, c / self.mm)   # world units -> mm
        self._nx, self._ny = mu.shape
        if self.contact.kind == "coulomb":
            st = self.scene.settings
            pts, w = footprint_points(shape.vertices, st.footprint_points)
            pts = pts * self.mm
            r = np.hypot(pts[:, 0], pts[:, 1])
            self._cb_geom = np.ascontiguousarray(np.vstack([pts[:, 0], pts[:, 1], w, r]))
            self._cb_grid = np.ascontiguousarray(mu, dtype=np.float64)
            a, b, c, d = self._to_tray
            self._cb_params = np.array([self.tile_mm, a, b, c, d, self.centre[0], self.centre[1],
                                        st.stick_speed_mm_s * self.mm, float(r.max()),
                                        self.scene.friction.static_ratio])
            self._cb_mem = np.zeros(4)
            self._cb_out = np.zeros(4)
            self._cb_z = st.support_radius_mm * self.mm     # height of the yaw link (its z slide at 0)
            self._cb_caps = None
            # (physics step, steps per call, calls per rest-test interval) near walls and in free flight
            k = st.free_flight_step_factor
            n_free = max(st.friction_substeps // k, 1)
            self._cb_modes = ((st.time_step_s, st.friction_substeps, st.substeps // st.friction_substeps),
                              (st.time_step_s * k, n_free, st.substeps // (n_free * k)))
            self._cb_mode = 0
            self._cb_free_factor = k
            # long steps also while the contact is steady (SimSettings.long_steps); both modes must
            # cover the same simulated time per call for the mode to change between calls
            self._cb_steady = (k > 1 and st.long_steps != "free"
                               and st.time_step_s * st.friction_substeps == st.time_step_s * k * n_free)
            # steady calls of twice the simulated time ("hold": one friction update for two calls)
            hold = 2 if st.long_steps == "free+steady-hold" else 1
            self._cb_stick_only = st.long_steps == "free+stick"
            self._cb_units = (st.friction_substeps, hold * st.friction_substeps, st.substeps)
            self._cb_modes += ((st.time_step_s * k, hold * n_free, 0),)
            W, H = self.scene.tray_x_mm, self.scene.tray_y_mm
            # clear by twice the distance covered in one interval, plus the contact threshold and 1 mm
            self._cb_walls = (W, H, float(r.max()) / self.mm, 2.0 * st.check_interval_s,
                              st.contact_threshold_mm + 1.0)

    # ------------------------------------------------------------------ state
    def set_pose(self, pose_mm, twist=None):  # noqa: D401
        """Place the part at a tray-frame pose (x, y in mm, theta in rad) on the floor, at rest or
        with the tray-frame ``twist`` (vx, vy in mm/s, yaw rate in rad/s)."""
        cid, ob = self.cid, self.body
        # Move away and run collision detection first: drops every cached contact (and its
        # warm-start impulse), so a trial never depends on the trial before it.
        if self.floating:
            pb.resetBasePositionAndOrientation(ob, [1000.0 * self.mm, 0.0, self._base_z], [0, 0, 0, 1],
                                               physicsClientId=cid)
        else:
            pb.resetJointState(ob, J_X, 1000.0 * self.mm, 0.0, physicsClientId=cid)   # 1 m away: touches nothing
        pb.performCollisionDetection(physicsClientId=cid)
        wx, wy = self._world_xy(pose_mm[:2])
        yaw = float(pose_mm[2]) - self.phi
        vel = (0.0, 0.0, 0.0)
        if twist is not None:
            vx, vy = self.R @ np.asarray(twist[:2], float) * self.mm
            vel = (float(vx), float(vy), float(twist[2]))
        if self.floating:
            pb.resetBasePositionAndOrientation(ob, [float(wx), float(wy), self._base_z], self._quat(yaw),
                                               physicsClientId=cid)
            pb.resetBaseVelocity(ob, [vel[0], vel[1], 0.0], [0.0, 0.0, vel[2]], physicsClientId=cid)
            self._yaw_prev = yaw
        else:
            for j, q, v in ((J_X, wx, vel[0]), (J_Y, wy, vel[1]), (J_Z, 0.0, 0.0), (J_YAW, yaw, vel[2])):
                pb.resetJointState(ob, j, float(q), v, physicsClientId=cid)
        if self.legs:
            for j in self.support_links:
                pb.resetJointState(ob, j, 0.0, 0.0, physicsClientId=cid)
        if self.contact.kind == "coulomb":
            self._cb_mem[:] = 0.0           # no previous step: no prediction on the first
            self._cb_out[:] = np.nan        # no previous update: the first is never steady
        self._after = None

    def lift_mm(self) -> float:
        """Largest height of a support above its resting height (mm)."""
        if not self.legs:
            s = self._after
            if s is None:
                s = self._get_states(self.body, _JOINTS, physicsClientId=self.cid)
            z = s[2][0]
            return z / self.mm
        s = pb.getJointStates(self.body, self.support_links, physicsClientId=self.cid)
        return max(abs(v[0]) for v in s) / self.mm

    def state(self):
        """(x, y, z, yaw, vx, vy, wz) in the world frame (m, rad, m/s, rad/s).

        After a coulomb step the joint states read after its last physics step are used (nothing
        has moved since): one PyBullet call fewer per rest-test interval."""
        s = self._after
        if s is None:
            s = self._get_states(self.body, _JOINTS, physicsClientId=self.cid)
        k = self.inv_scale
        return (s[0][0] * k, s[1][0] * k, s[2][0] * k, s[3][0], s[0][1] * k, s[1][1] * k, s[3][1])

    def to_tray(self, x, y, yaw):
        """World (m, rad) -> tray-frame pose (mm, rad in [0, 2 pi))."""
        p = self.R.T @ np.array([x, y]) * 1000.0 + self.centre
        th = (yaw + self.phi) % (2 * math.pi)
        if th >= 2 * math.pi:      # -tiny % 2pi rounds to 2pi
            th = 0.0
        return p[0], p[1], th

    def _set_support_mu(self, k: int, mu: float):
        if self._mu_now[k] != mu:
            pb.changeDynamics(self.body, self.support_links[k], lateralFriction=mu,
                              spinningFriction=self.spin_radius * mu, physicsClientId=self.cid)
            self._mu_now[k] = mu

    def _apply_map(self):
        """Give every support the coefficient of the map tile under it."""
        cid, ob = self.cid, self.body
        s = self._get_states(ob, _JOINTS, physicsClientId=cid)
        x, y, yaw = s[0][0], s[1][0], s[3][0]
        cy, sy = math.cos(yaw), math.sin(yaw)
        a, b, c, d = self._to_tray
        cx, cyy = self.centre
        t = self.tile_mm
        for k, (ox, oy) in enumerate(self.leg_offsets):
            wx, wy = x + cy * ox - sy * oy, y + sy * ox + cy * oy
            px, py = a * wx + b * wy + cx, c * wx + d * wy + cyy
            i = min(max(int(px // t), 0), self._nx - 1)
            j = min(max(int(py // t), 0), self._ny - 1)
            self._set_support_mu(k, float(self.mu_grid[i, j]))

    def _step_coulomb(self):
        """``substeps`` physics steps, each after setting the support's friction limits and the
        explicit friction force from the twist predicted for the end of the step (distributed
        Coulomb friction, :func:`transition_builder._coulomb._contact_update`).

        The joint states are read once after every call of ``stepSimulation`` (x, y, z and yaw in
        one call); the last read is kept (``_after``) for :meth:`state` and the next interval's
        first update, which read the same values again before."""
        cid, ob = self.cid, self.body
        mem, geom, grid, params, out = self._cb_mem, self._cb_geom, self._cb_grid, self._cb_params, self._cb_out
        joints = _JOINTS
        get_states, step = self._get_states, pb.stepSimulation
        mode = 0
        s = self._after
        if s is None:
            s = get_states(ob, joints, physicsClientId=cid)
        if self._cb_free_factor > 1:
            mode = self._free_flight(s[0][0], s[1][0], s[0][1], s[1][1])
            if mode != self._cb_mode:
                dt, n_sub, _ = self._cb_modes[mode]
                pb.setPhysicsEngineParameter(fixedTimeStep=dt * n_sub, numSubSteps=n_sub, physicsClientId=cid)
                self._cb_mode = mode
        if self._cb_steady:
            self._step_steady(mode, s)
            return
        for i in range(self._cb_modes[mode][2]):
            if i:                   # the first update uses the state read above
                s = get_states(ob, joints, physicsClientId=cid)
            sx, sy, _, sw = s
            _contact_update(sx[0], sy[0], sw[0], sx[1], sy[1], sw[1], mem, geom, grid, params, out)
            self._apply_contact(out, sx[0], sy[0])
            step(physicsClientId=cid)
        self._after = get_states(ob, joints, physicsClientId=cid)

    def _apply_contact(self, out, x: float, y: float) -> None:
        """Apply one contact update ``out`` before a physics step: the support's lateral and spinning
        limits when they changed, and the explicit friction force (at the support point ``x, y``)."""
        caps = (out[0], out[1])
        if caps != self._cb_caps:
            pb.changeDynamics(self.body, self.support_links[0], lateralFriction=caps[0], spinningFriction=caps[1],
                              physicsClientId=self.cid)
            self._cb_caps = caps
        if out[2] != 0.0 or out[3] != 0.0:
            n = self.normal_force
            pb.applyExternalForce(self.body, self._force_link, (out[2] * n, out[3] * n, 0.0), (x, y, self._cb_z),
                                  pb.WORLD_FRAME, physicsClientId=self.cid)

    def _step_steady(self, free: int, s):
        """:meth:`_step_coulomb` with ``long_steps="free+steady"``: every call runs in the long-step
        mode when the part is in free flight (``free``, decided once per interval as by default) or
        when this call's friction update gave exactly the limits and the explicit force of the one
        before (the contact is steady: sticking, or sliding in pure translation). Each call covers
        the same simulated time in either mode, so the friction is updated as often as by default.
        ``s``: the joint states at the start of the interval."""
        cid, ob = self.cid, self.body
        mem, geom, grid, params, out = self._cb_mem, self._cb_geom, self._cb_grid, self._cb_params, self._cb_out
        joints, modes = _JOINTS, self._cb_modes
        get_states, step = self._get_states, pb.stepSimulation
        unit, steady_units, left = self._cb_units
        stick_only = self._cb_stick_only
        first = True
        while left:
            if not first:
                s = get_states(ob, joints, physicsClientId=cid)
            first = False
            sx, sy, _, sw = s
            before = (out[0], out[1], out[2], out[3])
            _contact_update(sx[0], sy[0], sw[0], sx[1], sy[1], sw[1], mem, geom, grid, params, out)
            mode = 1 if free else 0
            if before == (out[0], out[1], out[2], out[3]) and (out[1] > 0.0 or not stick_only):
                mode = 2 if steady_units > unit and left >= steady_units else 1
            left -= steady_units if mode == 2 else unit
            if mode != self._cb_mode:
                dt, n_sub, _ = modes[mode]
                pb.setPhysicsEngineParameter(fixedTimeStep=dt * n_sub, numSubSteps=n_sub, physicsClientId=cid)
                self._cb_mode = mode
            self._apply_contact(out, sx[0], sy[0])
            step(physicsClientId=cid)
        self._after = get_states(ob, joints, physicsClientId=cid)

    def _free_flight(self, x, y, vx, vy) -> int:
        """1 if the part's bounding circle is clear of every wall by the margin (free flight), else 0.
        ``x, y, vx, vy``: world (downhill frame) position and velocity, world units."""
        a, b, c, d = self._to_tray
        px = a * x + b * y + self.centre[0]
        py = c * x + d * y + self.centre[1]
        W, H, r_mm, horizon_s, margin_mm = self._cb_walls
        speed_mm_s = math.hypot(vx, vy) / self.mm
        clear = min(px, W - px, py, H - py) - r_mm
        return int(clear > speed_mm_s * horizon_s + margin_mm)

    def step(self):
        """Advance one rest-test interval (``substeps`` physics steps)."""
        if self.contact.kind == "coulomb":
            self._step_coulomb()
            return
        self._after = None
        if self.has_map:
            for _ in range(self.substeps):
                self._apply_map()
                pb.stepSimulation(physicsClientId=self.cid)
        else:
            pb.stepSimulation(physicsClientId=self.cid)

    def rebuild(self):
        """Reset the physics server and build the world again on the same connection: no state of
        earlier trials survives (see :meth:`transition_builder.sim.TraySimulator.fresh_start`)."""
        self._build(self.scene, self.scene.settings, self.cid)

    def close(self):
        if self.cid is not None:
            try:
                pb.disconnect(self.cid)
            except pb.error:
                pass
            self.cid = None
