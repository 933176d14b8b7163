"""Snapping rest poses to representative states.

A landing pose joins the nearest existing representative within a tolerance *in the same report
cell and with the same wall contacts*, or it founds a new representative (docs/builder.md). The
tolerance is a normalised Euclidean ball: ``(dx/tol_mm)^2 + (dy/tol_mm)^2 + (dtheta/tol_rad)^2 <= 1``,
theta compared modulo the shape's symmetry period. The cell/contact condition is exact: the group
key ``cell * 256 + contacts`` enters the k-d tree as a fourth coordinate spaced far beyond the ball,
so a query never crosses groups.

Queries run on a :class:`scipy.spatial.cKDTree` over the representatives known at the last rebuild,
plus a brute-force scan of the few added since; the answer is the exact nearest either way, so the
result depends only on the order in which poses are offered, never on when the tree was rebuilt.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from transition_builder.grid import ReportGrid
from transition_builder.shapes import Shape

__all__ = ["PoseIndex", "wall_contacts"]

_GROUP_SPACING = 16.0   # in tolerance units; the ball has radius 1
_BIG = 1e12             # "non-periodic" box size for cKDTree's periodic-box argument
_MAX_TAIL = 256         # representatives added since the last tree rebuild, scanned by brute force


def wall_contacts(shape: Shape, poses, tray_x_mm: float, tray_y_mm: float, tol_mm: float,
                  flush_side: bool = False) -> np.ndarray:
    """Bitmask of the walls each pose touches within ``tol_mm``: 1 west, 2 east, 4 south, 8 north.

    With ``flush_side``, bits 4-7 (16 west ... 128 north) say, for a wall that two or more
    vertices touch (an edge lying flush, or nearly), which end of the touching set is closest to
    the wall: set when the closest vertex lies beyond the middle of the touching vertices along
    the wall. An edge a hair off flush (1e-4 rad on the allen key: its ends 0.006 mm apart in
    distance to the wall) rests on one end or the other, and the next tilt can tell the two apart.
    """
    p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    if len(p) == 0:
        return np.zeros(0, dtype=np.int64)
    v = shape.placed(p)
    x, y = v[..., 0], v[..., 1]
    walls = ((x, y), (tray_x_mm - x, y), (y, x), (tray_y_mm - y, x))   # (distance to wall, along it)
    out = np.zeros(len(p), dtype=np.int64)
    rows = np.arange(len(p))
    for bit, (dist, along) in enumerate(walls):
        touch = dist <= tol_mm
        out |= touch.any(axis=1).astype(np.int64) << bit
        if flush_side:
            n_touch = touch.sum(axis=1)
            mid = np.where(touch, along, 0.0).sum(axis=1) / np.maximum(n_touch, 1)
            closest = along[rows, np.argmin(dist, axis=1)]
            out |= ((n_touch >= 2) & (closest > mid)).astype(np.int64) << (bit + 4)
    return out


class PoseIndex:
    """Representative rest poses, with exact nearest-within-tolerance queries.

    Parameters
    ----------
    shape : Shape
    grid : ReportGrid
        The report grid; snapping never crosses one of its cells.
    tol_mm, tol_deg : float
        Snapping tolerance in x/y (mm) and theta (degrees).
    contact_tol_mm : float
        A vertex within this of a wall counts as touching it.
    use_contacts : bool
        Also require the same wall-contact signature.
    flush_side : bool
        Also require the same flush side (:func:`wall_contacts`).
    """

    def __init__(self, shape: Shape, grid: ReportGrid, tol_mm: float, tol_deg: float,
                 contact_tol_mm: float = 0.05, use_contacts: bool = True, flush_side: bool = False):
        self.shape = shape
        self.flush_side = bool(flush_side)
        self.grid = grid
        self.scale = np.array([1.0 / tol_mm, 1.0 / tol_mm, 1.0 / math.radians(tol_deg)])
        self.period = 2.0 * math.pi / shape.symmetry_order
        self.contact_tol_mm = float(contact_tol_mm)
        self.use_contacts = bool(use_contacts)
        self.box = np.array([_BIG, _BIG, self.period * self.scale[2], _BIG])
        self._buf = np.zeros((1024, 4))
        self._cells = np.zeros(1024, dtype=np.int64)
        self._n = 0
        self._tree = None
        self._tree_n = 0

    def __len__(self) -> int:
        return self._n

    @property
    def _points(self) -> np.ndarray:
        return self._buf[:self._n]

    @property
    def cells(self) -> np.ndarray:
        """Report cell of every representative."""
        return self._cells[:self._n]

    def embed(self, poses) -> tuple[np.ndarray, np.ndarray]:
        """Query coordinates ``(n, 4)`` and report cells ``(n,)`` of poses."""
        p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
        cells = self.grid.voxel_index(p)
        if self.use_contacts:
            contacts = wall_contacts(self.shape, p, self.grid.tray_x_mm, self.grid.tray_y_mm, self.contact_tol_mm,
                                     self.flush_side)
        else:
            contacts = np.zeros(len(p), dtype=np.int64)
        th = np.mod(p[:, 2], self.period)
        th = np.where(th >= self.period, 0.0, th)
        q = np.empty((len(p), 4))
        q[:, 0] = p[:, 0] * self.scale[0]
        q[:, 1] = p[:, 1] * self.scale[1]
        q[:, 2] = np.minimum(th * self.scale[2], self.box[2] * (1 - 1e-15))
        q[:, 3] = (cells * 256 + contacts) * _GROUP_SPACING
        return q, cells

    def add(self, poses) -> np.ndarray:
        """Append representatives; returns their indices."""
        q, cells = self.embed(poses)
        start, stop = self._n, self._n + len(q)
        if stop > len(self._buf):                      # amortised growth
            cap = max(stop, 2 * len(self._buf))
            self._buf = np.concatenate([self._buf[:start], np.zeros((cap - start, 4))])
            self._cells = np.concatenate([self._cells[:start], np.zeros(cap - start, dtype=np.int64)])
        self._buf[start:stop] = q
        self._cells[start:stop] = cells
        self._n = stop
        if self._n - self._tree_n > _MAX_TAIL:
            self._rebuild()
        return np.arange(start, stop)

    def move(self, indices, poses):
        """Move representatives ``indices`` to ``poses`` (same report cell and contacts expected)."""
        q, cells = self.embed(poses)
        idx = np.asarray(indices, dtype=np.int64)
        self._buf[idx] = q
        self._cells[idx] = cells
        self._rebuild()

    def compact(self):
        """Put the representatives added since the last rebuild into the k-d tree (before many
        queries; the answers are the same either way)."""
        if self._n > self._tree_n:
            self._rebuild()

    def _rebuild(self):
        self._tree = cKDTree(self._points.copy(), boxsize=self.box) if self._n else None
        self._tree_n = self._n

    def nearest_embedded(self, q: np.ndarray, workers: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """Nearest representative within tolerance of query coordinates ``q`` (from :meth:`embed`):
        ``(index or -1, distance in tolerance units or inf)``. ``workers``: threads of the k-d tree
        query (scipy's argument; -1: every core), the same answer for any number."""
        n = len(q)
        best = np.full(n, -1, dtype=np.int64)
        dist = np.full(n, np.inf)
        if self._tree is not None and n:
            d, i = self._tree.query(q, k=1, distance_upper_bound=1.0 + 1e-12, workers=workers)
            hit = np.isfinite(d)
            best[hit] = i[hit]
            dist[hit] = d[hit]
        if self._n > self._tree_n and n:
            tail = self._points[self._tree_n:]
            d2 = self.wrapped_norm(q[:, None, :] - tail[None, :, :])
            j = np.argmin(d2, axis=1)
            dj = d2[np.arange(n), j]
            better = (dj <= 1.0 + 1e-12) & (dj < dist)
            best[better] = self._tree_n + j[better]
            dist[better] = dj[better]
        return best, dist

    def nearest_among(self, queries, candidates, radius: float | None) -> np.ndarray:
        """For representatives ``queries``, the nearest of the representatives ``candidates``: in
        the same report cell and contact group within ``radius`` tolerance units (at most half the
        group spacing, so a match never crosses a group), or with ``radius=None`` the nearest pose
        in any cell and group. -1 where there is none."""
        if radius is not None and not 0 < radius <= _GROUP_SPACING / 2:
            raise ValueError(f"radius must be in (0, {_GROUP_SPACING / 2}] or None, got {radius!r}")
        queries = np.asarray(queries, dtype=np.int64)
        candidates = np.asarray(candidates, dtype=np.int64)
        out = np.full(len(queries), -1, dtype=np.int64)
        if len(queries) == 0 or len(candidates) == 0:
            return out
        if radius is None:
            tree = cKDTree(self._points[candidates, :3], boxsize=self.box[:3])
            _, i = tree.query(self._points[queries, :3], k=1)
            return candidates[i]
        tree = cKDTree(self._points[candidates], boxsize=self.box)
        d, i = tree.query(self._points[queries], k=1, distance_upper_bound=radius)
        hit = np.isfinite(d)
        out[hit] = candidates[i[hit]]
        return out

    def distance(self, poses_a, poses_b) -> np.ndarray:
        """Distance in tolerance units between paired poses (theta modulo the symmetry period);
        ``inf`` where the two lie in different report cells or contact groups."""
        qa, _ = self.embed(poses_a)
        qb, _ = self.embed(poses_b)
        return np.where(qa[:, 3] != qb[:, 3], np.inf, self.wrapped_norm(qa - qb))

    def wrapped_norm(self, diff: np.ndarray) -> np.ndarray:
        """Euclidean norm over the last axis of differences of query coordinates, theta wrapped
        around the symmetry period (the metric of the k-d tree's periodic box)."""
        diff = np.abs(diff)
        diff[..., 2] = np.minimum(diff[..., 2], self.box[2] - diff[..., 2])
        return np.sqrt((diff ** 2).sum(axis=-1))

    def snap(self, poses) -> np.ndarray:
        """Index of the nearest representative within tolerance (same cell and contacts), -1 if none."""
        q, _ = self.embed(poses)
        return self.nearest_embedded(q)[0]
