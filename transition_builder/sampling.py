"""Start poses: uniform random samples of the collision-free configuration space.

The free configuration space of a part in an empty rectangular tray is the set of poses
``(x, y, theta)`` at which the placed polygon lies inside the tray's inner rectangle. Because the
tray is convex, the polygon is inside iff every vertex is inside, so the test is exact.
Rejection sampling (draw ``theta`` uniform in ``[0, 2*pi)`` and ``x, y`` uniform in the tray;
keep the draw iff it is collision-free) gives exactly the uniform distribution on that set
(von Neumann 1951): the density in theta is proportional to the free area at that orientation.
"""
from __future__ import annotations

import math

import numpy as np

from kruskal_markov.validation import check_int
from transition_builder.shapes import Shape, check_fits

__all__ = ["is_collision_free", "sample_start_poses"]

# Give up when fewer than this fraction of draws is accepted (the shape barely fits).
_MIN_ACCEPTANCE = 1e-4
# At least this many draws before judging the acceptance rate.
_MIN_DRAWS_FOR_VERDICT = 200_000


def is_collision_free(shape: Shape, poses, tray_x_mm: float, tray_y_mm: float,
                      margin_mm: float = 0.0) -> np.ndarray:
    """True where the placed shape lies inside ``[margin, a - margin] x [margin, b - margin]``.

    ``poses`` is (n, 3); returns a boolean array of shape (n,). Non-finite poses are not free.
    """
    p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    finite = np.all(np.isfinite(p), axis=1)
    q = np.where(finite[:, None], p, 0.0)
    v = shape.placed(q)  # (n, m, 2)
    x, y = v[..., 0], v[..., 1]
    inside = ((x.min(axis=1) >= margin_mm) & (x.max(axis=1) <= tray_x_mm - margin_mm)
              & (y.min(axis=1) >= margin_mm) & (y.max(axis=1) <= tray_y_mm - margin_mm))
    return inside & finite


def sample_start_poses(shape: Shape, tray_x_mm: float, tray_y_mm: float, n: int, rng,
                       margin_mm: float = 0.0) -> np.ndarray:
    """Draw ``n`` poses uniformly from the collision-free configuration space (rejection sampling).

    Parameters
    ----------
    shape : Shape
    tray_x_mm, tray_y_mm : float
        Inner tray size (mm).
    n : int
        Number of poses.
    rng : numpy.random.Generator or int
        Source of randomness (an int is used as a seed). The result depends only on the
        generator's state, ``n`` and the arguments.
    margin_mm : float, default 0
        Required clearance between the part and the walls.

    Returns
    -------
    ndarray, shape (n, 3)
        Poses ``(x, y, theta)`` with theta in ``[0, 2*pi)``.

    Raises
    ------
    ValueError
        If the shape does not fit in the tray, or if the acceptance rate is practically zero.
    """
    check_int(n, "number of poses", lo=0)
    if not (np.isscalar(margin_mm) and math.isfinite(margin_mm) and margin_mm >= 0):
        raise ValueError(f"margin must be a non-negative number of mm, got {margin_mm!r}")
    check_fits(shape, tray_x_mm, tray_y_mm)
    if not isinstance(rng, np.random.Generator):
        rng = np.random.default_rng(rng)
    n = int(n)
    out = np.empty((n, 3), dtype=np.float64)
    filled = 0
    draws = accepted = 0
    while filled < n:
        need = n - filled
        rate = accepted / draws if accepted else 0.5  # acceptance rate so far (first guess 1/2)
        batch = int(min(max(1.2 * need / max(rate, 1e-3) + 16, 64), 1_000_000))
        cand = np.empty((batch, 3), dtype=np.float64)
        cand[:, 0] = rng.uniform(0.0, tray_x_mm, batch)
        cand[:, 1] = rng.uniform(0.0, tray_y_mm, batch)
        cand[:, 2] = rng.uniform(0.0, 2.0 * math.pi, batch)
        ok = cand[is_collision_free(shape, cand, tray_x_mm, tray_y_mm, margin_mm)]
        take = min(len(ok), need)
        out[filled:filled + take] = ok[:take]
        filled += take
        draws += batch
        accepted += len(ok)
        if filled < n and draws >= _MIN_DRAWS_FOR_VERDICT and accepted / draws < _MIN_ACCEPTANCE:
            raise ValueError(f"shape {shape.name!r} barely fits in the {tray_x_mm:g} x {tray_y_mm:g} mm tray: "
                             f"only {accepted} of {draws} random poses were collision-free")
    return out
