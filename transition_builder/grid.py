"""Pose grids: pose (x, y, theta) <-> voxel index.

The report grid is the paper's entropy grid (Mannam et al., Sec. III-B and IV): uniform bins over
``[0, a] x [0, b] x [0, 2*pi/k)`` where ``a x b`` is the tray's inner size and ``k`` the shape's
rotational symmetry order -- poses that differ by a symmetry rotation are the same physical state.

Theta bins and ``theta_offset``
-------------------------------
With ``G`` theta bins of width ``w = (2*pi/k) / G`` and offset ``o``, a pose's orientation bin is

    j = floor(((theta + o) mod (2*pi/k)) / w),

so bin ``j`` covers ``[j*w - o, (j+1)*w - o)`` (modulo ``2*pi/k``): the bin edges sit at
``-o + j*w``. The default ``o = w/2`` (``theta_offset=None``) puts the orientation 0 -- and so
every axis direction 0, 90, 180, 270 degrees that is a multiple of ``w`` -- at a bin *centre*:
parts come to rest against a wall at exactly those angles, and an edge there makes the entropy
flip with round-off (docs/commands.md). ``theta_offset=0`` gives the paper's edges ``[0, w), [w, 2w), ...``.

The voxel index is ``(ix * ny + iy) * ntheta + itheta`` (C order over ``(x, y, theta)``).
``x == a`` (and ``y == b``) fall in the last bin.
"""
from __future__ import annotations

import math
import re

import numpy as np

from kruskal_markov.validation import check_int

__all__ = ["DEFAULT_GRID", "ReportGrid", "parse_grid"]

#: the paper's simulation grid (4 x 4 x 4 = 64 voxels).
DEFAULT_GRID = "4x4x4"

# Poses may sit this far (relative to the tray size) outside [0, a] from round-off; clipped.
_EDGE_TOL = 1e-6


def parse_grid(text: str) -> tuple[int, int, int]:
    """Parse ``"AxBxG"`` (e.g. ``"4x4x4"``) into three positive bin counts.

    Parameters
    ----------
    text : str
        ``AxBxG``: bins in x, in y and in theta.

    Returns
    -------
    tuple of int
        ``(A, B, G)``; a one-line ValueError on anything else.

    Examples
    --------
    >>> parse_grid("4x4x4")
    (4, 4, 4)
    """
    if not isinstance(text, str):
        raise ValueError(f"bad grid {text!r}: expected AxBxG, e.g. 4x4x4")
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m:
        raise ValueError(f"bad grid {text!r}: expected AxBxG with positive integers, e.g. 4x4x4")
    dims = tuple(int(g) for g in m.groups())
    if min(dims) < 1:
        raise ValueError(f"bad grid {text!r}: every bin count must be at least 1")
    if math.prod(dims) > 2 ** 40:
        raise ValueError(f"bad grid {text!r}: too many voxels")
    return dims


class ReportGrid:
    """Uniform voxel grid over the tray's pose space, theta reduced modulo the symmetry order.

    Parameters
    ----------
    tray_x_mm, tray_y_mm : float
        Inner tray size ``a x b`` (mm); x bins cover ``[0, a]``, y bins ``[0, b]``.
    nx, ny, ntheta : int
        Bin counts.
    symmetry_order : int, default 1
        Rotational symmetry order ``k`` of the shape; theta is reduced modulo ``2*pi/k``.
    theta_offset : float or None
        Shift of the theta bin edges (radians, see the module docstring). None (default) is half
        a bin, which centres the bins on the tray's axes; 0 gives the paper's edges.
    """

    def __init__(self, tray_x_mm: float, tray_y_mm: float, nx: int, ny: int, ntheta: int,
                 symmetry_order: int = 1, theta_offset: float | None = None):
        for label, val in (("tray x size", tray_x_mm), ("tray y size", tray_y_mm)):
            if not (np.isscalar(val) and np.isfinite(val) and val > 0):
                raise ValueError(f"{label} must be a positive number of mm, got {val!r}")
        for label, val in (("nx", nx), ("ny", ny), ("ntheta", ntheta), ("symmetry_order", symmetry_order)):
            check_int(val, f"grid {label}", lo=1)
        self.tray_x_mm = float(tray_x_mm)
        self.tray_y_mm = float(tray_y_mm)
        self.nx, self.ny, self.ntheta = int(nx), int(ny), int(ntheta)
        self.symmetry_order = int(symmetry_order)
        self.theta_period = 2.0 * math.pi / self.symmetry_order
        self.theta_width = self.theta_period / self.ntheta
        if theta_offset is None:
            theta_offset = 0.5 * self.theta_width
        if not (np.isscalar(theta_offset) and np.isfinite(theta_offset)):
            raise ValueError(f"theta offset must be a finite number of radians, got {theta_offset!r}")
        self.theta_offset = float(theta_offset)

    @classmethod
    def from_spec(cls, spec: str, tray_x_mm: float, tray_y_mm: float, symmetry_order: int = 1,
                  theta_offset: float | None = None) -> ReportGrid:
        """Build from an ``"AxBxG"`` string (see :func:`parse_grid`)."""
        return cls(tray_x_mm, tray_y_mm, *parse_grid(spec), symmetry_order=symmetry_order,
                   theta_offset=theta_offset)

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(nx, ny, ntheta)``."""
        return (self.nx, self.ny, self.ntheta)

    @property
    def n_voxels(self) -> int:
        """Number of voxels ``nx * ny * ntheta``."""
        return self.nx * self.ny * self.ntheta

    def to_dict(self) -> dict:
        """JSON-able description (for logs and content hashes)."""
        return {"tray_x_mm": self.tray_x_mm, "tray_y_mm": self.tray_y_mm, "nx": self.nx, "ny": self.ny,
                "ntheta": self.ntheta, "symmetry_order": self.symmetry_order,
                "theta_offset": self.theta_offset}

    def __repr__(self) -> str:
        return (f"ReportGrid({self.tray_x_mm:g} x {self.tray_y_mm:g} mm, {self.nx}x{self.ny}x{self.ntheta}, "
                f"symmetry {self.symmetry_order}, theta_offset {self.theta_offset:.6g})")

    def reduce_theta(self, theta) -> np.ndarray:
        """Theta modulo the symmetry period ``2*pi/k``, in ``[0, 2*pi/k)``."""
        t = np.mod(np.asarray(theta, dtype=np.float64), self.theta_period)
        return np.where(t >= self.theta_period, 0.0, t)  # np.mod may round up to the period

    def bin_indices(self, poses) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per-axis bin indices ``(ix, iy, itheta)`` of an (n, 3) array of poses (int64 each)."""
        p = np.asarray(poses, dtype=np.float64)
        if p.ndim == 1:
            p = p[None, :]
        if p.ndim != 2 or p.shape[1] != 3:
            raise ValueError(f"poses must be an (n, 3) array of (x, y, theta), got shape {p.shape}")
        if not np.all(np.isfinite(p)):
            bad = int(np.flatnonzero(~np.all(np.isfinite(p), axis=1))[0])
            raise ValueError(f"pose {bad} is not finite (NaN or infinity); drop faulted trials first")
        ix = self._axis_bins(p[:, 0], self.tray_x_mm, self.nx, "x")
        iy = self._axis_bins(p[:, 1], self.tray_y_mm, self.ny, "y")
        u = np.mod(p[:, 2] + self.theta_offset, self.theta_period) / self.theta_width
        it = np.floor(u).astype(np.int64) % self.ntheta
        return ix, iy, it

    @staticmethod
    def _axis_bins(v: np.ndarray, size: float, n: int, label: str) -> np.ndarray:
        tol = _EDGE_TOL * size
        if v.size and (v.min() < -tol or v.max() > size + tol):
            bad = int(np.flatnonzero((v < -tol) | (v > size + tol))[0])
            raise ValueError(f"pose {bad}: {label} = {v[bad]:.6g} mm lies outside the tray [0, {size:g}]")
        idx = np.floor(v * (n / size)).astype(np.int64)
        return np.clip(idx, 0, n - 1)

    def voxel_index(self, poses) -> np.ndarray:
        """Voxel index (int64, shape (n,)) of each pose; ``(ix * ny + iy) * ntheta + itheta``."""
        ix, iy, it = self.bin_indices(poses)
        return (ix * self.ny + iy) * self.ntheta + it

    def unravel(self, index) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Inverse of the index layout: voxel index -> ``(ix, iy, itheta)``."""
        i = np.asarray(index, dtype=np.int64)
        if i.size and (i.min() < 0 or i.max() >= self.n_voxels):
            raise ValueError(f"voxel index out of range [0, {self.n_voxels})")
        return np.unravel_index(i, self.shape)

    def centres(self, index) -> np.ndarray:
        """Centre pose (x, y, theta in [0, 2*pi/k)) of each voxel index, shape (n, 3)."""
        ix, iy, it = self.unravel(np.atleast_1d(index))
        x = (ix + 0.5) * self.tray_x_mm / self.nx
        y = (iy + 0.5) * self.tray_y_mm / self.ny
        th = self.reduce_theta((it + 0.5) * self.theta_width - self.theta_offset)
        return np.stack([x, y, th], axis=-1)

    def counts(self, poses) -> np.ndarray:
        """Histogram of poses over the voxels (int64, length ``n_voxels``)."""
        return np.bincount(self.voxel_index(poses), minlength=self.n_voxels).astype(np.int64)

    def entropy_bits(self, poses) -> float:
        """Plug-in Shannon entropy (bits) of the poses' voxel histogram (0 for no poses)."""
        from kruskal_markov.entropy import histogram_entropy_bits

        p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
        if len(p) == 0:
            return 0.0
        return histogram_entropy_bits(self.counts(p))
