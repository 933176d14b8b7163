"""Tray design (``kruskal design``): tray variants for a part or a kit, each answered from its models.

``rank`` ranks parts for one tray; ``design`` ranks trays for one part (or kit). A variant is a
compartment size (the side ``T`` of the square of the same area, and the aspect ratio ``a`` = x/y:
the compartment is ``T sqrt(a)`` by ``T / sqrt(a)`` mm) and a tilt angle; for a kit every
compartment gets the variant's size (a tray of equal compartments), or keeps its own when no size
range is given. Each variant's models are built like any model (the model cache: a variant built
before costs nothing), and :func:`kit_metrics` answers, with the ranking's definitions
(:func:`analysis.orientability.part_metrics`, same seeds, so one part's numbers are the ranking's):

- the shortest common plan for the target, proven shortest or bracketed by its proven lower bound;
- the share of random ``length``-tilt sequences that orient every part at once (95% Wilson
  interval);
- the expected random tilts until every part's predicted entropy is ``<= epsilon`` at once (Monte
  Carlo over shared sequences, 95% interval; censored runs give only a lower bound).

The Pareto front keeps the variants no other variant beats on tray area, plan length and expected
tilts at once (a variant that never orients the part is not on it); the best variant has the
shortest plan, and among those the smallest tray whose expected tilts are not clearly worse than
the fewest (:func:`best_variant`).
"""
from __future__ import annotations

import dataclasses
import itertools
import math
import re
import time

import numpy as np

from analysis.kit import Kit
from analysis.streams import salted

__all__ = ["Sweep", "parse_sweep_range", "variants", "kit_metrics", "pareto_front", "best_variant", "run_design"]


@dataclasses.dataclass(frozen=True)
class Sweep:
    """The swept values: compartment sizes (mm, None: the kit's own), aspect ratios and tilts (deg)."""

    tray_mm: tuple
    aspect: tuple
    tilt_deg: tuple


def parse_sweep_range(text: str | None, points: int, what: str, default):
    """The values of ``LO..HI`` (``points`` evenly spaced, or ``LO..HI:N``) or of one number.

    >>> parse_sweep_range("80..200:4", 3, "--tray-mm", None)
    (80.0, 120.0, 160.0, 200.0)
    >>> parse_sweep_range("20..40", 3, "--tilt-deg", None), parse_sweep_range("1.5", 3, "--aspect", 1.0)
    ((20.0, 30.0, 40.0), (1.5,))
    """
    if text is None:
        return (default,)
    number = r"((?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)"
    m = re.fullmatch(rf"\s*{number}\s*(?:\.\.\s*{number}\s*(?::\s*(\d+))?)?\s*", text)
    try:
        lo = float(m.group(1))
        hi = float(m.group(2)) if m.group(2) else None
    except (AttributeError, ValueError):
        raise ValueError(f"bad {what} {text!r}: expected a number or LO..HI (optionally LO..HI:N)") from None
    if not math.isfinite(lo) or lo <= 0 or (hi is not None and (not math.isfinite(hi) or hi < lo)):
        raise ValueError(f"bad {what} {text!r}: expected positive numbers with LO <= HI")
    if hi is None:
        return (lo,)
    n = int(m.group(3)) if m.group(3) else int(points)
    if n < 1 or (n == 1 and hi != lo):
        raise ValueError(f"{what} {text!r}: a range needs at least 2 points")
    if hi == lo:
        return (lo,)
    return tuple(float(round(v, 6)) for v in np.linspace(lo, hi, n))


def variants(kit: Kit, sweep: Sweep):
    """Every variant of the sweep as ``(description, kit)``; variants whose parts do not fit are
    returned separately as ``(description, reason)``."""
    out, skipped = [], []
    for t, a, tilt in itertools.product(sweep.tray_mm, sweep.aspect, sweep.tilt_deg):
        size = None if t is None else (round(t * math.sqrt(a), 1), round(t / math.sqrt(a), 1))
        desc = {"tray_mm": None if size is None else list(size), "side_mm": t, "aspect": a, "tilt_deg": tilt}
        try:
            v = kit.with_sizes(size, tilt) if size is not None else kit.with_tilt(tilt)
        except ValueError as exc:
            skipped.append((desc, str(exc)))
            continue
        desc["area_mm2"] = v.area_mm2
        out.append((desc, v))
    return out, skipped


def kit_metrics(models, *, target="cell", seed: int = 0, count: int = 500, length: int = 50, runs: int = 300,
                epsilon: float = 1e-3, max_tilts: int = 1000, node_budget: int = 2_000_000,
                max_length: int = 64) -> dict:
    """A variant's answers from its compartments' models (module docstring).

    The ensemble's sequences come from ``seed`` and the expected tilts' from ``[seed, 5]``, as in
    :func:`analysis.orientability.part_metrics`: for one model the converging share and the
    expected tilts are the ranking's ``converging_share_50`` and ``random_tilts``.

    Parameters
    ----------
    models : list of TransitionModel
        One per compartment.
    target : str
        Plan target (``state``, ``cell``, ``probability:E``).
    seed, count, length, runs, epsilon, max_tilts
        The random sequences: seed, ensemble size and length, Monte Carlo runs, convergence
        threshold (bits), tilts before a run is censored.
    node_budget, max_length : int
        The plan search's budget (images computed: the same answer on any machine) and longest word.

    Returns
    -------
    dict
        ``plan_length``, ``exact``, ``lower_bound``, ``word``, ``final_cells``,
        ``success_probabilities``, ``joint_success``, ``own_lengths``, ``converging_share``,
        ``converging_share_ci``, ``expected_tilts``, ``expected_tilts_ci``,
        ``expected_tilts_censored``, ``expected_tilts_lower``.
    """
    from kruskal_markov.kit import kit_ensemble, kit_entropy_tilts, kit_plan, wilson_interval

    plan = kit_plan(models, target, node_budget=node_budget, max_length=max_length)
    common = plan["common"]
    ens = kit_ensemble(models, count, length, seed=seed, epsilon=epsilon)
    # the single part's stream (orientability's random tilts): a one-part design answers as `rank` does
    tilts = kit_entropy_tilts(models, epsilon, runs=runs, seed=salted(seed, "orientability.entropy_tilts"),
                              max_steps=max_tilts)

    def listed(x):
        return None if x is None else (list(x) if isinstance(x, list) else [x])

    return {"plan_length": common.length, "exact": bool(common.exact),
            "lower_bound": common.lower_bound, "word": None if common.word is None else list(common.word),
            "final_cells": listed(common.final_cell), "success_probabilities": listed(common.success_probability),
            "joint_success": plan["joint_success"], "own_lengths": [p.length for p in plan["own"]],
            "converging_share": ens["converged"] / count, "converging_share_ci": wilson_interval(ens["converged"], count),
            "expected_tilts": tilts["mean"], "expected_tilts_ci": list(tilts["ci95"]),
            "expected_tilts_censored": tilts["censored"], "expected_tilts_lower": tilts["lower"]}


def _objectives(v: dict) -> tuple:
    inf = float("inf")
    tilts = v["expected_tilts"] if v["expected_tilts"] is not None else inf
    return (v["area_mm2"], inf if v["plan_length"] is None else v["plan_length"], tilts)


def pareto_front(rows: list, keys=(0, 1, 2)) -> list:
    """Indices of the rows no other row beats on the objectives ``keys`` of (area, plan length,
    expected tilts), all minimised (at least as good on each, better on one). A variant that
    orients nothing on the front's terms (no plan and, with the tilts among the keys, no finite
    expected tilts) is never on it, however small its tray.

    >>> rows = [{"area_mm2": 1, "plan_length": 5, "expected_tilts": 9}, {"area_mm2": 2, "plan_length": 4,
    ...          "expected_tilts": 9}, {"area_mm2": 2, "plan_length": 6, "expected_tilts": 9},
    ...         {"area_mm2": 0.5, "plan_length": None, "expected_tilts": None}]
    >>> pareto_front(rows), pareto_front(rows, (0, 2))
    ([0, 1], [0])
    """
    objs = [tuple(_objectives(r)[k] for k in keys) for r in rows]
    front = []
    for i, a in enumerate(objs):
        if all(x == float("inf") for x in a[1:]):
            continue
        beaten = any(all(b[j] <= a[j] for j in range(len(a))) and any(b[j] < a[j] for j in range(len(a)))
                     for b in objs)
        if not beaten:
            front.append(i)
    return front


def best_variant(rows: list) -> int | None:
    """The index of the best variant: the shortest plan; among those, the variants whose expected
    random tilts are not clearly worse than the fewest (their 95% interval reaches the fewest's);
    among those the smallest tray in whole cm^2 (then the fewest expected tilts, then the first). Without any
    plan: the fewest expected tilts. None without variants.

    >>> rows = [{"area_mm2": 40000, "plan_length": 5, "expected_tilts": 30.0, "expected_tilts_ci": [28, 32]},
    ...         {"area_mm2": 10000, "plan_length": 5, "expected_tilts": 31.0, "expected_tilts_ci": [29, 33]},
    ...         {"area_mm2": 5000, "plan_length": 5, "expected_tilts": 40.0, "expected_tilts_ci": [38, 42]}]
    >>> best_variant(rows)
    1
    """
    if not rows:
        return None
    inf = float("inf")
    with_plan = [i for i, r in enumerate(rows) if r["plan_length"] is not None]
    if not with_plan:
        return min(range(len(rows)), key=lambda i: (_objectives(rows[i])[2], rows[i]["area_mm2"], i))
    shortest = min(rows[i]["plan_length"] for i in with_plan)
    tied = [i for i in with_plan if rows[i]["plan_length"] == shortest]
    fewest = min(tied, key=lambda i: (_objectives(rows[i])[2], i))
    top = (rows[fewest].get("expected_tilts_ci") or [None, None])[1]
    top = _objectives(rows[fewest])[2] if top is None else top

    def not_worse(i):
        lo = (rows[i].get("expected_tilts_ci") or [None, None])[0]
        return (inf if rows[i]["expected_tilts"] is None else (lo if lo is not None else inf)) <= top

    close = [i for i in tied if i == fewest or not_worse(i)]
    # areas compared in whole cm^2: a variant of another aspect has the same area up to rounding
    return min(close, key=lambda i: (round(rows[i]["area_mm2"] / 100.0), _objectives(rows[i])[2], i))


def run_design(kit: Kit, sweep: Sweep, build_settings, *, contact=None, workers=None, log=None,
               setting_changes: dict | None = None, **metric_options) -> dict:
    """Build (or take from the cache) every variant's models and answer for each (:func:`kit_metrics`).

    Parameters
    ----------
    kit : Kit
        The part (a one-compartment kit) or kit.
    sweep : Sweep
    build_settings : BuildSettings
        Of every model.
    contact : str, optional
        Floor contact.
    workers : int, optional
        Worker processes of the builds.
    log : callable, optional
        Told one line per variant.
    setting_changes : dict, optional
        Simulator settings of every scene (e.g. the engine).
    **metric_options
        Passed to :func:`kit_metrics`.

    Returns
    -------
    dict
        ``variants`` (list of rows), ``skipped``, ``pareto``, ``pareto_plan``, ``pareto_tilts``,
        ``best``, and per variant its compartments' scenes under ``"_scenes"`` (not JSON).
    """
    from analysis.kit import kit_models

    found, skipped = variants(kit, sweep)
    rows, scenes = [], []
    for desc, v in found:
        t0 = time.perf_counter()
        comps = kit_models(v, build_settings, contact=contact, workers=workers, setting_changes=setting_changes)
        row = dict(desc)
        row.update(kit_metrics([c["model"] for c in comps], **metric_options))
        from transition_builder.cache import cache_key
        row["models"] = [cache_key(c["path"]) for c in comps]          # by cache key, never a machine's path
        row["states"] = [c["model"].n_states for c in comps]
        row["cached"] = all(c["cached"] for c in comps)
        row["seconds"] = time.perf_counter() - t0
        rows.append(row)
        scenes.append([c["scene"] for c in comps])
        if log is not None:
            log(f"variant {len(rows)}/{len(found)}: tray {desc['tray_mm']} tilt {desc['tilt_deg']:g}: plan "
                f"{row['plan_length']}, {row['converging_share']:.2f} converging ({row['seconds']:.0f} s)")
    return {"variants": rows, "skipped": [dict(d, reason=r) for d, r in skipped],
            "pareto": pareto_front(rows), "pareto_plan": pareto_front(rows, (0, 1)),
            "pareto_tilts": pareto_front(rows, (0, 2)), "best": best_variant(rows), "_scenes": scenes}
