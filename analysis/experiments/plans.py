"""Plans for every target on the key's model, replayed in direct simulation, and how rare good
plans are among random words (``plans``; ``docs/plans.md``)."""
from __future__ import annotations

import dataclasses
import os

import numpy as np

from analysis.experiments.text import fmt, interval


@dataclasses.dataclass(frozen=True)
class Settings:
    """The plan targets (besides ``state``), random words per target, the longest word, the search
    budgets and the replay's trials."""

    targets: tuple
    words: int
    length: int
    sync_time_budget: float
    sync_node_budget: int | None
    replay_trials: int

    @classmethod
    def from_settings(cls, s) -> "Settings":
        return cls(tuple(s.plan_targets), s.plan_words, s.length, s.sync_time_budget, s.sync_node_budget,
                   s.replay_trials)


@dataclasses.dataclass(frozen=True)
class Result:
    """Per target: the random words' success curve, the shortest plan and its replay (``state``'s plan
    is the key's synchronizing word, :mod:`analysis.experiments.sync`)."""

    settings: Settings
    plans: dict
    sync: object

    def to_dict(self) -> dict:
        return {"plans": self.plans}


def plan_replay(ctx, scene, plan: dict, trials: int, stream: str) -> dict:
    """Replay a plan in direct simulation: the entropy after its last tilt, the faults, and the share
    of trials that end in the plan's final report cell (``final_cell``) as the model predicts."""
    from analysis.montecarlo import run_direct

    res = run_direct(scene, plan["word"], trials, seed=ctx.seed(stream), workers=ctx.workers)
    last = res.poses[:, -1, :]
    ok = np.all(np.isfinite(last), axis=1)
    cells = res.grid.voxel_index(last[ok])
    share = float(np.count_nonzero(cells == plan["final_cell"]) / trials)
    return {"entropy_bits": float(res.entropy_bits[-1]), "trials": int(trials), "faults": dict(res.faults),
            "share_in_final_cell": share, "model_success": plan["success_probability"]}


def _target_entry(ctx, model, target: str, st: Settings) -> dict:
    from kruskal_markov.sync import random_word_success, shortest_plan

    entry = {"success": random_word_success(model, target, max_length=st.length, words=st.words,
                                            seed=ctx.seed(f"plans.words:{target}"))}
    if target == "state":      # the state plan is the key's synchronizing word
        return entry
    budget = {} if st.sync_node_budget is None else {"node_budget": st.sync_node_budget}
    plan = shortest_plan(model, target, time_budget=st.sync_time_budget, **budget)
    entry["plan"] = plan.to_dict()
    if plan.word:
        from kruskal_markov.answers import plan_success_interval

        entry["plan"]["success_interval"] = plan_success_interval(
            model, [model.actions.index(a) if isinstance(a, str) else int(a) for a in plan.word],
            plan.success_probability, draws=20, seed=ctx.seed("plans.interval"), final_cell=plan.final_cell)
        ctx.log(f"{target} plan replayed with {st.replay_trials} trials")
        entry["replay"] = plan_replay(ctx, ctx.scene(), entry["plan"], st.replay_trials, f"plans.replay:{target}")
    return entry


def run(ctx) -> Result:
    st = Settings.from_settings(ctx.settings)
    model, _ = ctx.key_model()
    sync = ctx.result("sync")
    plans = {target: _target_entry(ctx, model, target, st) for target in ("state",) + st.targets}
    return Result(st, plans, sync)


def _replayed(e: dict, p_: dict | None, sync_replay: dict | None) -> str:
    rp = e.get("replay")
    if rp is None and p_ is None and sync_replay is not None:      # the state plan: the sync word's replay
        return f"entropy {sync_replay['entropy_bits'][-1]:.3f} bits"
    if rp is not None:
        disagree = " **(disagrees with the model)**" if rp["share_in_final_cell"] < rp["model_success"] - 0.01 else ""
        return (f"{rp['share_in_final_cell']:.2%} of {rp['trials']:,}, {rp['entropy_bits']:.3f} bits, "
                f"{sum(rp['faults'].values())} faults{disagree}")
    return "-"


def _row(t: str, e: dict, km, sync_replay) -> str:
    p_ = e.get("plan")
    if p_ is None:
        word, length, exact, succ = km.sync_word, km.sync_length, km.sync_exact, None
    else:
        word, length, exact, succ = p_["word"], p_["length"], p_["exact"], p_["success_probability"]
    prob = e["success"]["probability"]
    at = prob[length] if length is not None and length < len(prob) else None
    return (f"| `{t}` | `{','.join(word) if word else '-'}` | {fmt(length, 'd')} | "
            f"{'yes' if exact else 'no'} | {fmt(succ, '.4f')}"
            + (f" ({interval(p_['success_interval']['model_ci90'], '.4f')})"
               if p_ is not None and p_.get("success_interval") else "")
            + f" | {_replayed(e, p_, sync_replay)} | {fmt(at, '.4f')} | "
            f"{fmt(prob[min(20, len(prob) - 1)], '.3f')} / {fmt(prob[-1], '.3f')} |")


def markdown(r: Result) -> str:
    pl = r.plans
    if not pl:
        return ""
    lines = ["**Plans for every target** (`kruskal plan`, `docs/plans.md`): `state` drives every start state to "
             "one model state, `cell` into one report cell (the paper's \"all poses in one voxel\"), "
             "`probability:E` puts at least 1 - E of the start distribution into one cell.", "",
             "| target | shortest plan | length | proven shortest | model's success (model 90%) | replayed: trials "
             "in that cell, entropy after | random words of that length meeting it | at 20 / 50 tilts |",
             "|---|---|---|---|---|---|---|---|"]
    lines += [_row(t, e, r.sync.metrics, r.sync.replay) for t, e in pl.items()]
    lines += ["", f"Converging plans are common only well beyond the optimum ({pl[next(iter(pl))]['success']['words']:,} "
              "random words per target): the paper's \"converging plans are common, optimal plans are rare\", "
              "measured.", "", "![plans](fig_plans.png)", ""]
    return "\n".join(lines)


def figures(r: Result, out: str) -> list[str]:
    if not r.plans:
        return []
    from analysis.figures import random_word_success_figure

    pl = r.plans
    optimum = {t: (pl[t]["plan"]["length"] if "plan" in pl[t] else r.sync.metrics.sync_length) for t in pl}
    return [random_word_success_figure({t: pl[t]["success"] for t in pl}, os.path.join(out, "fig_plans.png"),
                                       optimum=optimum, title="how rare are good plans (the key's model)")]
