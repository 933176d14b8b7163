"""Kits and trays (``kits``; ``docs/kits.md``): the paper's future work, "compartmentalized
tray-tilting of a kit of parts". A three-part kit (the key and two of the paper's triangles, each
in its own compartment of one tray, tilted together): its shortest common plan against each
part's own, replayed by direct simulation and animated; random sequences against the whole kit;
and the key's tray design curve (compartment size and tilt angle).

Off unless ``settings.kits`` (on in the full and the quick report; the quick one on coarse models
and two design variants).
"""
from __future__ import annotations

import dataclasses
import os

from analysis.experiments.text import fmt, interval


@dataclasses.dataclass(frozen=True)
class Settings:
    """The kit (``(name, shape, x_mm, y_mm)`` per compartment), its models' build settings, the
    design sweep (compartment sides, tilts), the replay's trials, the random sequences' count and
    Monte Carlo runs, and the plan search's node budget."""

    on: bool
    compartments: tuple
    build: dict
    design_tray_mm: tuple
    design_tilt_deg: tuple
    replay_trials: int
    count: int
    runs: int
    node_budget: int
    epsilon: float

    @classmethod
    def from_settings(cls, s) -> "Settings":
        return cls(s.kits, tuple(s.kit_compartments), dict(s.kit_build), tuple(s.kit_design_tray_mm),
                   tuple(s.kit_design_tilt_deg), s.kit_replay_trials, s.metrics_count, s.metrics_runs,
                   s.kit_node_budget, s.epsilon)


@dataclasses.dataclass(frozen=True)
class Result:
    """The kit's plan, replay, random-sequence figures and the design sweep (empty when off);
    ``direct`` keeps the replay's poses for the animation (not in ``results.json``)."""

    kit: dict
    design: dict
    direct: tuple = ()
    scenes: tuple = ()

    def to_dict(self) -> dict:
        return {"kits": self.kit, "kit_design": self.design} if self.kit else {}


def _kit_of(st: Settings, ctx):
    from analysis.kit import parse_kit

    comps = []
    for name, shape, x, y in st.compartments:
        c = {"name": name, "size_mm": [x, y], "shape": shape}
        if ctx.settings.friction is not None:
            c["friction"] = ctx.settings.friction
        comps.append(c)
    return parse_kit({"compartments": comps})


def _engine_changes(ctx) -> dict:
    """The run's engine for every scene of the section (none: the simulator's default), as for every other section."""
    engine = getattr(ctx.settings, "engine", None)
    return {} if engine is None else {"engine": engine}


def _kit_answers(ctx, st: Settings, kit) -> tuple:
    """The common plan, the replay and the random-sequence figures of the kit."""
    from analysis.design import kit_metrics
    from analysis.kit_replay import replay_plan

    t0 = ctx.clock()
    scenes = kit.scenes(ctx.settings.contact, **_engine_changes(ctx))
    built = [ctx.build(scene, st.build, f"kit: {name}") for name, scene in zip(kit.names, scenes)]
    models = [m for m, _ in built]
    m = kit_metrics(models, target="cell", seed=ctx.seed("kits"), count=st.count, runs=st.runs, epsilon=st.epsilon,
                    node_budget=st.node_budget)
    own = [kit_metrics([x], target="cell", seed=ctx.seed("kits"), count=st.count, runs=st.runs, epsilon=st.epsilon,
                       node_budget=st.node_budget) for x in models]
    model_seconds = ctx.clock() - t0
    out = {"compartments": [dict(c.to_dict(), states=x.n_states, model=info.cache_key)
                            for c, (x, info) in zip(kit.compartments, built)],
           "plan": {k: m[k] for k in ("word", "plan_length", "exact", "lower_bound", "final_cells",
                                      "success_probabilities", "joint_success")},
           "own": [{k: o[k] for k in ("word", "plan_length", "exact", "lower_bound", "converging_share",
                                      "expected_tilts", "expected_tilts_ci", "expected_tilts_lower")} for o in own],
           "random": {k: m[k] for k in ("converging_share", "converging_share_ci", "expected_tilts",
                                        "expected_tilts_ci", "expected_tilts_censored", "expected_tilts_lower")},
           "model_seconds": model_seconds}
    direct = ()
    if m["word"]:
        ctx.log(f"kit plan replayed with {st.replay_trials} trials per compartment")
        t1 = ctx.clock()
        rep = replay_plan(scenes, kit.names, m["word"], m["final_cells"], m["success_probabilities"],
                          st.replay_trials, seed=ctx.seed("kits.replay"), workers=ctx.workers)
        direct = tuple(rep.pop("results"))
        rep["seconds"] = ctx.clock() - t1
        out["replay"] = rep
    return out, direct, tuple(scenes)


def _design(ctx, st: Settings) -> dict:
    """The key's design sweep (compartment side x tilt), from the model cache when built before."""
    from analysis.design import Sweep, run_design
    from analysis.kit import parse_kit
    from transition_builder.builder import BuildSettings

    t0 = ctx.clock()
    comp = {"name": ctx.settings.shape, "size_mm": [200, 200], "shape": ctx.settings.shape}
    if ctx.settings.friction is not None:
        comp["friction"] = ctx.settings.friction
    res = run_design(parse_kit({"compartments": [comp]}), Sweep(st.design_tray_mm, (1.0,), st.design_tilt_deg),
                     BuildSettings(seed=ctx.settings.seed, **st.build), contact=ctx.settings.contact,
                     setting_changes=_engine_changes(ctx), workers=ctx.workers, log=ctx.log, target="cell", seed=ctx.seed("kits.design"), count=st.count,
                     runs=st.runs, epsilon=st.epsilon, node_budget=st.node_budget)
    res.pop("_scenes")
    rows = res["variants"]
    ref = next((i for i, r in enumerate(rows) if r["tray_mm"] == [200.0, 200.0] and r["tilt_deg"] == 30.0), None)
    res["reference"] = ref
    res["seconds"] = ctx.clock() - t0
    res["source"] = ctx.settings.shape
    res["target"] = "cell"
    return res


def run(ctx) -> Result:
    st = Settings.from_settings(ctx.settings)
    if not st.on:
        return Result({}, {})
    kit = _kit_of(st, ctx)
    out, direct, scenes = _kit_answers(ctx, st, kit)
    return Result(out, _design(ctx, st), direct, scenes)


def _plan_rows(k: dict) -> list[str]:
    lines = ["| | shortest plan (cell target) | length | proven | expected random tilts (95%) | "
             "converging share of random 50-tilt sequences |", "|---|---|---|---|---|---|"]
    for c, o in zip(k["compartments"], k["own"]):
        lines.append(f"| {c['name']} alone ({c['shape']}, {c['size_mm'][0]:g} x {c['size_mm'][1]:g} mm) | "
                     f"`{','.join(o['word']) if o['word'] else '-'}` | {fmt(o['plan_length'], 'd')} | "
                     f"{'yes' if o['exact'] else 'no'} | {_tilts(o)} | {o['converging_share']:.1%} |")
    p, r = k["plan"], k["random"]
    lines.append(f"| **the kit** (one sequence for all) | `{','.join(p['word']) if p['word'] else '-'}` | "
                 f"{fmt(p['plan_length'], 'd')} | {'yes' if p['exact'] else 'no (>= ' + str(p['lower_bound']) + ')'} | "
                 f"{_tilts(r)} | {r['converging_share']:.1%} {interval(r['converging_share_ci'], '.3f')} |")
    return lines


def _tilts(o: dict) -> str:
    if o.get("expected_tilts") is not None:
        return f"{o['expected_tilts']:.1f} {interval(o.get('expected_tilts_ci'), '.1f')}"
    return f">= {fmt(o.get('expected_tilts_lower'), '.1f')} (censored)"


def _design_rows(d: dict) -> list[str]:
    lines = ["| tray (mm) | tilt | plan | proven | expected random tilts (95%) | converging share | |",
             "|---|---|---|---|---|---|---|"]
    for i, v in enumerate(d["variants"]):
        mark = ", ".join(x for x, on in (("best", i == d["best"]), ("Pareto", i in d["pareto"]),
                                         ("the paper's tray", i == d.get("reference"))) if on)
        lines.append(f"| {v['tray_mm'][0]:g} x {v['tray_mm'][1]:g} | {v['tilt_deg']:g} | {fmt(v['plan_length'], 'd')} "
                     f"| {'yes' if v['exact'] else 'no'} | {_tilts(v)} | {v['converging_share']:.1%} | {mark} |")
    return lines


def markdown(r: Result) -> str:
    k, d = r.kit, r.design
    if not k:
        return ""
    lines = ["## Kits and trays", "",
             "The paper's future work: one tilt program for a kit of parts, each in its own compartment of one tray "
             "(`kruskal plan --kit`, `docs/kits.md`). The parts move independently given the sequence, so the kit's "
             "plan is the robust plan over the compartments' models (proven shortest like a single part's), and its "
             "random figures come from shared random sequences, every part oriented at once.", ""]
    lines += _plan_rows(k)
    rep = k.get("replay")
    if rep:
        lines += ["", f"Replayed by direct simulation ({rep['trials']:,} trials per compartment, "
                      f"{rep['seconds']:.0f} s): " + "; ".join(
                          f"{c['name']} {c['share']:.1%} in its predicted cell {interval(c['share_ci95'], '.3f')}, "
                          f"model {c['model_success']:.3f}" + ("" if c["within"] else " (**outside the interval**)")
                          for c in rep["compartments"])
                  + f". The whole kit in its cells: {rep['joint_share']:.1%} (model {rep['joint_model_success']:.3f}).",
                  "", "![the kit's plan](kits_animation.gif)"]
    if d and d.get("variants"):
        lines += ["", f"**The key's tray** (`kruskal design`, {len(d['variants'])} variants, {d['seconds']:.0f} s): "
                      "compartment size and tilt angle against the shortest plan and the random tilts.", ""]
        lines += _design_rows(d)
        ref, best = d.get("reference"), d["variants"][d["best"]]
        if ref is not None and best["plan_length"] is not None and d["variants"][ref]["plan_length"] is not None:
            old, new = d["variants"][ref]["plan_length"], best["plan_length"]
            lines += ["", f"The best tray ({best['tray_mm'][0]:g} mm at {best['tilt_deg']:g} degrees) "
                          + (f"shortens the plan from {old} (the paper's 200 mm at 30 degrees) to {new} tilts."
                             if new < old else f"does not shorten the plan of the paper's tray ({old} tilts).")]
        lines += ["", "![design](fig_kit_design.png)"]
    return "\n".join(lines) + "\n"


def figures(r: Result, out: str) -> list[str]:
    if not r.kit:
        return []
    from analysis.kit_figures import animate_kit, pareto_figure

    paths = []
    if r.direct:
        paths.append(animate_kit(list(r.direct), list(r.scenes), [c["name"] for c in r.kit["compartments"]],
                                 os.path.join(out, "kits_animation.gif")))
    if r.design and r.design.get("variants"):
        paths.append(pareto_figure(r.design, os.path.join(out, "fig_kit_design.png")))
    return paths
