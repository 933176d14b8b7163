"""Floor friction: a uniform Coulomb coefficient, a static/kinetic pair, or a seeded spatially
varying map (paper, Fig. 5).

Friction spec strings (``--friction``, docs/commands.md):

``0.3``
    A uniform Coulomb coefficient, static and kinetic alike (metal on metal is about 0.2-0.4; it
    must be below ``tan(tilt)`` for parts to slide at all: ``tan 30 deg = 0.577``).
``MU_S/MU_K``
    A static and a kinetic coefficient (``0.61/0.47``: clean dry aluminium on mild steel, the
    handbook pair), ``MU_S >= MU_K``. A part at rest stays while the wrench that holds it lies inside
    the static limit surface and slides under the kinetic one (docs/simulator.md). ``0.3/0.3`` is
    ``0.3``: the same scene, the same cache key.
``map:LEVEL:SEED`` or ``map:LEVEL:SEED:MEAN``
    A spatially varying floor (paper, section "Varying the friction noise"): ``LEVEL`` is ``low``,
    ``medium`` or ``high`` and sets the amplitude of the variation, ``SEED`` an integer, ``MEAN``
    (optional; default the scene's base coefficient, 0.3) the map's mean coefficient, a number or a
    pair ``MU_S/MU_K``. A pair scales both: the static coefficient of every tile is the kinetic one
    times ``MU_S / MU_K``.

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
    """A parsed friction spec: ``kind`` is ``"uniform"`` (``mu``) or ``"map"`` (``level``, ``seed``,
    mean ``mu``). ``mu`` is the kinetic (sliding) coefficient, and the only one when ``mu_s`` is
    ``None``; ``mu_s`` is the static coefficient of a pair (always above ``mu``: a pair with equal
    coefficients is stored as one number, so it keeps the single number's scene and cache key).
    """

    kind: str
    mu: float = DEFAULT_MU
    level: str | None = None
    seed: int | None = None
    mu_s: float | None = None

    @property
    def static_mu(self) -> float:
        """The static coefficient (the mean one on a map): ``mu_s``, or ``mu`` for one coefficient."""
        return self.mu if self.mu_s is None else self.mu_s

    @property
    def static_ratio(self) -> float:
        """``MU_S / MU_K`` (exactly 1.0 for one coefficient): a map's static coefficients are its
        kinetic ones times this."""
        return 1.0 if self.mu_s is None else self.mu_s / self.mu

    @property
    def is_pair(self) -> bool:
        """True when the static coefficient differs from the kinetic one."""
        return self.mu_s is not None

    def __str__(self) -> str:
        pair = f"{self.mu_s:g}/{self.mu:g}" if self.mu_s is not None else None
        if self.kind == "uniform":
            return pair or f"{self.mu:g}"
        # one coefficient: the mean is the scene's base_mu (kept out of the text: unchanged keys)
        return f"map:{self.level}:{self.seed}" + (f":{pair}" if pair else "")

    def to_dict(self) -> dict:
        out = {"kind": self.kind, "mu": self.mu, "level": self.level, "seed": self.seed}
        if self.mu_s is not None:
            out["mu_s"] = self.mu_s
        return out


def _parse_coefficients(text: str, whole: str) -> tuple[float, float | None]:
    """``"0.3"`` -> ``(0.3, None)``; ``"0.5/0.3"`` -> ``(0.3, 0.5)`` (kinetic, static); one-line
    ValueError naming ``whole`` (the spec as given) otherwise."""
    parts = text.split("/")
    if len(parts) > 2:
        raise ValueError(f"bad friction {whole!r}: expected a number or a pair MU_S/MU_K, e.g. 0.5/0.3")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ValueError(f"bad friction {whole!r}: expected a number (e.g. 0.3), a pair MU_S/MU_K "
                         f"(e.g. 0.5/0.3) or map:LEVEL:SEED") from None
    for v in values:
        _check_mu(v, "friction")
    if len(values) == 1:
        return values[0], None
    mu_s, mu_k = values
    if mu_s < mu_k:
        raise ValueError(f"bad friction {whole!r}: the static coefficient MU_S ({mu_s:g}) must be at least "
                         f"the kinetic MU_K ({mu_k:g})")
    if mu_s == mu_k:
        return mu_k, None
    if mu_k <= 0.0:
        raise ValueError(f"bad friction {whole!r}: the kinetic coefficient of a pair must be positive")
    return mu_k, mu_s


def parse_friction(spec, base_mu: float = DEFAULT_MU) -> FrictionSpec:
    """Parse one friction spec (a number, a pair ``MU_S/MU_K``, or ``map:LEVEL:SEED[:MEAN]``) into a
    :class:`FrictionSpec`; one-line :class:`ValueError` if malformed.

    Parameters
    ----------
    spec : float, str or FrictionSpec
        A Coulomb coefficient (``0.3``), a static/kinetic pair (``0.5/0.3``; ``MU_S >= MU_K``, equal
        coefficients are one number), or ``map:low|medium|high:SEED`` with an optional mean
        (``map:low:3:0.4``, ``map:low:3:0.5/0.3``).
    base_mu : float, default 0.3
        The mean kinetic coefficient of a map that names no mean.

    Returns
    -------
    FrictionSpec

    Examples
    --------
    >>> str(parse_friction("0.5/0.3")), parse_friction("0.3/0.3") == parse_friction(0.3)
    ('0.5/0.3', True)
    """
    if isinstance(spec, FrictionSpec):
        return spec
    if isinstance(spec, (int, float)) and not isinstance(spec, bool):
        text = repr(float(spec))
    elif isinstance(spec, str):
        text = spec.strip()
    else:
        raise ValueError(f"friction must be a number, a pair MU_S/MU_K or 'map:LEVEL:SEED', got {spec!r}")
    if text.lower().startswith("map:"):
        parts = text.split(":")
        if len(parts) not in (3, 4):
            raise ValueError(f"bad friction map {text!r}: expected map:LEVEL:SEED or map:LEVEL:SEED:MEAN, "
                             f"e.g. map:low:3")
        level = parts[1].strip().lower()
        if level not in MAP_LEVELS:
            raise ValueError(f"bad friction map {text!r}: level must be one of {', '.join(MAP_LEVELS)}")
        try:
            seed = int(parts[2])
        except ValueError:
            raise ValueError(f"bad friction map {text!r}: seed must be an integer") from None
        if seed < 0:
            raise ValueError(f"bad friction map {text!r}: seed must be >= 0")
        mu_s = None
        if len(parts) == 4:
            base_mu, mu_s = _parse_coefficients(parts[3].strip(), text)
        _check_mu(base_mu, "base friction")
        if base_mu - MAP_LEVELS[level] <= 0:
            raise ValueError(f"friction map {text!r}: base mu {base_mu} is too small for level {level}")
        return FrictionSpec("map", float(base_mu), level, seed, mu_s)
    mu, mu_s = _parse_coefficients(text, text)
    return FrictionSpec("uniform", mu, mu_s=mu_s)


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
