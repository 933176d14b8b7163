"""Does the answer depend on the contact model and the time step? The key's paper-level answers
under other floor contacts and finer steps, and the contact judges (``contact_models``,
``contact_judges``)."""
from __future__ import annotations

import dataclasses

from analysis.experiments.model_answers import key_metrics, model_answers
from analysis.experiments.paper import PAPER
from analysis.experiments.text import fmt

_JUDGE_COLUMNS = (("slide_mm", "free slide, worst final distance (mm)", ".2f"),
                  ("slide_deg", "free slide, worst final angle (deg)", ".2f"),
                  ("disk_stop_gap", "disk: sliding and spinning stop apart (share of the time)", ".1%"),
                  ("disk_ratio_error", "disk: late v / (R omega), relative error", ".1%"),
                  ("pure_slide_error", "pure sliding: stopping time v0 / (mu g), relative error", ".1%"),
                  ("pure_spin_error", "pure spinning: stopping time, relative error", ".1%"),
                  ("isotropy_slide", "isotropy: slide turned by 45 deg, displacement change", ".1%"),
                  ("isotropy_turn", "isotropy: slide turned by 45 deg, rotation change", ".1%"))


@dataclasses.dataclass(frozen=True)
class Settings:
    """The compared contacts (label, ``SimSettings`` changes), the finer steps (1/R), the compared
    models' build changes, whether the judges run, and what the table prints."""

    shape: str
    compare_contacts: tuple
    compare_refine: tuple
    key_build: dict
    contact_build: dict | None
    judges: bool
    sync_time_budget: float
    a_sequences: int
    length: int

    @classmethod
    def from_settings(cls, s) -> "Settings":
        return cls(s.shape, tuple(s.compare_contacts), tuple(s.compare_refine), dict(s.key_build),
                   s.contact_build, s.judges, s.sync_time_budget, s.a_sequences, s.length)

    @property
    def compare_build(self) -> dict:
        """The build changes of the compared models (``contact_build``, else ``key_build``)."""
        return self.key_build if self.contact_build is None else self.contact_build


@dataclasses.dataclass(frozen=True)
class Result:
    """Label -> :class:`ModelAnswers` (the default contact first) with the compared models' info,
    and the judges' table (None when not run)."""

    settings: Settings
    answers: dict
    models: dict
    judges: dict | None

    def to_dict(self) -> dict:
        rows = {k: {**a.to_dict(), **({"model": self.models[k].to_dict()} if k in self.models else {})}
                for k, a in self.answers.items()}
        return {"contact_models": rows, **({"contact_judges": self.judges} if self.judges is not None else {})}


def _variants(ctx, st: Settings):
    key_scene = ctx.scene()
    default = key_scene.settings.contact
    out = []
    if st.compare_build != st.key_build and (st.compare_contacts or st.compare_refine):
        out.append((f"{default} (compared resolution)", key_scene))
    out += [(str(label), key_scene.with_settings(**dict(changes))) for label, changes in st.compare_contacts]
    out += [(f"{default}, 1/{r} step", key_scene.with_settings(**key_scene.settings.finer_step(r)))
            for r in st.compare_refine]
    return out


def run(ctx) -> Result:
    st = Settings.from_settings(ctx.settings)
    key, _ = ctx.key_model()
    default = ctx.scene().settings.contact
    km = ctx.result("sync").metrics
    answers = {default: model_answers(ctx, key, km)}
    models = {}
    for label, scene in _variants(ctx, st):
        model, models[label] = ctx.build(scene, st.compare_build, f"{st.shape}, {label}")
        answers[label] = model_answers(ctx, model, key_metrics(ctx, model, sync_time_budget=st.sync_time_budget))
    judges = None
    if st.judges:
        from transition_builder.judges import JUDGE_TARGETS, judges_table

        ctx.log("the contact judges (free sliding against the integration of Coulomb's law)")
        judges = {"table": judges_table((default, "sphere", "legs:4", "legs:25")), "targets": JUDGE_TARGETS}
    return Result(st, answers, models, judges)


def contact_builds(s: dict) -> str:
    """How the compared contact models were built: the same settings, or which differ."""
    contact = s.get("contact_build")
    if contact is None or contact == s.get("key_build"):
        return "The same build settings, the same random sequences:"
    return (f"The same random sequences; the compared models were built with `{contact}`, the default's "
            f"with `{s.get('key_build')}`, so part of a difference can be the resolution's:")


def judges_lines(judges: dict) -> list:
    """The judges' table: every contact model against the integration of Coulomb's law."""
    table, targets = judges["table"], judges["targets"]
    keys = list(table)
    lines = ["**The judges** (free sliding on a level floor against a direct integration of distributed Coulomb "
             "friction, `transition_builder/judges.py`; each contact model at 1/16 of the default time step, so "
             "that the engine's integrator error stays below the targets; a cell in bold misses its target):", "",
             "| judge | target | " + " | ".join(f"`{k}`" for k in keys) + " |",
             "|---|---|" + "---|" * len(keys)]
    for key, label, f in _JUDGE_COLUMNS:
        cells = []
        for k in keys:
            v = table[k][key]
            text = "-" if v is None else ("inf" if v == float("inf") else format(v, f))
            cells.append(f"**{text}**" if v is None or v > targets[key] else text)
        lines.append(f"| {label} | {format(targets[key], f)} | " + " | ".join(cells) + " |")
    passed = [k for k in keys if all(table[k][c] is not None and table[k][c] <= targets[c] for c in targets)]
    lines += ["", f"Passing every judge: {', '.join(f'`{k}`' for k in passed) if passed else 'none'}.", ""]
    return lines


def _rows(st: Settings, cm: dict, keys: list):
    paper_a = PAPER["A"]
    return [("model states", "states", ",d", None),
            (f"A: of {st.a_sequences} random sequences converging", "a_converged", "d",
             f"{paper_a['converged']} of {paper_a['sequences']}"),
            (f"share of {cm[keys[0]]['ensemble_count']:,} random sequences converging", "converging_share", ".1%",
             f"{paper_a['converged'] / paper_a['sequences']:.0%}"),
            ("mean convergence tilt (converging ones)", "mean_convergence_tilt", ".1f", None),
            ("mean entropy at tilt 20 (bits)", "mean_entropy_20", ".2f", "about 0"),
            (f"mean entropy at tilt {st.length} (bits)", "mean_entropy_end", ".2f", None),
            ("shortest synchronizing word (tilts)", "sync_length", "d",
             f"best random {paper_a['best_length']}, hand plan {PAPER['erdmann_mason_plan_length']}"),
            ("expected random tilts to converge", "random_tilts", ".1f", None)]


def _verdicts(cm: dict, keys: list, rows) -> list[str]:
    """Each variant against the default contact built at the variants' resolution."""
    base_key = next((k for k in keys if k.endswith("(compared resolution)")), keys[0])
    base = cm[base_key]
    lines = []
    for other_key in [k for k in keys[1:] if k != base_key]:
        verdict = []
        other = cm[other_key]
        for label, k, _, _ in rows[1:]:
            x, y = base[k], other[k]
            if x is None or y is None:
                continue
            rel = abs(x - y) / max(abs(x), abs(y), 1e-9)
            verdict.append(f"{label}: {'within 10%' if rel <= 0.1 else 'differs by ' + format(rel, '.0%')}")
        lines += ["", f"`{other_key}` against `{base_key}` (relative difference): " + "; ".join(verdict) + "."]
    return lines


def _comparison_lines(st: Settings, cm: dict) -> list[str]:
    keys = list(cm)
    lines = ["**The paper-level answers** under each contact model and at a quarter of the default time step "
             "(same rest-test interval). " + contact_builds({"key_build": st.key_build,
                                                              "contact_build": st.contact_build}), "",
             "| answer | paper | " + " | ".join(f"`{k}`" for k in keys) + " |",
             "|---|---|" + "---|" * len(keys)]
    rows = _rows(st, cm, keys)
    for label, k, f, paper in rows:
        lines.append(f"| {label} | {paper or '-'} | " + " | ".join(fmt(cm[c][k], f) for c in keys) + " |")
    lines += _verdicts(cm, keys, rows)
    lines += [""]
    both = all(cm[k]["sync_length"] is not None for k in keys)
    lines += ["What holds under every contact model and step: "
              + ("a synchronizing word exists (" + ", ".join(str(cm[k]["sync_length"]) for k in keys)
                 + " tilts), " if both else "")
              + "random sequences orient the key (" + ", ".join(f"{100 * cm[k]['converging_share']:.0f}%"
                                                                for k in keys)
              + f" of random {st.length}-tilt sequences converge), and the expected random length is finite. "
              "Where the columns differ, the number is only as good as the contact model behind it: the default "
              "is the one that passes the judges above, and its column at a quarter of the step says how much "
              "of it is the time step's.", ""]
    return lines


def markdown(r: Result) -> str:
    cm = {k: a.to_dict() for k, a in r.answers.items()}
    if len(cm) <= 1 and not r.judges:
        return ""
    keys = list(cm)
    lines = ["## Does the answer depend on the contact model and the time step?", "",
             f"The default floor contact is `{keys[0]}`: distributed Coulomb friction under uniform pressure, "
             "computed over the part's footprint before every physics step (`docs/simulator.md`). The "
             "alternatives stay selectable with `--contact`: `sphere` (one support sphere with fixed force and "
             "torque limits, the default before simulator version 4) and `legs:K` (K point legs, biased by "
             "PyBullet's per-axis friction rows).", ""]
    if r.judges:
        lines += judges_lines(r.judges)
    if len(cm) > 1:
        lines += _comparison_lines(r.settings, cm)
    return "\n".join(lines)


def figures(r: Result, out: str) -> list[str]:
    return []
