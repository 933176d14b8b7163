"""One reported number with its intervals: the project's :class:`Estimate`.

Every answer the project reports (a converging share, a mean entropy, an expected number of
tilts, a plan's success probability) is a point value beside up to four intervals, each for one
way the value can be wrong (docs/uncertainty.md):

``mc_ci95``
    Monte Carlo: the 95% interval of an estimate from finitely many random sequences or runs.
``posterior_ci90``
    Sampling noise of the model's rows: the 5-95% spread over draws from the Dirichlet posterior
    (:mod:`kruskal_markov.posterior`); None for a model without sample counts.
``structural_range``
    Structural error: the value's range when every report-cell distribution may lie anywhere in
    the model's structural ball (:mod:`kruskal_markov.structural`); ``[value, value]`` for a model
    without a structural term (an automaton given exactly), and then ``note`` says so.
``model_ci90``
    The two model terms end to end: ``posterior_ci90`` widened by ``structural_range``.

The design follows deeptime's ``QuantityStatistics`` (a value with its confidence interval,
``deeptime.util.QuantityStatistics``): an immutable record, built by :meth:`Estimate.combine`,
written by :meth:`Estimate.to_dict` with exactly the JSON keys the commands have always printed.
This type is frozen: new fields may be added with a default, none renamed or removed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

__all__ = ["Estimate", "Interval"]

Interval = tuple  # (low, high) of floats; a bound may be None (e.g. an interval that could not be computed)

_INTERVALS = ("mc_ci95", "posterior_ci90", "structural_range", "model_ci90")


def _pair(x, name: str) -> Interval | None:
    if x is None:
        return None
    lo, hi = x
    lo = None if lo is None else float(lo)
    hi = None if hi is None else float(hi)
    if lo is not None and hi is not None and not lo <= hi:
        raise ValueError(f"{name}: low end {lo} above high end {hi}")
    return (lo, hi)


@dataclass(frozen=True)
class Estimate:
    """A value with its Monte Carlo, posterior, structural and model intervals.

    Parameters
    ----------
    value : float or None
        The point estimate (None: not computed, e.g. every run censored).
    mc_ci95, posterior_ci90, structural_range, model_ci90 : (float, float) or None
        The intervals of the module docstring; None where the term does not apply.
    note : str, optional
        Why a term is missing or empty (e.g. "no structural term: the model was given exactly").
    extra : dict
        Further JSON keys written beside the intervals (e.g. ``censored``).

    Examples
    --------
    >>> e = Estimate.combine(0.5, mc=(0.4, 0.6), posterior=(0.45, 0.55), structural=(0.5, 0.75))
    >>> e.model_ci90
    (0.45, 0.8)
    >>> e.to_dict()["structural_range"]
    [0.5, 0.75]
    """

    value: float | None
    mc_ci95: Interval | None = None
    posterior_ci90: Interval | None = None
    structural_range: Interval | None = None
    model_ci90: Interval | None = None
    note: str | None = None
    extra: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.value is not None:
            v = float(self.value)
            if math.isnan(v):
                raise ValueError("an estimate's value must not be NaN")
            object.__setattr__(self, "value", v)
        for name in _INTERVALS:
            object.__setattr__(self, name, _pair(getattr(self, name), name))

    @classmethod
    def combine(cls, value, mc=None, posterior=None, structural=None, note: str | None = None,
                clip: tuple[float, float] | None = None, **extra) -> "Estimate":
        """An estimate whose model interval is the posterior interval widened by the structural range.

        Each model interval is first widened to contain ``value``; ``model_ci90`` is then
        ``[post_lo - (value - struct_lo), post_hi + (struct_hi - value)]`` (the two terms end to
        end). Without a posterior interval the posterior term is ``[value, value]``; without a
        structural range the structural term is ``[value, value]``.

        Parameters
        ----------
        value : float
        mc, posterior, structural : (float, float), optional
        note : str, optional
        clip : (float, float), optional
            Bounds of the quantity (e.g. ``(0, 1)`` for a probability) applied to ``model_ci90``.
        **extra
            Further JSON keys.
        """
        v = float(value)
        p_lo, p_hi = posterior if posterior is not None else (v, v)
        s_lo, s_hi = structural if structural is not None else (v, v)
        p_lo, p_hi = min(float(p_lo), v), max(float(p_hi), v)
        s_lo, s_hi = min(float(s_lo), v), max(float(s_hi), v)
        lo, hi = p_lo - (v - s_lo), p_hi + (s_hi - v)
        if clip is not None:
            lo, hi = max(clip[0], lo), min(clip[1], hi)
        return cls(v, mc_ci95=None if mc is None else tuple(mc),
                   posterior_ci90=None if posterior is None else (p_lo, p_hi),
                   structural_range=(s_lo, s_hi), model_ci90=(lo, hi), note=note, extra=dict(extra))

    def to_dict(self) -> dict:
        """The JSON form: ``value`` and the four intervals as ``[lo, hi]`` lists (or None), then ``extra``;
        ``note`` only when set."""
        out = {"value": self.value}
        for name in _INTERVALS:
            x = getattr(self, name)
            out[name] = None if x is None else [x[0], x[1]]
        if self.note is not None:
            out["note"] = self.note
        out.update(self.extra)
        return out

    @classmethod
    def from_dict(cls, d: dict) -> "Estimate":
        """The inverse of :meth:`to_dict`."""
        extra = {k: v for k, v in d.items() if k not in ("value", "note", *_INTERVALS)}
        return cls(d.get("value"), **{k: d.get(k) for k in _INTERVALS}, note=d.get("note"), extra=extra)

    def contains(self, x: float, interval: str = "model_ci90") -> bool:
        """True if ``x`` lies in the named interval (False when that interval is None)."""
        iv = getattr(self, interval)
        if iv is None or None in iv:
            return False
        return iv[0] <= x <= iv[1]
