"""Planar part shapes: the allen key, seeded random triangles, rectangles, polygons and JSON files.

A :class:`Shape` is a laminar part lying flat in the tray: a simple polygon (convex or concave)
extruded by a thickness, of uniform density. Its vertices are stored counter-clockwise in the
*body frame*, whose origin is the polygon's area centroid and whose axes are those of the spec
(so ``theta = 0`` shows the part as written). Concave polygons are split into at most
:data:`MAX_CONVEX_PARTS` convex parts for the physics engine (a PyBullet compound body has at
most 16 children).

Shape specs (``--shape``, docs/commands.md):

``allen-key`` (or ``allen-key:arm=6,thickness=5``)
    The paper's L-shaped hex key, 77.5 x 27.5 mm outer size, see :func:`allen_key`.
``triangle:SEED``
    A seeded random triangle, see :func:`random_triangle`.
``rectangle:WxH``
    A W x H mm rectangle.
``polygon:x1,y1;x2,y2;...``
    Any simple polygon in mm, either orientation.
``path/to/shape.json``
    ``{"vertices": [[x, y], ...], "thickness_mm": t, "density_kg_m3": d}`` (the last two optional).

Every malformed spec raises :class:`ValueError` with a one-line message.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "DEFAULT_THICKNESS_MM",
    "MAX_CONVEX_PARTS",
    "STEEL_DENSITY_KG_M3",
    "Shape",
    "allen_key",
    "check_fits",
    "convex_decomposition",
    "fits_in_tray",
    "make_shape",
    "parse_shape",
    "random_triangle",
    "rectangle",
    "symmetry_order",
]

#: density of steel, the allen key's material (kg/m^3); also the default for every other shape.
STEEL_DENSITY_KG_M3 = 7850.0
#: default thickness (mm): a 5 mm hex key lying flat is 5 mm high.
DEFAULT_THICKNESS_MM = 5.0
_MAX_SPAN_MM = 1e5          # a part larger than 100 m fits no tray (and would overflow the area)
#: the most convex parts a shape may be split into (PyBullet's compound-shape child limit).
MAX_CONVEX_PARTS = 16

# Relative geometric tolerance (fraction of the shape's diameter) for collinearity, symmetry, ears.
_REL_TOL = 1e-9


@dataclass(frozen=True, eq=False)
class Shape:
    """A laminar part: a simple polygon extruded by ``thickness_mm``, of uniform density.

    Build it with :func:`parse_shape` or :func:`make_shape` rather than directly: they validate the
    polygon and compute the derived fields.

    Attributes
    ----------
    name : str
        The spec string, e.g. ``"allen-key"``, ``"triangle:3"``, ``"rectangle:40x20"``.
    vertices : ndarray, shape (m, 2)
        Polygon vertices (mm), counter-clockwise, body frame with the area centroid at the origin.
    thickness_mm, density_kg_m3 : float
        Extrusion height (mm) and density (kg/m^3).
    convex_parts : tuple of ndarray (p, 2)
        Counter-clockwise convex polygons (body frame) whose union is the polygon; at most 16.
    symmetry_order : int
        Order k of the rotational symmetry group (square 4, equilateral triangle 3, rectangle 2, L 1).
    area_mm2, mass_kg : float
        Polygon area (mm^2) and mass (kg).
    inertia_kg_m2 : float
        Moment of inertia about the z axis through the centroid (kg m^2).
    """

    name: str
    vertices: np.ndarray
    thickness_mm: float
    density_kg_m3: float
    convex_parts: tuple = field(default_factory=tuple)
    symmetry_order: int = 1
    area_mm2: float = 0.0
    mass_kg: float = 0.0
    inertia_kg_m2: float = 0.0

    def to_dict(self) -> dict:
        """Everything that defines the shape, JSON-able (for content hashes and logs)."""
        return {
            "name": self.name,
            "vertices": np.round(self.vertices, 12).tolist(),
            "thickness_mm": float(self.thickness_mm),
            "density_kg_m3": float(self.density_kg_m3),
            "convex_parts": [np.round(p, 12).tolist() for p in self.convex_parts],
            "symmetry_order": int(self.symmetry_order),
            "area_mm2": float(self.area_mm2),
            "mass_kg": float(self.mass_kg),
            "inertia_kg_m2": float(self.inertia_kg_m2),
        }

    def placed(self, pose) -> np.ndarray:
        """Vertices in the tray frame for ``pose = (x, y, theta)``.

        ``pose`` of shape (3,) gives an (m, 2) array; a batch of shape (n, 3) gives (n, m, 2).
        """
        p = np.asarray(pose, dtype=np.float64)
        if p.shape[-1] != 3:
            raise ValueError(f"a pose is (x, y, theta); got an array of shape {p.shape}")
        c = np.cos(p[..., 2])[..., None]
        s = np.sin(p[..., 2])[..., None]
        vx, vy = self.vertices[:, 0], self.vertices[:, 1]
        x = p[..., 0, None] + c * vx - s * vy
        y = p[..., 1, None] + s * vx + c * vy
        return np.stack([x, y], axis=-1)

    @property
    def radius_mm(self) -> float:
        """Largest distance from the centroid to a vertex (mm)."""
        return float(np.max(np.hypot(self.vertices[:, 0], self.vertices[:, 1])))

    def __repr__(self) -> str:
        return (f"Shape({self.name!r}, {len(self.vertices)} vertices, area {self.area_mm2:.1f} mm^2, "
                f"{len(self.convex_parts)} convex part(s), symmetry {self.symmetry_order})")


# ----------------------------------------------------------------------------------------------
# polygon geometry
# ----------------------------------------------------------------------------------------------

def _signed_area(v: np.ndarray) -> float:
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _centroid(v: np.ndarray) -> np.ndarray:
    """Area centroid of a simple polygon (shoelace formula)."""
    x, y = v[:, 0], v[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cross = x * y1 - x1 * y
    a = 0.5 * np.sum(cross)
    return np.array([np.sum((x + x1) * cross), np.sum((y + y1) * cross)]) / (6.0 * a)


def _polar_second_moment(v: np.ndarray) -> float:
    """Integral of x^2 + y^2 over a CCW polygon, about the origin (same units^4 as v)."""
    x, y = v[:, 0], v[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cross = x * y1 - x1 * y
    ixx = np.sum(cross * (y * y + y * y1 + y1 * y1)) / 12.0
    iyy = np.sum(cross * (x * x + x * x1 + x1 * x1)) / 12.0
    return float(ixx + iyy)


def _cross(o, a, b) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _drop_collinear(v: np.ndarray, tol: float) -> np.ndarray:
    """Remove repeated and collinear vertices (a vertex whose turn is below ``tol`` mm^2)."""
    pts = [p for p in v]
    changed = True
    while changed and len(pts) > 3:
        changed = False
        for i in range(len(pts)):
            a, b, c = pts[i - 1], pts[i], pts[(i + 1) % len(pts)]
            seg = max(np.hypot(*(c - a)), 1e-300)
            # distance of b from the line a-c, and b coinciding with a neighbour
            if abs(_cross(a, b, c)) / seg <= tol or np.hypot(*(b - a)) <= tol:
                # only drop b if it lies between a and c (a straight-through vertex), or repeats
                if np.dot(b - a, c - b) >= 0 or np.hypot(*(b - a)) <= tol:
                    del pts[i]
                    changed = True
                    break
    return np.asarray(pts, dtype=np.float64)


def _is_convex_ccw(v: np.ndarray, tol: float) -> bool:
    n = len(v)
    for i in range(n):
        if _cross(v[i - 1], v[i], v[(i + 1) % n]) < -tol:
            return False
    return True


def _point_in_triangle(p, a, b, c, tol) -> bool:
    """True if p is inside or on the CCW triangle abc (with tolerance)."""
    return _cross(a, b, p) >= -tol and _cross(b, c, p) >= -tol and _cross(c, a, p) >= -tol


def _ear_clip(v: np.ndarray, tol: float) -> list[tuple[int, int, int]]:
    """Triangulate a simple CCW polygon by ear clipping (Meisters 1975), O(m^3); vertex indices out."""
    idx = list(range(len(v)))
    tris = []
    guard = 0
    while len(idx) > 3:
        guard += 1
        if guard > 10 * len(v) ** 2:
            raise ValueError("could not triangulate the polygon (degenerate geometry)")
        found = False
        n = len(idx)
        # prefer the ear with the largest minimum angle: avoids slivers, makes parts nicer
        best, best_score = None, -1.0
        for k in range(n):
            i0, i1, i2 = idx[k - 1], idx[k], idx[(k + 1) % n]
            a, b, c = v[i0], v[i1], v[i2]
            if _cross(a, b, c) <= tol:
                continue  # reflex or flat vertex: not an ear
            ok = True
            for j in idx:
                if j in (i0, i1, i2):
                    continue
                if _point_in_triangle(v[j], a, b, c, tol):
                    ok = False
                    break
            if ok:
                score = _min_angle(np.array([a, b, c]))
                if score > best_score:
                    best, best_score = k, score
                found = True
        if not found:
            raise ValueError("could not triangulate the polygon (is it simple?)")
        k = best
        tris.append((idx[k - 1], idx[k], idx[(k + 1) % n]))
        del idx[k]
    tris.append(tuple(idx))
    return tris


def _min_angle(tri: np.ndarray) -> float:
    """Smallest interior angle (radians) of a triangle given as a (3, 2) array."""
    angles = []
    for i in range(3):
        a, b, c = tri[i - 1], tri[i], tri[(i + 1) % 3]
        u, w = a - b, c - b
        nu, nw = np.hypot(*u), np.hypot(*w)
        if nu == 0 or nw == 0:
            return 0.0
        angles.append(math.acos(max(-1.0, min(1.0, float(np.dot(u, w) / (nu * nw))))))
    return min(angles)


def convex_decomposition(vertices, max_parts: int = MAX_CONVEX_PARTS) -> tuple[np.ndarray, ...]:
    """Split a simple CCW polygon into convex CCW parts.

    Ear-clipping triangulation followed by the Hertel--Mehlhorn greedy merge: an internal diagonal
    is removed whenever the union of the two parts it separates is still convex (Hertel & Mehlhorn
    1983; at most four times the minimum number of convex parts). A convex polygon is returned as
    a single part. Raises :class:`ValueError` if more than ``max_parts`` parts remain.
    """
    v = np.asarray(vertices, dtype=np.float64)
    scale = float(np.max(np.ptp(v, axis=0)))
    tol = _REL_TOL * scale * scale
    if _is_convex_ccw(v, tol):
        return (v.copy(),)
    parts = [list(t) for t in _ear_clip(v, tol)]

    def edges(part):
        return [(part[i], part[(i + 1) % len(part)]) for i in range(len(part))]

    merged = True
    while merged:
        merged = False
        # try the longest diagonals first: merging across them removes the most awkward cuts
        candidates = []
        for pi, p in enumerate(parts):
            for a, b in edges(p):
                for qi in range(pi + 1, len(parts)):
                    if (b, a) in edges(parts[qi]):
                        candidates.append((np.hypot(*(v[a] - v[b])), pi, qi, a, b))
        candidates.sort(key=lambda t: -t[0])
        for _, pi, qi, a, b in candidates:
            p, q = parts[pi], parts[qi]
            # rotate p to start at b and end at a; q to start at a and end at b
            ip = p.index(b)
            p_rot = p[ip:] + p[:ip]
            iq = q.index(a)
            q_rot = q[iq:] + q[:iq]
            union = p_rot + q_rot[1:-1]
            if _is_convex_ccw(v[union], tol):
                parts[pi] = union
                del parts[qi]
                merged = True
                break
    out = tuple(_drop_collinear(v[p], tol=_REL_TOL * scale) for p in parts)
    if len(out) > max_parts:
        raise ValueError(f"polygon needs {len(out)} convex parts; at most {max_parts} are supported "
                         f"(simplify the outline)")
    return out


def symmetry_order(vertices, rel_tol: float = 1e-3) -> int:
    """Order of the rotational symmetry group of a polygon about its area centroid.

    The largest k such that rotating the polygon by 2*pi/k about its centroid maps it onto itself:
    every rotated vertex lies within ``rel_tol * diameter`` of a vertex and the symmetric difference
    of the two polygons has area below ``rel_tol * diameter * perimeter``. Only k dividing the
    number of (non-collinear) vertices can occur. Independent of vertex order and starting vertex.
    """
    from shapely.geometry import Polygon

    v = np.asarray(vertices, dtype=np.float64)
    diam = float(np.max(np.ptp(v, axis=0)))
    v = _drop_collinear(v, tol=1e-7 * diam)
    if _signed_area(v) < 0:
        v = v[::-1]
    v = v - _centroid(v)
    m = len(v)
    tol = rel_tol * diam
    perimeter = float(np.sum(np.hypot(*(np.roll(v, -1, axis=0) - v).T)))
    poly = Polygon(v)
    for k in range(m, 1, -1):
        if m % k:
            continue
        ang = 2.0 * math.pi / k
        c, s = math.cos(ang), math.sin(ang)
        r = v @ np.array([[c, s], [-s, c]])
        d = np.hypot(r[:, None, 0] - v[None, :, 0], r[:, None, 1] - v[None, :, 1])
        if np.max(np.min(d, axis=1)) > tol:
            continue
        if poly.symmetric_difference(Polygon(r)).area > tol * perimeter:
            continue
        return k
    return 1


# ----------------------------------------------------------------------------------------------
# construction and validation
# ----------------------------------------------------------------------------------------------

def _validate_polygon(vertices, name: str) -> np.ndarray:
    """Check finiteness, vertex count, simplicity and area; return CCW vertices without repeats."""
    from shapely.geometry import Polygon
    from shapely.validation import explain_validity

    try:
        v = np.asarray(vertices, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"shape {name!r}: vertices must be numbers") from None
    if v.ndim != 2 or v.shape[1] != 2:
        raise ValueError(f"shape {name!r}: vertices must be (x, y) pairs, got an array of shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"shape {name!r}: vertices must be finite numbers (found NaN or infinity)")
    if len(v) > 3 and np.array_equal(v[0], v[-1]):
        v = v[:-1]  # a closed ring given with its first vertex repeated
    if len(v) < 3:
        raise ValueError(f"shape {name!r}: a polygon needs at least 3 vertices, got {len(v)}")
    diam = float(np.max(np.ptp(v, axis=0)))
    if diam > _MAX_SPAN_MM:
        raise ValueError(f"shape {name!r}: the vertices span {diam:.3g} mm, so it does not fit in any tray "
                         f"(coordinates are millimetres)")
    poly = Polygon(v)
    area = _signed_area(v)
    centred = v - v.mean(axis=0)
    flat = diam <= 0 or np.linalg.svd(centred, compute_uv=False)[-1] <= 1e-9 * diam
    if flat:  # all vertices on one line (or one point)
        raise ValueError(f"shape {name!r}: polygon has zero area (all vertices on a line)")
    if not poly.is_valid:
        why = explain_validity(poly).replace("[", " at [")
        raise ValueError(f"shape {name!r}: polygon is not simple ({why.lower()}); "
                         f"vertices must trace a non-self-intersecting outline")
    if area <= 1e-9 * diam * diam and area >= -1e-9 * diam * diam:
        raise ValueError(f"shape {name!r}: polygon has zero area")
    if area < 0:
        v = v[::-1].copy()
    v = _drop_collinear(v, tol=1e-9 * diam)
    if len(v) < 3 or abs(_signed_area(v)) <= 1e-9 * diam * diam:
        raise ValueError(f"shape {name!r}: polygon has zero area")
    return v


def make_shape(vertices, name: str = "polygon", thickness_mm: float = DEFAULT_THICKNESS_MM,
               density_kg_m3: float = STEEL_DENSITY_KG_M3) -> Shape:
    """Validate a simple polygon (either orientation) and build its :class:`Shape`.

    The vertices are normalised to counter-clockwise order, repeated and collinear vertices are
    dropped, and the polygon is translated so that its area centroid is the origin.

    Parameters
    ----------
    vertices : array_like (n, 2)
        The polygon's vertices in mm, either orientation, not closed.
    name : str, default "polygon"
        The shape's name.
    thickness_mm, density_kg_m3 : float, default 5 and 7850
        Thickness of the part and its density (steel).

    Returns
    -------
    Shape
        Raises a one-line ValueError for a polygon that is not simple or has no area.
    """
    for label, val in (("thickness_mm", thickness_mm), ("density_kg_m3", density_kg_m3)):
        try:
            val = float(val)
        except (TypeError, ValueError):
            raise ValueError(f"shape {name!r}: {label} must be a number, got {val!r}") from None
        if not math.isfinite(val) or val <= 0:
            raise ValueError(f"shape {name!r}: {label} must be a positive finite number, got {val!r}")
    thickness_mm, density_kg_m3 = float(thickness_mm), float(density_kg_m3)
    v = _validate_polygon(vertices, name)
    v = v - _centroid(v)
    v.setflags(write=False)
    area = _signed_area(v)
    parts = convex_decomposition(v)
    for p in parts:
        p.setflags(write=False)
    volume_m3 = area * 1e-6 * thickness_mm * 1e-3
    mass = density_kg_m3 * volume_m3
    inertia = density_kg_m3 * thickness_mm * 1e-3 * _polar_second_moment(v) * 1e-12
    return Shape(name=name, vertices=v, thickness_mm=thickness_mm, density_kg_m3=density_kg_m3,
                 convex_parts=parts, symmetry_order=symmetry_order(v), area_mm2=float(area),
                 mass_kg=float(mass), inertia_kg_m2=float(inertia))


def allen_key(arm_width_mm: float = 6.0, thickness_mm: float = DEFAULT_THICKNESS_MM,
              long_mm: float = 77.5, short_mm: float = 27.5,
              density_kg_m3: float = STEEL_DENSITY_KG_M3, name: str = "allen-key") -> Shape:
    """The paper's L-shaped allen key: outer size ``long_mm`` x ``short_mm`` (77.5 x 27.5 mm).

    Modelled as a flat L of constant arm width (default 6 mm, a 5-6 mm hex key seen from above) and
    thickness (default 5 mm), steel (7850 kg/m^3): area 594 mm^2, mass about 23 g. The long arm lies
    along the body x axis, the short arm along +y at its west end.

    Parameters
    ----------
    arm_width_mm : float, default 6
        Width of both arms.
    thickness_mm : float, default 5
        Thickness of the part.
    long_mm, short_mm : float, default 77.5 and 27.5
        Outer length of the long and the short arm.
    density_kg_m3 : float, default 7850
        Density (steel).
    name : str, default "allen-key"
        The shape's name.

    Returns
    -------
    Shape
    """
    w = float(arm_width_mm)
    if not (math.isfinite(w) and 0 < w < min(long_mm, short_mm)):
        raise ValueError(f"allen key: arm width must be in (0, {min(long_mm, short_mm)}) mm, got {arm_width_mm}")
    v = [(0.0, 0.0), (long_mm, 0.0), (long_mm, w), (w, w), (w, short_mm), (0.0, short_mm)]
    return make_shape(v, name=name, thickness_mm=thickness_mm, density_kg_m3=density_kg_m3)


def rectangle(width_mm: float, height_mm: float, thickness_mm: float = DEFAULT_THICKNESS_MM,
              density_kg_m3: float = STEEL_DENSITY_KG_M3, name: str | None = None) -> Shape:
    """A ``width_mm`` x ``height_mm`` rectangle (width along the body x axis).

    Parameters
    ----------
    width_mm, height_mm : float
        Side lengths (positive).
    thickness_mm, density_kg_m3 : float, default 5 and 7850
        Thickness of the part and its density (steel).
    name : str, optional
        Default ``rectangle:WxH``.

    Returns
    -------
    Shape
    """
    w, h = float(width_mm), float(height_mm)
    if not (math.isfinite(w) and math.isfinite(h) and w > 0 and h > 0):
        raise ValueError(f"rectangle: width and height must be positive finite numbers, got {width_mm} x {height_mm}")
    name = name or f"rectangle:{width_mm:g}x{height_mm:g}"
    return make_shape([(0, 0), (w, 0), (w, h), (0, h)], name=name, thickness_mm=thickness_mm,
                      density_kg_m3=density_kg_m3)


#: parameters of the random triangle generator (documented in :func:`random_triangle`).
TRIANGLE_BOX_MM = 80.0
TRIANGLE_MIN_ANGLE_DEG = 20.0
TRIANGLE_AREA_RANGE_MM2 = (400.0, 1400.0)
TRIANGLE_MAX_SIDE_MM = 90.0


def random_triangle(seed: int, thickness_mm: float = DEFAULT_THICKNESS_MM,
                    density_kg_m3: float = STEEL_DENSITY_KG_M3) -> Shape:
    """A seeded random triangle, in the spirit of the paper's Fig. 2 (15 random triangles).

    Generator: ``numpy.random.default_rng([seed, 0x7421])`` draws the three vertices uniformly in
    an 80 x 80 mm square, and the draw is rejected and repeated until the triangle is not a sliver
    and is comparable in size to the allen key (77.5 x 27.5 mm, 594 mm^2):

    - smallest interior angle >= 20 degrees,
    - area in [400, 1400] mm^2,
    - longest side <= 90 mm.

    Same thickness (5 mm) and density (steel, 7850 kg/m^3) as the key by default. The same seed
    always gives the same triangle.

    Parameters
    ----------
    seed : int
        Non-negative; the same seed gives the same triangle.
    thickness_mm, density_kg_m3 : float, default 5 and 7850
        Thickness of the part and its density (steel).

    Returns
    -------
    Shape
        Named ``triangle:SEED``.
    """
    try:
        seed_int = int(seed)
    except (TypeError, ValueError):
        raise ValueError(f"triangle seed must be a non-negative integer, got {seed!r}") from None
    if seed_int < 0 or seed_int != seed:
        raise ValueError(f"triangle seed must be a non-negative integer, got {seed!r}")
    rng = np.random.default_rng([seed_int, 0x7421])
    lo, hi = TRIANGLE_AREA_RANGE_MM2
    min_angle = math.radians(TRIANGLE_MIN_ANGLE_DEG)
    for _ in range(100000):
        t = rng.uniform(0.0, TRIANGLE_BOX_MM, size=(3, 2))
        area = abs(_signed_area(t))
        sides = np.hypot(*(np.roll(t, -1, axis=0) - t).T)
        if lo <= area <= hi and sides.max() <= TRIANGLE_MAX_SIDE_MM and _min_angle(t) >= min_angle:
            t = np.round(t, 6)  # a stable, printable definition
            return make_shape(t, name=f"triangle:{seed_int}", thickness_mm=thickness_mm,
                              density_kg_m3=density_kg_m3)
    raise RuntimeError("random triangle generator failed to find an acceptable triangle")  # pragma: no cover


def _parse_float(token: str, what: str, spec: str) -> float:
    try:
        value = float(token)
    except ValueError:
        raise ValueError(f"bad shape {spec!r}: {what} {token.strip()!r} is not a number") from None
    if not math.isfinite(value):
        raise ValueError(f"bad shape {spec!r}: {what} must be finite, got {token.strip()!r}")
    return value


def _parse_keywords(text: str, allowed: dict, spec: str) -> dict:
    out = {}
    if not text:
        return out
    for item in text.split(","):
        if "=" not in item:
            raise ValueError(f"bad shape {spec!r}: expected key=value, got {item!r}")
        key, val = (s.strip() for s in item.split("=", 1))
        if key not in allowed:
            raise ValueError(f"bad shape {spec!r}: unknown parameter {key!r}; known: {', '.join(allowed)}")
        out[allowed[key]] = _parse_float(val, key, spec)
    return out


def parse_shape(spec: str) -> Shape:
    """Build a :class:`Shape` from a ``--shape`` spec (see the module docstring).

    Parameters
    ----------
    spec : str
        ``allen-key``, ``triangle:SEED``, ``rectangle:WxH``, ``polygon:x1,y1;x2,y2;...`` or the path of
        a ``.json`` file holding ``{"vertices": [[x, y], ...]}``.

    Returns
    -------
    Shape
        Raises a one-line ValueError naming the accepted forms on a bad spec.

    Examples
    --------
    >>> parse_shape("rectangle:40x20").symmetry_order
    2
    >>> parse_shape("polygon:0,0;30,0;30,30;0,30").area_mm2
    900.0
    """
    if isinstance(spec, Shape):
        return spec
    if not isinstance(spec, str) or not spec.strip():
        raise ValueError("empty shape spec; use allen-key, triangle:SEED, rectangle:WxH, "
                         "polygon:x1,y1;x2,y2;... or a .json file")
    spec = spec.strip()
    head, _, rest = spec.partition(":")
    kind = head.lower()
    if kind in ("allen-key", "allen_key", "allenkey"):
        kw = _parse_keywords(rest, {"arm": "arm_width_mm", "arm_width": "arm_width_mm",
                                    "thickness": "thickness_mm", "long": "long_mm",
                                    "short": "short_mm", "density": "density_kg_m3"}, spec)
        return allen_key(name=spec, **kw)
    if kind == "triangle":
        if not rest.strip().isdigit():
            raise ValueError(f"bad shape {spec!r}: expected triangle:SEED with a non-negative integer SEED")
        return random_triangle(int(rest))
    if kind == "rectangle":
        dims = rest.lower().split("x")
        if len(dims) != 2:
            raise ValueError(f"bad shape {spec!r}: expected rectangle:WxH, e.g. rectangle:40x20")
        w = _parse_float(dims[0], "width", spec)
        h = _parse_float(dims[1], "height", spec)
        if w <= 0 or h <= 0:
            raise ValueError(f"bad shape {spec!r}: width and height must be positive")
        return rectangle(w, h, name=spec)
    if kind == "polygon":
        tokens = [t for t in rest.strip().rstrip(";").split(";")]
        if not rest.strip() or any(not t.strip() for t in tokens):
            raise ValueError(f"bad shape {spec!r}: expected polygon:x1,y1;x2,y2;... (mm)")
        pts = []
        for t in tokens:
            xy = t.split(",")
            if len(xy) != 2:
                raise ValueError(f"bad shape {spec!r}: vertex {t.strip()!r} is not an x,y pair")
            pts.append((_parse_float(xy[0], "coordinate", spec), _parse_float(xy[1], "coordinate", spec)))
        return make_shape(pts, name=spec)
    if spec.lower().endswith(".json") or os.path.isfile(spec):
        return _load_shape_json(spec)
    raise ValueError(f"unknown shape {spec!r}; use allen-key, triangle:SEED, rectangle:WxH, "
                     f"polygon:x1,y1;x2,y2;... or a .json file")


def _load_shape_json(path: str) -> Shape:
    if not os.path.isfile(path):
        raise ValueError(f"shape file {path!r} does not exist")
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
    except UnicodeDecodeError:
        raise ValueError(f"shape file {path!r} is not UTF-8 text") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"shape file {path!r} is not valid JSON: {exc.msg} at line {exc.lineno}") from None
    if not isinstance(data, dict) or "vertices" not in data:
        raise ValueError(f"shape file {path!r}: expected an object with a \"vertices\" list")
    unknown = set(data) - {"vertices", "thickness_mm", "density_kg_m3", "name"}
    if unknown:
        raise ValueError(f"shape file {path!r}: unknown key(s) {', '.join(sorted(unknown))}")
    verts = data["vertices"]
    if not isinstance(verts, list) or not all(isinstance(p, (list, tuple)) and len(p) == 2 for p in verts):
        raise ValueError(f"shape file {path!r}: \"vertices\" must be a list of [x, y] pairs")
    if not all(isinstance(c, (int, float)) and not isinstance(c, bool) for p in verts for c in p):
        raise ValueError(f"shape file {path!r}: vertex coordinates must be numbers")
    for key in ("thickness_mm", "density_kg_m3"):
        v = data.get(key)
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float))):
            raise ValueError(f"shape file {path!r}: \"{key}\" must be a number, got {json.dumps(v)}")
    return make_shape(verts, name=path,
                      thickness_mm=data.get("thickness_mm", DEFAULT_THICKNESS_MM),
                      density_kg_m3=data.get("density_kg_m3", STEEL_DENSITY_KG_M3))


# ----------------------------------------------------------------------------------------------
# fitting in the tray
# ----------------------------------------------------------------------------------------------

def _extent_over_rotations(shape: Shape, n_angles: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    theta = np.linspace(0.0, math.pi, n_angles, endpoint=False)
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    vx, vy = shape.vertices[:, 0], shape.vertices[:, 1]
    x = c * vx - s * vy
    y = s * vx + c * vy
    return theta, np.ptp(x, axis=1), np.ptp(y, axis=1)


def fits_in_tray(shape: Shape, tray_x_mm: float, tray_y_mm: float, n_angles: int = 3600) -> bool:
    """True if some rotation of ``shape`` fits strictly inside a ``tray_x_mm`` x ``tray_y_mm`` tray.

    Checked on ``n_angles`` rotations in [0, pi) (the bounding box has period pi); "strictly" means
    the bounding box is smaller than the tray in both directions, so the shape can also move.
    """
    _, w, h = _extent_over_rotations(shape, n_angles)
    return bool(np.any((w < tray_x_mm) & (h < tray_y_mm)))


def check_fits(shape: Shape, tray_x_mm: float, tray_y_mm: float) -> bool:
    """Raise :class:`ValueError` (one line) unless some rotation of ``shape`` fits in the tray.

    Returns True when it fits. See :func:`fits_in_tray`.
    """
    for label, val in (("tray x size", tray_x_mm), ("tray y size", tray_y_mm)):
        if not (isinstance(val, (int, float, np.floating, np.integer)) and math.isfinite(val) and val > 0):
            raise ValueError(f"{label} must be a positive number of mm, got {val!r}")
    if not fits_in_tray(shape, tray_x_mm, tray_y_mm):
        _, w, h = _extent_over_rotations(shape, 3600)
        raise ValueError(f"shape {shape.name!r} ({w[0]:.1f} x {h[0]:.1f} mm) does not fit in the "
                         f"{tray_x_mm:g} x {tray_y_mm:g} mm tray at any rotation")
    return True
