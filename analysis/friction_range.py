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

from analysis.streams import offset_seed

__all__ = ["FrictionRange", "answers_over_range", "between_points", "check_plan_between", "is_friction_range",
           "models_over_range", "parse_friction_range", "plan_cell", "rankings_over_range"]

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


# ----------------------------------------------------------------------------------------------
# answers over a range (the Python API behind --friction LO..HI)
# ----------------------------------------------------------------------------------------------

def models_over_range(scene, frange: FrictionRange, points: int, build_settings=None, **build_kwargs) -> list:
    """Models of ``scene`` at ``points`` evenly spaced coefficients of ``frange`` (cached builds).

    Parameters
    ----------
    scene : transition_builder.scene.Scene
        Everything but the friction.
    frange : FrictionRange
    points : int
    build_settings : transition_builder.builder.BuildSettings, optional
        Default: the fit's grid (1 mm / 1 degree, one recentring round, 2,000 start samples), so
        that a fitted interval's models are reused.
    **build_kwargs
        ``workers``, ``scheduler``, ``progress`` of :func:`~transition_builder.cache.cached_build`.

    Returns
    -------
    list of (str, TransitionModel, str)
        (friction spec, model, path) per point.
    """
    from dataclasses import replace

    from transition_builder.builder import BuildSettings
    from transition_builder.cache import cached_build
    from transition_builder.friction import parse_friction

    bs = build_settings or BuildSettings.compared()
    out = []
    for spec in frange.points(points):
        res, path, _ = cached_build(replace(scene, friction=parse_friction(spec)), bs, **build_kwargs)
        out.append((spec, res.model, path))
    return out


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def answers_over_range(frictions, answers: list) -> dict:
    """Every answer as its range over the interval: for each key whose value is a number at every
    point, ``[min, max]``; a list of numbers (a curve) as ``[min, max]`` per entry; nested objects
    recursively; anything else (text, words) is left out.

    >>> answers_over_range(["0.2", "0.4"], [{"a": 1, "b": {"c": 3.0}}, {"a": 2, "b": {"c": 1.0}}])
    {'friction': ['0.2', '0.4'], 'range': {'a': [1, 2], 'b': {'c': [1.0, 3.0]}}}
    """
    def span(values):
        if all(_is_number(v) for v in values):
            return [min(values), max(values)]
        if (all(isinstance(v, list) and len(v) == len(values[0]) for v in values)
                and all(_is_number(x) for v in values for x in v)):
            return [[min(c), max(c)] for c in zip(*values)]     # a curve: its band, step by step
        if all(isinstance(v, dict) for v in values):
            keys = [k for k in values[0] if all(k in v for v in values)]
            inner = {k: span([v[k] for v in values]) for k in keys}
            return {k: v for k, v in inner.items() if v is not None}
        return None

    return {"friction": list(frictions), "range": span(answers) or {}}


def rankings_over_range(frictions, rankings: list) -> dict:
    """Each part's rank range and the pairwise orders that hold at every point of the interval.

    Parameters
    ----------
    frictions : list of str
    rankings : list of list of dict
        Per point, the ranking rows (``shape``, ``rank``).

    Returns
    -------
    dict
        ``rank_range`` (shape -> [best, worst]), ``orders_that_hold`` ([a, b]: a ranks above b at
        every point), ``orders_that_flip`` (pairs whose order changes), ``kendall_tau_ends`` (the
        rank correlation of the interval's two ends).
    """
    from scipy.stats import kendalltau

    ranks = [{r["shape"]: int(r["rank"]) for r in rows} for rows in rankings]
    shapes = sorted(ranks[0], key=lambda s: ranks[0][s])
    rank_range = {s: [min(r[s] for r in ranks), max(r[s] for r in ranks)] for s in shapes}
    hold, flip = [], []
    for i, a in enumerate(shapes):
        for b in shapes[i + 1:]:
            above = [r[a] < r[b] for r in ranks]
            if all(above):
                hold.append([a, b])
            elif not any(r[a] > r[b] for r in ranks):
                continue                                # tied somewhere, never reversed
            elif any(above):
                flip.append([a, b])
            else:
                hold.append([b, a])
    tau = None
    if len(shapes) >= 2 and len(ranks) >= 2:
        tau = float(kendalltau([ranks[0][s] for s in shapes], [ranks[-1][s] for s in shapes])[0])
    return {"friction": list(frictions), "rank_range": rank_range, "orders_that_hold": hold,
            "orders_that_flip": flip, "kendall_tau_ends": tau}


def plan_cell(final_cell):
    """The one report cell a plan promises: ``final_cell`` of a plan over one model, or the common
    entry of a robust plan's per-model cells; None when the models end it in different cells (the
    plan then promises no one cell across the interval) or when there is none.

    >>> plan_cell(62), plan_cell([62, 62, 62]), plan_cell([0, 62]), plan_cell(None)
    (62, 62, None, None)
    """
    if final_cell is None:
        return None
    if isinstance(final_cell, (list, tuple, np.ndarray)):
        cells = {int(c) for c in final_cell if c is not None}
        return cells.pop() if len(cells) == 1 and None not in list(final_cell) else None
    return int(final_cell)


def between_points(frange: FrictionRange, points: int) -> list[float]:
    """The coefficients halfway between consecutive model points of ``frange`` (``points`` models).

    >>> between_points(parse_friction_range("0.2..0.4"), 5)
    [0.225, 0.275, 0.325, 0.375]
    """
    mus = frange.values(points)[:, 0]
    return [float(round(m, 10)) for m in (mus[:-1] + mus[1:]) / 2]


def check_plan_between(scene, word, final_cell, frange: FrictionRange | None, points: int, trials: int, seed: int,
                       grid="4x4x4", workers=None, *, coefficients=None, simulator_factory=None) -> list:
    """Replay a plan by direct simulation at coefficients where no model was built.

    Parameters
    ----------
    scene : transition_builder.scene.Scene
        The scene the models were built for (its friction is replaced).
    word : sequence of str
        The plan.
    final_cell : int, list of int or None
        The plan's ``final_cell`` (a robust plan's list: one per model; see :func:`plan_cell`).
    frange : FrictionRange or None
        With ``points``: the default coefficients, halfway between the model points.
    points : int
    trials : int
        Uniform random starts per coefficient.
    seed : int
        Coefficient ``i`` (in the order given) draws its starts with seed ``seed + i``; a second
        plan replayed with the same seed starts from the same poses (a paired comparison).
    grid : str
        The report grid of the plan's cells.
    workers : int, optional
    coefficients : sequence of float, optional
        Replay at these coefficients instead of halfway between the points.
    simulator_factory : callable, optional
        Passed to :func:`transition_builder.tilting.run_direct` (tests).

    Returns
    -------
    list of dict
        Per coefficient: ``mu``, ``seed``, ``trials``, ``cell`` (the promised cell, None when the
        models disagree), ``in_cell`` and ``share_in_cell`` (trials ending in it; faulted trials
        count as misses) with its Wilson 95% interval ``share_in_cell_ci95``, ``faulted``, and
        ``modal_cell`` / ``share_in_modal_cell`` (the most common end cell: whether the plan
        gathers the part at all).
    """
    from dataclasses import replace

    from analysis.montecarlo import report_grid_for, run_direct
    from kruskal_markov.answers import wilson_interval
    from transition_builder.friction import parse_friction
    from transition_builder.status import OK

    mus = [float(m) for m in coefficients] if coefficients is not None else between_points(frange, points)
    cell = plan_cell(final_cell)
    out = []
    for i, mu in enumerate(mus):
        sc = replace(scene, friction=parse_friction(mu))
        res = run_direct(sc, list(word), trials, seed=offset_seed(seed, i), workers=workers, grid=grid,
                         simulator_factory=simulator_factory)
        g = report_grid_for(sc, grid)
        ok = res.status[:, -1] == OK
        cells = g.voxel_index(res.poses[ok, -1]) if ok.any() else np.zeros(0, dtype=np.int64)
        counts = np.bincount(cells, minlength=1) if cells.size else np.zeros(1, dtype=np.int64)
        row = {"mu": float(round(mu, 10)), "seed": offset_seed(seed, i), "trials": int(trials), "cell": cell,
               "faulted": int(trials - ok.sum()), "modal_cell": int(np.argmax(counts)) if cells.size else None,
               "share_in_modal_cell": float(counts.max() / trials)}
        if cell is not None:
            hit = int(np.sum(cells == cell))
            row.update(in_cell=hit, share_in_cell=hit / trials, share_in_cell_ci95=list(wilson_interval(hit, trials)))
        else:
            row.update(in_cell=None, share_in_cell=None, share_in_cell_ci95=None)
        out.append(row)
    return out
