"""Process noise: a small random displacement of the part before every tilt.

A real tray is not a perfectly repeatable machine: it vibrates while it is tilted and levelled,
the part bounces a little when the tray stops, and the friction is not the same everywhere (the
paper varied the friction over the tray to make its simulation less ideal). The physics engine,
in contrast, is deterministic: the same start pose and tilt always give the same rest pose. The
noise model here adds the missing randomness in one place, with one meaning for direct
simulation (:func:`analysis.montecarlo.run_direct`) and for model building.

``pose:SIGMA_MM,SIGMA_DEG`` moves the part, **before every tilt**, by ``dx, dy ~ N(0, SIGMA_MM)``
(millimetres, in the tray frame) and turns it by ``dtheta ~ N(0, SIGMA_DEG)`` (degrees) about its
centroid. A displacement that would push the part into a wall is redrawn (the tray cannot push a
part through its own wall): a candidate is accepted when its penetration, the largest distance by
which a vertex lies outside the tray rectangle, is at most the current pose's penetration plus
:data:`CONTACT_TOLERANCE_MM`; a part resting against a wall can therefore move away from it or
along it, but not deeper into it. After :data:`MAX_REDRAWS` rejected redraws the pose is kept
unperturbed. ``none`` is no noise; ``pose:0,0`` is exactly ``none`` (no random numbers are drawn
and results are bit-identical).

The noise is not part of a :class:`~transition_builder.scene.Scene` (nor of its content hash):
whoever caches results computed with noise keys them by ``str(noise)`` as well. Draws come from
:func:`noise_rng` with their own stream number :data:`NOISE_STREAM`, keyed by a seed and integer
keys (e.g. trial and step), so they never coincide with the start-pose or sequence streams and do
not depend on how trials are split between workers.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from kruskal_markov.validation import check_number, is_int

__all__ = [
    "CONTACT_TOLERANCE_MM",
    "MAX_REDRAWS",
    "NOISE_KINDS",
    "NOISE_STREAM",
    "NoiseSpec",
    "noise_rng",
    "parse_noise",
    "penetration_mm",
    "perturb_pose",
    "perturb_poses",
    "check_noise_for_tray",
]

#: first entry of every noise generator's seed sequence (other streams use other numbers).
NOISE_STREAM = 7
#: a candidate may lie this much deeper in a wall than the pose it perturbs (mm): rest poses
#: touch walls with a few hundredths of a millimetre of penetration.
CONTACT_TOLERANCE_MM = 0.02
#: redraws of a rejected candidate before the pose is kept unperturbed.
MAX_REDRAWS = 100
#: the noise kinds, in the order of :func:`parse_noise`'s message.
NOISE_KINDS = ("none", "pose")

_FORMATS = "none or pose:SIGMA_MM,SIGMA_DEG (non-negative numbers, e.g. pose:0.5,1)"
_TWO_PI = 2.0 * math.pi


def _short(v: float) -> str:
    """Shortest exact text of ``v``: ``:g`` when it round-trips, else ``repr``."""
    g = f"{v:g}"
    return g if float(g) == v else repr(v)


@dataclass(frozen=True)
class NoiseSpec:
    """A process-noise model (see the module docstring).

    Parameters
    ----------
    kind : str
        ``"none"`` or ``"pose"``.
    sigma_mm : float, default 0
        Standard deviation of the x and y displacement (mm), ``kind="pose"`` only.
    sigma_deg : float, default 0
        Standard deviation of the rotation (degrees), ``kind="pose"`` only.
    """

    kind: str
    sigma_mm: float = 0.0
    sigma_deg: float = 0.0

    def __post_init__(self):
        if self.kind not in NOISE_KINDS:
            raise ValueError(f"unknown noise kind {self.kind!r}; expected {_FORMATS}")
        for name in ("sigma_mm", "sigma_deg"):
            v = getattr(self, name)
            object.__setattr__(self, name, check_number(v, f"noise {name}", lo=0))
        if self.kind == "none" and (self.sigma_mm or self.sigma_deg):
            raise ValueError("noise kind 'none' takes no sigmas; use pose:SIGMA_MM,SIGMA_DEG")

    @property
    def is_zero(self) -> bool:
        """True when the noise changes nothing (``none``, or ``pose`` with both sigmas 0)."""
        return self.kind == "none" or (self.sigma_mm == 0.0 and self.sigma_deg == 0.0)

    def to_dict(self) -> dict:
        """The canonical form, JSON-able: a zero noise is ``{"kind": "none", ...}`` whatever its spelling."""
        if self.is_zero:
            return {"kind": "none", "sigma_mm": 0.0, "sigma_deg": 0.0}
        return {"kind": self.kind, "sigma_mm": self.sigma_mm, "sigma_deg": self.sigma_deg}

    def __str__(self) -> str:
        """The canonical spec text: ``none`` (also for ``pose:0,0``) or ``pose:0.5,1``."""
        if self.is_zero:
            return "none"
        return f"pose:{_short(self.sigma_mm)},{_short(self.sigma_deg)}"


def parse_noise(spec) -> NoiseSpec:
    """Parse a noise spec: None or ``"none"`` (no noise), ``"pose:SIGMA_MM,SIGMA_DEG"``, or a NoiseSpec.

    Raises a one-line ValueError naming the accepted formats.

    Parameters
    ----------
    spec : str, NoiseSpec or None
        The spec.

    Returns
    -------
    NoiseSpec
        ``pose:0,0`` parses to a zero noise (``is_zero``), printed as ``none``.


    Examples
    --------
    >>> str(parse_noise("pose:0.5, 1"))
    'pose:0.5,1'
    >>> parse_noise("pose:0,0").is_zero
    True
    """
    if spec is None:
        return NoiseSpec("none")
    if isinstance(spec, NoiseSpec):
        return spec
    text = spec.strip().lower() if isinstance(spec, str) else ""   # not text: a bad spec below
    if text == "none":
        return NoiseSpec("none")
    kind, sep, rest = text.partition(":")
    parts = [p.strip() for p in rest.split(",")]
    if kind.strip() != "pose" or not sep or len(parts) != 2:
        raise ValueError(f"bad noise spec {spec!r}: expected {_FORMATS}")
    try:
        sigma_mm, sigma_deg = (float(p) for p in parts)
    except ValueError:
        raise ValueError(f"bad noise spec {spec!r}: expected {_FORMATS}") from None
    if not all(math.isfinite(v) and v >= 0 for v in (sigma_mm, sigma_deg)):
        raise ValueError(f"bad noise spec {spec!r}: expected {_FORMATS}")
    return NoiseSpec("pose", sigma_mm, sigma_deg)


#: the largest noise a tray takes: a standard deviation of a quarter of the tray's shorter side in
#: x and y (beyond it most nudges would push the part into a wall and be dropped, so the noise
#: would silently do nothing) and half a turn in theta (beyond it the turn is uniform anyway).
MAX_SIGMA_TRAY_SHARE = 0.25
MAX_SIGMA_DEG = 180.0


def check_noise_for_tray(noise, tray_x_mm: float, tray_y_mm: float) -> NoiseSpec:
    """``noise`` parsed, if the tray can carry it out; else a one-line ValueError with the bound.

    Parameters
    ----------
    noise : NoiseSpec or str
        The process noise.
    tray_x_mm, tray_y_mm : float
        The tray's inner size (mm).

    Returns
    -------
    NoiseSpec
        The parsed noise.

    Examples
    --------
    >>> str(check_noise_for_tray("pose:0.5,1", 200.0, 200.0))
    'pose:0.5,1'
    >>> check_noise_for_tray("pose:1e5,0", 200.0, 200.0)
    Traceback (most recent call last):
    ...
    ValueError: noise pose:100000,0 is too large for this tray: sigma_mm must be at most 50 mm, a quarter of its shorter side (200 mm)
    """
    spec = parse_noise(noise)
    side = min(float(tray_x_mm), float(tray_y_mm))
    bound_mm = MAX_SIGMA_TRAY_SHARE * side
    if spec.sigma_mm > bound_mm:
        raise ValueError(f"noise {spec} is too large for this tray: sigma_mm must be at most {_short(bound_mm)} mm, "
                         f"a quarter of its shorter side ({_short(side)} mm)")
    if spec.sigma_deg > MAX_SIGMA_DEG:
        raise ValueError(f"noise {spec} is too large: sigma_deg must be at most {_short(MAX_SIGMA_DEG)} degrees "
                         "(half a turn)")
    return spec


def noise_rng(seed, *keys) -> np.random.Generator:
    """The noise generator for ``seed`` and integer ``keys`` (e.g. trial, step).

    ``numpy.random.default_rng([NOISE_STREAM, seed, *keys])``: independent of every other stream
    of the same seed, and of how the work is split. Every key must be a non-negative integer.
    """
    out = [NOISE_STREAM]
    for k in (seed, *keys):
        if not is_int(k) or k < 0:
            raise ValueError(f"noise seed and keys must be non-negative integers, got {k!r}")
        out.append(int(k))
    return np.random.default_rng(out)


def penetration_mm(scene, pose) -> float:
    """Largest distance (mm) by which a vertex of the placed shape lies outside the tray; 0 if none."""
    v = scene.shape.placed(np.asarray(pose, dtype=np.float64))
    x, y = v[:, 0], v[:, 1]
    return float(max(0.0, -x.min(), x.max() - scene.tray_x_mm, -y.min(), y.max() - scene.tray_y_mm))


def perturb_pose(scene, pose, noise, rng) -> tuple[np.ndarray, int]:
    """Perturb one pose by the process noise; return ``(new_pose, redraws)``.

    Parameters
    ----------
    scene : transition_builder.scene.Scene
        Gives the shape and the tray size.
    pose : array_like (3,)
        ``(x_mm, y_mm, theta_rad)``.
    noise : NoiseSpec or str
    rng : numpy.random.Generator
        Source of the draws (see :func:`noise_rng`).

    Returns
    -------
    new_pose : ndarray (3,)
        The perturbed pose, theta in ``[0, 2 pi)``. For a zero noise or a pose that is not finite
        the pose itself (same values, nothing drawn); if every candidate was rejected, the pose
        unperturbed.
    redraws : int
        Rejected candidates: 0 if the first draw was accepted, ``MAX_REDRAWS + 1`` if all were
        rejected (the pose is then unperturbed).
    """
    noise = parse_noise(noise)
    p = np.array(pose, dtype=np.float64).reshape(3)
    if noise.is_zero or not np.all(np.isfinite(p)):
        return p, 0
    scale = np.array([noise.sigma_mm, noise.sigma_mm, math.radians(noise.sigma_deg)])
    limit = penetration_mm(scene, p) + CONTACT_TOLERANCE_MM
    for attempt in range(MAX_REDRAWS + 1):
        q = p + rng.standard_normal(3) * scale
        if penetration_mm(scene, q) <= limit:
            th = math.fmod(q[2], _TWO_PI)
            if th < 0.0:
                th += _TWO_PI
            q[2] = th if th < _TWO_PI else 0.0
            return q, attempt
    return p, MAX_REDRAWS + 1


def perturb_poses(scene, poses, noise, rngs) -> np.ndarray:
    """Perturb every row of ``poses`` (n, 3) with its own generator ``rngs[i]`` (see :func:`perturb_pose`).

    Rows that are not finite (faulted trials) stay as they are and draw nothing. Returns a new
    (n, 3) array.
    """
    noise = parse_noise(noise)
    p = np.array(poses, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"poses must be an (n, 3) array of (x_mm, y_mm, theta_rad); got shape {p.shape}")
    rngs = list(rngs)
    if len(rngs) != len(p):
        raise ValueError(f"need one generator per pose: {len(p)} poses, {len(rngs)} generators")
    if noise.is_zero:
        return p
    finite = np.all(np.isfinite(p), axis=1)
    for i in np.flatnonzero(finite):
        p[i] = perturb_pose(scene, p[i], noise, rngs[i])[0]
    return p
