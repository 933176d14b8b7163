"""What every tilt engine shares (no engine imported here): the tilt-time ramp's schedule, the test
of a valid start or landing, and the check of a batch of poses. :mod:`transition_builder.sim`
(PyBullet) and :mod:`transition_builder.planar` (the planar engine) both use them, so both engines
ramp, accept and refuse poses alike.
"""
from __future__ import annotations

import math

import numpy as np

from transition_builder.sampling import is_collision_free

__all__ = ["ramp_fractions", "valid_start", "check_poses"]


def ramp_fractions(tilt_time_s: float, check_interval_s: float) -> np.ndarray:
    """The tilt-time ramp's schedule: the fraction of the full tilt set for each rest-test interval.

    The tray turns from level to its tilt linearly in ``tilt_time_s``; interval ``i`` (of length
    ``check_interval_s``) takes the slope at its midpoint, ``min((i + 1/2) dt / tilt_time, 1)``, for
    ``i < k = ceil(tilt_time / dt)``, and the full tilt from interval ``k`` on (docs/simulator.md,
    "The tilt's own motion"). The rest test starts at interval ``k``.

    Parameters
    ----------
    tilt_time_s : float
        Time from level to the full tilt (s); 0 is an instant tilt.
    check_interval_s : float
        The rest test's interval ``dt`` (s), > 0.

    Returns
    -------
    numpy.ndarray
        ``k + 1`` fractions in (0, 1], the last exactly 1 (``k`` the ramp's intervals); empty for an
        instant tilt.

    Examples
    --------
    >>> ramp_fractions(0.35, 0.1).round(4).tolist()
    [0.1429, 0.4286, 0.7143, 1.0, 1.0]
    >>> ramp_fractions(0.0, 0.1).size
    0
    """
    if not (check_interval_s > 0 and math.isfinite(check_interval_s)):
        raise ValueError(f"check_interval_s must be a positive number, got {check_interval_s}")
    if not (tilt_time_s >= 0 and math.isfinite(tilt_time_s)):
        raise ValueError(f"tilt_time_s must be a number >= 0, got {tilt_time_s}")
    k = int(math.ceil(tilt_time_s / check_interval_s - 1e-9))
    if k <= 0:
        return np.zeros(0)
    out = np.ones(k + 1)
    for i in range(k):
        out[i] = min((i + 0.5) * check_interval_s / tilt_time_s, 1.0)
    return out


def valid_start(scene, poses) -> np.ndarray:
    """True for every pose that is finite and whose outline lies inside the tray (collision-free).

    An outline may poke ``settings.escape_tolerance_mm`` into a wall: rest poses sit in contact
    (a few hundredths of a millimetre of penetration) and must be valid starts of the next tilt.
    """
    return is_collision_free(scene.shape, poses, scene.tray_x_mm, scene.tray_y_mm,
                             margin_mm=-scene.settings.escape_tolerance_mm)


def check_poses(poses) -> np.ndarray:
    """``poses`` as a C-contiguous ``(n, 3)`` float array (one pose ``(3,)`` becomes one row); one-line
    ValueError for any other shape."""
    p = np.asarray(poses, dtype=np.float64)
    if p.ndim == 1 and p.shape == (3,):
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"poses must be an (n, 3) array of (x_mm, y_mm, theta_rad); got shape {p.shape}")
    return np.ascontiguousarray(p)
