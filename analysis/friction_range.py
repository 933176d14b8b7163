"""Friction ranges ``LO..HI``: the floor coefficient a user does not know, as an interval.

``--friction LO..HI`` on ``plan``, ``ensemble``, ``convergence`` and ``rank`` (and ``--range`` of
``kruskal fit``) names an interval of uniform coefficients; ``LO_S/LO_K..HI_S/HI_K`` an interval of
static/kinetic pairs (docs/commands.md, "Friction"). Each end is read by the one friction parser,
:func:`transition_builder.friction.parse_friction`, so a range accepts exactly what ``--friction``
accepts at a point; a spatially varying map (``map:LEVEL:SEED``) has no range.

>>> r = parse_friction_range("0.2..0.4")
>>> r.points(3)
['0.2', '0.3', '0.4']
>>> r.contains(0.25), r.contains(0.5)
(True, False)
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FrictionRange", "is_friction_range", "parse_friction_range"]

_SEP = ".."


def is_friction_range(text) -> bool:
    """Whether a ``--friction`` value is a range ``LO..HI`` (rather than one coefficient)."""
    return isinstance(text, str) and _SEP in text


def _pair(spec) -> tuple[float, float]:
    """(static, kinetic) coefficients of a parsed uniform spec (equal for a single number)."""
    mu_s = getattr(spec, "mu_s", None)
    mu_k = getattr(spec, "mu_k", None)
    mu = float(spec.mu)
    return (float(mu_s) if mu_s is not None else mu, float(mu_k) if mu_k is not None else mu)


@dataclass(frozen=True)
class FrictionRange:
    """A closed interval of floor friction: two uniform specs ``lo`` and ``hi`` (``lo <= hi``).

    Attributes
    ----------
    lo, hi : tuple of float
        The ends as (static, kinetic) coefficients; equal entries for plain Coulomb friction.
    paired : bool
        Whether the ends were written as ``MU_S/MU_K`` pairs (points are then written as pairs).
    """

    lo: tuple
    hi: tuple
    paired: bool = False

    def __str__(self) -> str:
        return f"{self._fmt(self.lo)}{_SEP}{self._fmt(self.hi)}"

    def _fmt(self, pair) -> str:
        s, k = (float(f"{v:.10g}") for v in pair)
        return f"{s:g}/{k:g}" if self.paired else f"{s:g}"

    @property
    def width(self) -> float:
        """Width of the interval in the (static) coefficient."""
        return self.hi[0] - self.lo[0]

    def values(self, n: int) -> np.ndarray:
        """``n`` evenly spaced points as an (n, 2) array of (static, kinetic) coefficients, ends included."""
        if n < 1:
            raise ValueError(f"a friction range needs at least 1 point, got {n}")
        if n == 1 or self.lo == self.hi:
            return np.array([np.add(self.lo, self.hi) / 2.0] * (1 if self.lo == self.hi else n))
        t = np.linspace(0.0, 1.0, n)[:, None]
        return np.asarray(self.lo)[None, :] * (1 - t) + np.asarray(self.hi)[None, :] * t

    def points(self, n: int) -> list[str]:
        """``n`` evenly spaced points as ``--friction`` spec strings (read back by ``parse_friction``)."""
        return [self._fmt(p) for p in self.values(n)]

    def contains(self, mu: float) -> bool:
        """Whether the (static) coefficient ``mu`` lies in the interval."""
        return self.lo[0] - 1e-12 <= float(mu) <= self.hi[0] + 1e-12

    def to_dict(self) -> dict:
        return {"range": str(self), "lo": list(self.lo), "hi": list(self.hi), "paired": self.paired}


def parse_friction_range(text: str) -> FrictionRange:
    """Parse ``LO..HI`` (or ``LO_S/LO_K..HI_S/HI_K``); one-line :class:`ValueError` when malformed.

    Each end goes through :func:`transition_builder.friction.parse_friction`; both ends must be
    uniform (no friction map) and ``LO <= HI`` in every coefficient.

    Parameters
    ----------
    text : str
        The range.

    Returns
    -------
    FrictionRange
    """
    from transition_builder.friction import parse_friction

    if not isinstance(text, str) or text.count(_SEP) != 1:
        raise ValueError(f"bad friction range {text!r}: expected LO..HI, e.g. 0.2..0.4")
    ends = []
    for part in text.split(_SEP):
        part = part.strip()
        if not part:
            raise ValueError(f"bad friction range {text!r}: expected LO..HI, e.g. 0.2..0.4")
        try:
            spec = parse_friction(part)
        except ValueError as exc:
            raise ValueError(f"bad friction range {text!r}: {exc}") from None
        if getattr(spec, "kind", "uniform") != "uniform":
            raise ValueError(f"bad friction range {text!r}: a range takes coefficients, not {part!r}")
        ends.append((_pair(spec), "/" in part))
    (lo, lo_pair), (hi, hi_pair) = ends
    if lo_pair != hi_pair:
        raise ValueError(f"bad friction range {text!r}: write both ends as numbers or both as MU_S/MU_K pairs")
    if any(a > b for a, b in zip(lo, hi)):
        raise ValueError(f"bad friction range {text!r}: the low end must not exceed the high end")
    return FrictionRange(lo=lo, hi=hi, paired=lo_pair)
