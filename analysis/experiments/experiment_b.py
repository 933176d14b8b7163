"""Experiment B (the paper's Fig. 4): A's best sequence on other parts, one model per part, each
also simulated directly; the model-against-simulation rank correlation (``B``)."""
from __future__ import annotations

import dataclasses

import numpy as np

from analysis.experiments.curves import first_at_most
from analysis.experiments.model_answers import key_metrics
from analysis.experiments.plotting import pyplot, save, trend_axes
from analysis.experiments.text import fmt
from analysis.orientability import random_tilts_text


@dataclasses.dataclass(frozen=True)
class Settings:
    """The parts' shape specs, their build changes, the direct trials, length and threshold."""

    parts: tuple
    build: dict
    trials: int
    length: int
    epsilon: float
    sync_time_budget: float

    @classmethod
    def from_settings(cls, s) -> "Settings":
        return cls(tuple(s.parts), dict(s.part_build), s.b_trials, s.length, s.epsilon, s.part_sync_time_budget)


@dataclasses.dataclass(frozen=True)
class Result:
    """Per part (spec -> entry): its model, the model's and direct simulation's curves along A's best
    sequence, where each first reaches zero, and its orientability metrics."""

    settings: Settings
    parts: dict
    rank_correlation: dict | None

    @property
    def converged(self) -> int:
        return sum(p["converged_at"] is not None for p in self.parts.values())

    @property
    def converged_direct(self) -> int:
        return sum(p["direct_zero_at"] is not None for p in self.parts.values())

    @property
    def mean(self):
        return np.array([p["entropy_bits"] for p in self.parts.values()]).mean(axis=0) if self.parts else None

    @property
    def mean_near_zero_by(self) -> int | None:
        return first_at_most(self.mean, 0.1) if self.parts else None

    def to_dict(self) -> dict:
        return {"B": {"parts": self.parts, "converged": self.converged, "converged_direct": self.converged_direct,
                      "mean": self.mean.tolist() if self.parts else [], "mean_near_zero_by": self.mean_near_zero_by,
                      "rank_correlation": self.rank_correlation}}


def run(ctx) -> Result:
    from kruskal_markov.entropy import entropy_trajectory

    st = Settings.from_settings(ctx.settings)
    best = ctx.result("A").best_sequence
    parts = {}
    for spec in st.parts:
        scene = ctx.scene(spec)
        model, info = ctx.build(scene, st.build, f"B: {spec}")
        curve = entropy_trajectory(model, best).entropy_bits
        metrics = key_metrics(ctx, model, sync_time_budget=st.sync_time_budget)
        ctx.log(f"B: {spec}: best sequence in direct simulation ({st.trials} trials)")
        direct = ctx.direct(scene, best, st.trials, f"B:{spec}")
        parts[spec] = {"model": info.to_dict(), "entropy_bits": curve.tolist(),
                       "converged_at": first_at_most(curve, st.epsilon), "direct": direct,
                       "direct_zero_at": first_at_most(direct["entropy_bits"], 0.0), "metrics": metrics.to_dict()}
    return Result(st, parts, rank_correlation(parts))


def rank_correlation(parts: dict) -> dict | None:
    """Spearman correlation of the model's and direct simulation's final entropy along the best
    sequence, over the B parts (None for fewer than 3 parts)."""
    if len(parts) < 3:
        return None
    from scipy.stats import spearmanr

    model = [p["entropy_bits"][-1] + 1e-3 * np.mean(p["entropy_bits"]) for p in parts.values()]
    direct = [p["direct"]["entropy_bits"][-1] + 1e-3 * np.mean(p["direct"]["entropy_bits"]) for p in parts.values()]
    rho, pval = spearmanr(model, direct)
    return {"spearman": None if not np.isfinite(rho) else float(rho),
            "p_value": None if not np.isfinite(pval) else float(pval), "parts": len(parts),
            "on": "final entropy along the best sequence (ties broken by the mean over the sequence)"}


def markdown(r: Result) -> str:
    lines = ["## B: other parts", ""]
    if r.parts:
        rc = r.rank_correlation
        lines += [
            "| part | model states | converges along the best sequence (model / direct) | shortest word | "
            "expected random tilts | mean entropy after 10 / 50 random tilts | share of 50-tilt sequences converging |",
            "|---|---|---|---|---|---|---|",
        ]
        for spec, q in r.parts.items():
            m = q["metrics"]
            lines.append(f"| {spec} | {q['model']['states']:,} | {fmt(q['converged_at'], 'd', 'no')} / "
                         f"{fmt(q['direct_zero_at'], 'd', 'no')} | {fmt(m['sync_length'], 'd', 'none')}"
                         f"{'' if m['sync_exact'] else ' (greedy)'} | {random_tilts_text(m)} | "
                         f"{m['mean_entropy_10']:.2f} / {m['mean_entropy_50']:.2f} | {100 * m['converging_share_50']:.0f}% |")
        lines += ["", "![B](fig_b_parts.png)", "", "![B shapes](fig_b_shapes.png)", ""]
        if rc:
            lines += [f"Model against direct simulation over the parts ({rc['on']}): Spearman rank correlation "
                      f"{fmt(rc['spearman'])} (p = {fmt(rc['p_value'], '.2g')}, {rc['parts']} parts).", ""]
    return "\n".join(lines)


def figures(r: Result, out: str) -> list[str]:
    if not r.parts:
        return []
    fig, (ax1, ax2) = pyplot().subplots(1, 2, figsize=(11, 4), sharey=True)
    m = np.array([p["entropy_bits"] for p in r.parts.values()])
    d = np.array([p["direct"]["entropy_bits"] for p in r.parts.values()])
    trend_axes(ax1, m, m.mean(0), *np.quantile(m, [0.25, 0.75], axis=0),
               f"B: the best sequence on {len(r.parts)} parts (models)", thin_label="part")
    trend_axes(ax2, d, d.mean(0), *np.quantile(d, [0.25, 0.75], axis=0),
               f"B: the same in direct simulation (M = {r.settings.trials})", thin_label="part")
    return save(fig, out, "fig_b_parts.png") + _shapes_figure(r.parts, out)


def _shapes_figure(parts, out) -> list[str]:
    from transition_builder.shapes import parse_shape

    n = len(parts)
    cols = min(n, 5)
    rows = -(-n // cols)
    fig, axes = pyplot().subplots(rows, cols, figsize=(1.8 * cols, 1.8 * rows), squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    for ax, (spec, p) in zip(axes.ravel(), parts.items()):
        v = np.asarray(parse_shape(spec).vertices)
        ax.fill(v[:, 0], v[:, 1], color="tab:green" if p["converged_at"] is not None else "tab:gray")
        ax.set_aspect("equal")
        ax.set_title(spec, fontsize=7)
    fig.suptitle("B parts (green: the model converges along the best sequence)", fontsize=9)
    return save(fig, out, "fig_b_shapes.png")
