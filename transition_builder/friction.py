"""Floor friction: a uniform Coulomb coefficient or a seeded spatially varying map (paper, Fig. 5).

Friction spec strings (``--friction``, docs/commands.md):

``0.3``
    A uniform Coulomb coefficient (metal on metal is about 0.2-0.4; it must be below
    ``tan(tilt)`` for parts to slide at all: ``tan 30 deg = 0.577``).
``map:LEVEL:SEED``
    A spatially varying floor (paper, section "Varying the friction noise"): ``LEVEL`` is ``low``,
    ``medium`` or ``high`` and sets the amplitude of the variation, ``SEED`` an integer.

The map is a smooth random field on a grid of square floor tiles (the simulator gives every tile its
own ``lateralFriction``): white noise from ``numpy.random.default_rng([seed, 0x46524943])``, smoothed
with a Gaussian of :data:`MAP_CORRELATION_MM` standard deviation (periodic-free, truncated at 3
sigma), scaled to zero mean and unit maximum magnitude, then ``mu = mu0 + amplitude * field``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["FrictionSpec", "parse_friction", "friction_map", "DEFAULT_MU", "MAP_LEVELS",
           "MAP_TILE_MM", "MAP_CORRELATION_MM"]

#: default uniform coefficient: dry steel on steel sliding, below tan(30 deg) = 0.577.
DEFAULT_MU = 0.3
#: amplitude (largest deviation of mu from mu0) of each map level.
MAP_LEVELS = {"low": 0.05, "medium": 0.12, "high": 0.2}
#: side of a floor tile of a friction map (mm); the tray is covered by ceil(size / tile) tiles.
MAP_TILE_MM = 10.0
#: correlation length (Gaussian smoothing sigma, mm) of a friction map.
MAP_CORRELATION_MM = 25.0
_MAP_SALT = 0x46524943


@dataclass(frozen=True)
class FrictionSpec:
    """A parsed friction spec: ``kind`` is ``"uniform"`` (``mu``) or ``"map"`` (``level``, ``seed``, base ``mu``)."""

    kind: str
    mu: float = DEFAULT_MU
    level: str | None = None
    seed: int | None = None

    def __str__(self) -> str:
        if self.kind == "uniform":
            return f"{self.mu:g}"
        return f"map:{self.level}:{self.seed}"

    def to_dict(self) -> dict:
        return {"kind": self.kind, "mu": self.mu, "level": self.level, "seed": self.seed}


def parse_friction(spec, base_mu: float = DEFAULT_MU) -> FrictionSpec:
    """Parse a friction spec (a number or ``map:LEVEL:SEED``); one-line :class:`ValueError` if malformed.

    ``base_mu`` is the mean coefficient of a map.

    Parameters
    ----------
    spec : float, str or FrictionSpec
        A Coulomb coefficient (``0.3``) or ``map:low|medium|high:SEED``.
    base_mu : float, default 0.3
        The mean coefficient of a map.

    Returns
    -------
    FrictionSpec
    """
    if isinstance(spec, FrictionSpec):
        return spec
    if isinstance(spec, (int, float)) and not isinstance(spec, bool):
        text = repr(float(spec))
    elif isinstance(spec, str):
        text = spec.strip()
    else:
        raise ValueError(f"friction must be a number or 'map:LEVEL:SEED', got {spec!r}")
    if text.lower().startswith("map:"):
        parts = text.split(":")
        if len(parts) != 3:
            raise ValueError(f"bad friction map {text!r}: expected map:LEVEL:SEED, e.g. map:low:3")
        level = parts[1].strip().lower()
        if level not in MAP_LEVELS:
            raise ValueError(f"bad friction map {text!r}: level must be one of {', '.join(MAP_LEVELS)}")
        try:
            seed = int(parts[2])
        except ValueError:
            raise ValueError(f"bad friction map {text!r}: seed must be an integer") from None
        if seed < 0:
            raise ValueError(f"bad friction map {text!r}: seed must be >= 0")
        _check_mu(base_mu, "base friction")
        if base_mu - MAP_LEVELS[level] <= 0:
            raise ValueError(f"friction map {text!r}: base mu {base_mu} is too small for level {level}")
        return FrictionSpec("map", float(base_mu), level, seed)
    try:
        mu = float(text)
    except ValueError:
        raise ValueError(f"bad friction {text!r}: expected a number (e.g. 0.3) or map:LEVEL:SEED") from None
    _check_mu(mu, "friction")
    return FrictionSpec("uniform", mu)


def _check_mu(mu, what):
    if not (isinstance(mu, (int, float)) and math.isfinite(mu) and 0.0 <= mu <= 5.0):
        raise ValueError(f"bad {what} {mu!r}: a Coulomb coefficient must be a finite number in [0, 5]")


def _gaussian_kernel(sigma_cells: float) -> np.ndarray:
    half = max(1, int(math.ceil(3.0 * sigma_cells)))
    k = np.exp(-0.5 * (np.arange(-half, half + 1) / sigma_cells) ** 2)
    return k / k.sum()


def friction_map(spec: FrictionSpec, tray_x_mm: float, tray_y_mm: float,
                 tile_mm: float = MAP_TILE_MM) -> tuple[np.ndarray, float]:
    """The tile coefficients of a friction spec over a tray.

    Returns ``(mu, tile)`` where ``mu[i, j]`` is the coefficient of the tile covering
    ``[i*tile, (i+1)*tile] x [j*tile, (j+1)*tile]`` (tray frame, mm; i along x). A uniform spec
    gives a single tile covering the tray (``tile`` is then the larger tray side).
    """
    spec = parse_friction(spec)
    if spec.kind == "uniform":
        return np.full((1, 1), spec.mu), float(max(tray_x_mm, tray_y_mm))
    nx = int(math.ceil(tray_x_mm / tile_mm - 1e-9))
    ny = int(math.ceil(tray_y_mm / tile_mm - 1e-9))
    rng = np.random.default_rng([spec.seed, _MAP_SALT])
    kern = _gaussian_kernel(MAP_CORRELATION_MM / tile_mm)
    pad = len(kern) // 2
    noise = rng.standard_normal((nx + 2 * pad, ny + 2 * pad))
    sm = np.apply_along_axis(lambda r: np.convolve(r, kern, mode="valid"), 0, noise)
    sm = np.apply_along_axis(lambda r: np.convolve(r, kern, mode="valid"), 1, sm)
    sm = sm - sm.mean()
    sm = sm / np.max(np.abs(sm))
    mu = spec.mu + MAP_LEVELS[spec.level] * sm
    return mu, float(tile_mm)
