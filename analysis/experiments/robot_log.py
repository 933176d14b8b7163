"""A robot's log beside the model: A's best sequence in direct simulation, written as a ``--poses``
CSV, read back and compared with the model's prediction (no entries of its own in ``results.json``;
the numbers are A's ``best_direct``)."""
from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class Result:
    """The key's shape and experiment A's result."""

    shape: str
    a: object

    def to_dict(self) -> dict:
        return {}


def run(ctx) -> Result:
    return Result(ctx.settings.shape, ctx.result("A"))


def markdown(r: Result) -> str:
    a, bd = r.a, r.a.best_direct
    if "entropy_bits_log" not in bd:
        return ""
    model_h = np.asarray(a.best_entropy)
    log_h = np.asarray(bd["entropy_bits_log"])
    return "\n".join([
        "## A robot's log beside the model", "",
        "A physical tray's camera log, one row per part and tilt in the `--poses` CSV format "
        "(`trial,step,x_mm,y_mm,theta_rad,status`; docs/commands.md), is compared with the model "
        "like this:", "", "```",
        f"kruskal entropy --poses log.csv --shape {r.shape} --json         # the log's entropy",
        f"kruskal entropy --model KEY.npz --sequence {','.join(a.best_sequence[:4])},... --json"
        "   # the model's prediction", "```", "",
        f"Here the log is the direct simulation of A's best sequence ({bd['trials']} trials), written "
        f"and read back through that CSV: its entropy agrees with the simulation's to "
        f"{np.abs(log_h - np.asarray(bd['entropy_bits'])).max():.1e} bits, and the model's "
        f"prediction differs from it by {np.abs(model_h - log_h).mean():.3f} bits on average "
        f"(max {np.abs(model_h - log_h).max():.2f}; the log's own sampling noise at "
        f"{bd['trials']} trials is part of that).", ""])


def figures(r: Result, out: str) -> list[str]:
    return []
