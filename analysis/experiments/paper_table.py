"""The paper's numbers beside ours: one table from experiments A, B, C and the key's plan
(``paper``: the paper's own figures, :data:`~analysis.experiments.paper.PAPER`)."""
from __future__ import annotations

import dataclasses

import numpy as np

from analysis.experiments.curves import first_at_most, settled_steps
from analysis.experiments.paper import PAPER
from analysis.experiments.text import fmt


@dataclasses.dataclass(frozen=True)
class Result:
    """The results the table cites."""

    a: object
    b: object
    c: object
    sync: object

    def to_dict(self) -> dict:
        return {"paper": PAPER}


def run(ctx) -> Result:
    return Result(ctx.result("A"), ctx.result("B"), ctx.result("C"), ctx.result("sync"))


def _best_text(a) -> str:
    eps = a.settings.epsilon
    reach = first_at_most(a.best_entropy, eps)
    settle = int(settled_steps(a.best_entropy, eps)[0])
    bd = a.best_direct
    return (f"the model's best reaches zero at tilt {fmt(reach, 'd', 'never')}"
            + (f" and stays from tilt {settle}" if settle >= 0 else ", then splits again (ends at "
               f"{a.best_entropy[-1]:.2f} bits)")
            + f"; in direct simulation (M = {bd['trials']}) it reaches "
            f"{min(bd['entropy_bits']):.3f} bits at best and ends at {bd['entropy_bits'][-1]:.3f}")


def _a_rows(a) -> list[str]:
    p, n = PAPER["A"], a.settings.length
    a_settled = int(np.count_nonzero(settled_steps(a.entropy, a.settings.epsilon) >= 0))
    return [f"| A: random sequences converging to zero | {p['converged']} of {p['sequences']} | "
            f"{a_settled} of {a.converged['of']} reach zero and stay there to tilt {n}; {a.converged['converged']} "
            "reach it at some tilt (model) |",
            f"| A: mean entropy near zero (<= 0.1 bits) by tilt | ~{p['near_zero_by']} | "
            f"{fmt(a.mean_near_zero_by, 'd', 'not within ' + str(n))} |",
            f"| A: mean convergence tilt of the converging ones | - | "
            f"{fmt(a.converged['mean_convergence_tilt'], '.1f')} (first reach) |",
            f"| A: best random sequence converges in | {p['best_length']} tilts | {_best_text(a)} |"]


def _b_rows(b, eps: float, n: int) -> list[str]:
    p = PAPER["B"]
    model_end = sum(q["entropy_bits"][-1] <= eps for q in b.parts.values())
    direct_end = sum(q["direct"]["entropy_bits"][-1] == 0.0 for q in b.parts.values())
    return [f"| B: parts converging under the best sequence | {p['converged']} of {p['parts']} | "
            f"models: {b.converged} of {len(b.parts)} reach zero, {model_end} end there; direct "
            f"(M = {b.settings.trials}): {b.converged_direct} reach zero, {direct_end} end there |",
            f"| B: mean near zero by tilt | ~{p['near_zero_by']} | "
            f"{fmt(b.mean_near_zero_by, 'd', 'not within ' + str(n))} |"]


def _c_rows(c) -> list[str]:
    rows = []
    for level, g in c.levels.items():
        pc, pn = PAPER["C"][level]
        ends = sum(m["entropy_bits"][-1] == 0.0 for m in c.of_level(level))
        rows.append(f"| C: {level}-noise friction maps converging | {pc} of {pn} | {g['converged']} of {g['maps']} "
                    f"reach zero (mean tilt {fmt(g['mean_zero_at'], '.1f')}), {ends} end there "
                    f"(direct, M = {c.settings.trials}) |")
    return rows


def _plan_row(km) -> str:
    plan = (f"{km.sync_length} tilts (target {km.sync_target}; "
            + ("proven shortest" if km.sync_exact else f"greedy; lower bound {fmt(km.sync_lower_bound, 'd')}")
            + ")" if km.sync_length is not None else
            f"none found within the time budget (lower bound {fmt(km.sync_lower_bound, 'd')} tilts)")
    return (f"| optimal sensorless plan for the key | Erdmann and Mason: {PAPER['erdmann_mason_plan_length']} "
            f"tilts (by hand) | {plan} |")


def markdown(r: Result) -> str:
    lines = ["## The paper's numbers beside ours", "", "| experiment | paper | this report |", "|---|---|---|"]
    lines += _a_rows(r.a) + _b_rows(r.b, r.a.settings.epsilon, r.a.settings.length) + _c_rows(r.c)
    lines += [_plan_row(r.sync.metrics), ""]
    return "\n".join(lines)


def figures(r: Result, out: str) -> list[str]:
    return []
