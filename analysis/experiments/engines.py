"""Engine against engine: which physics engine answered the report, its judges beside the other
engine's, and the key's headline answers from both engines' models (``engines``).

The default engine is decided by the rule in docs/simulator.md; the other engine is its reference.
Both models are built at the compared resolution (the contact section's) and asked the same questions
on the same random streams (:func:`analysis.experiments.model_answers.model_answers`).
"""
from __future__ import annotations

import dataclasses

from analysis.experiments.model_answers import key_metrics, model_answers
from analysis.experiments.text import fmt

ENGINES = ("planar", "pybullet")

_JUDGE_ROWS = (("slide_mm", "free slide, worst final distance (mm)", ".3f"),
               ("slide_deg", "free slide, worst final angle (deg)", ".3f"),
               ("disk_stop_gap", "disk: sliding and spinning stop apart (share of the time)", ".2%"),
               ("disk_ratio_error", "disk: late v / (R omega), relative error", ".2%"),
               ("pure_slide_error", "pure sliding: stopping time, relative error", ".2%"),
               ("pure_spin_error", "pure spinning: stopping time, relative error", ".2%"),
               ("isotropy_slide", "isotropy: displacement change under a 45 deg turn", ".2%"),
               ("isotropy_turn", "isotropy: rotation change under a 45 deg turn", ".2%"),
               ("simultaneous_stop", "disk, three start ratios: stops apart (share of the time)", ".2%"),
               ("drift_mm", "triangle wedged in a corner: drift over a second (mm)", ".4f"),
               ("turn_deg", "triangle wedged in a corner: turn over a second (deg)", ".4f"),
               ("not_at_rest", "triangle wedged in a corner: starts not at rest", "d"))


@dataclasses.dataclass(frozen=True)
class Settings:
    """Whether the section runs, the part, the compared resolution, the judges and the search budgets."""

    engines: bool
    shape: str
    compare_build: dict
    judges: bool
    sync_time_budget: float
    part_sync_time_budget: float
    sync_node_budget: int | None

    @classmethod
    def from_settings(cls, s) -> "Settings":
        build = s.key_build if s.contact_build is None else s.contact_build
        return cls(bool(getattr(s, "engines", False)), s.shape, dict(build), s.judges, s.sync_time_budget,
                   s.part_sync_time_budget, s.sync_node_budget)


@dataclasses.dataclass(frozen=True)
class Result:
    """The default engine, each engine's answers (``engine -> dict``) and judges (``engine -> dict``, or None)."""

    settings: Settings
    default: str
    answers: dict
    judges: dict | None

    def to_dict(self) -> dict:
        if not self.settings.engines:
            return {}
        from transition_builder.judges import JUDGE_TARGETS, NEW_JUDGE_TARGETS
        out = {"default": self.default, "answers": self.answers}
        if self.judges is not None:
            out["judges"] = self.judges
            out["judge_targets"] = {**JUDGE_TARGETS, **NEW_JUDGE_TARGETS}
        return {"engines": out}


def _answers(ctx, st: Settings, engine: str) -> dict:
    from kruskal_markov.sync import shortest_plan
    scene = ctx.scene().with_settings(engine=engine)
    model, info = ctx.build(scene, st.compare_build, f"{st.shape}, {engine} engine")
    answers = model_answers(ctx, model, key_metrics(ctx, model, sync_time_budget=st.sync_time_budget)).to_dict()
    budget = {} if st.sync_node_budget is None else {"node_budget": st.sync_node_budget}
    cell = shortest_plan(model, "cell", time_budget=st.part_sync_time_budget, **budget)
    return {**answers, "cell_plan": cell.length, "cell_plan_exact": bool(cell.exact),
            "cell_plan_lower_bound": cell.lower_bound, "model": info.to_dict()}


def run(ctx) -> Result:
    st = Settings.from_settings(ctx.settings)
    default = ctx.scene().settings.engine
    if not st.engines:
        return Result(st, default, {}, None)
    order = (default,) + tuple(e for e in ENGINES if e != default)
    answers = {}
    for engine in order:
        ctx.log(f"the key's headline answers from the {engine} engine's model")
        answers[engine] = _answers(ctx, st, engine)
    judges = None
    if st.judges:
        ctx.log("the judges on both engines")
        from transition_builder.judges import engine_judges
        judges = {engine: engine_judges(engine) for engine in order}
    return Result(st, default, answers, judges)


_ANSWER_ROWS = (("model states", "states", ",d"),
                ("share of random 50-tilt sequences converging", "converging_share", ".1%"),
                ("expected random tilts to converge", "random_tilts", ".1f"),
                ("shortest one-state plan (tilts)", "sync_length", "d"),
                ("shortest one-cell plan (tilts)", "cell_plan", "d"),
                ("experiment A: random sequences converging", "a_converged", "d"))


def markdown(r: Result) -> str:
    if not r.settings.engines:
        return ""
    engines = list(r.answers)
    lines = ["## Engine against engine", "", f"**Which engine answered**: every model and direct simulation of this report ran in the "
             f"`{r.default}` engine (the default chosen by the rule in docs/simulator.md); the other engine is "
             f"its reference. The key's models of both engines at the compared resolution "
             f"(`{r.settings.compare_build}`), asked the same questions on the same random sequences:", "",
             "| answer | " + " | ".join(f"`{e}`" for e in engines) + " |", "|---|" + "---|" * len(engines)]
    for label, key, f in _ANSWER_ROWS:
        lines.append(f"| {label} | " + " | ".join(fmt(r.answers[e].get(key), f) for e in engines) + " |")
    exact = {e: (r.answers[e].get("sync_exact"), r.answers[e].get("cell_plan_exact")) for e in engines}
    lines += ["", "Plans proven shortest (one-state, one-cell): "
              + "; ".join(f"`{e}` {a}, {b}" for e, (a, b) in exact.items()) + ".", ""]
    if r.judges is not None:
        from transition_builder.judges import JUDGE_TARGETS, NEW_JUDGE_TARGETS
        targets = {**JUDGE_TARGETS, **NEW_JUDGE_TARGETS}
        lines += ["**The judges on both engines** (`transition_builder/judges.py`; free slides at 1/16 of the "
                  "step against a direct integration of Coulomb's law; a cell in bold misses its target):", "",
                  "| judge | target | " + " | ".join(f"`{e}`" for e in engines) + " |",
                  "|---|---|" + "---|" * len(engines)]
        for key, label, f in _JUDGE_ROWS:
            cells = []
            for e in engines:
                v = r.judges[e][key]
                cells.append(f"**{format(v, f)}**" if v > targets[key] else format(v, f))
            lines.append(f"| {label} | {format(targets[key], f)} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


def figures(r: Result, out: str) -> list[str]:
    return []
