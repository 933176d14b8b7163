"""Experiment A (the paper's Fig. 3): the key under random 50-tilt sequences through its model, the
best sequence replayed in direct simulation (``A``)."""
from __future__ import annotations

import dataclasses

import numpy as np

from analysis.experiments.curves import best_settled, first_at_most, settled_steps
from analysis.experiments.model_answers import converged_summary
from analysis.experiments.plotting import pyplot, save, trend_axes

BEST_RULE = "settles first (reaches entropy <= epsilon and stays there), else reaches first"


@dataclasses.dataclass(frozen=True)
class Settings:
    """Sequences of ``length`` tilts, the convergence threshold and the direct check's trials."""

    sequences: int
    length: int
    epsilon: float
    check_trials: int

    @classmethod
    def from_settings(cls, s) -> "Settings":
        return cls(s.a_sequences, s.length, s.epsilon, s.a_check_trials)


@dataclasses.dataclass(frozen=True)
class Result:
    """The sequences' entropy curves, their statistics and the best sequence (action names)."""

    settings: Settings
    entropy: np.ndarray
    mean: np.ndarray
    q25: np.ndarray
    q75: np.ndarray
    best_index: int
    best_sequence: list
    converged: dict
    settled: dict
    mean_near_zero_by: int | None
    best_direct: dict

    @property
    def best_entropy(self) -> np.ndarray:
        return self.entropy[self.best_index]

    def to_dict(self) -> dict:
        return {"A": {"entropy": self.entropy.tolist(), "mean": self.mean.tolist(), "q25": self.q25.tolist(),
                      "q75": self.q75.tolist(), "best_index": self.best_index, "best_sequence": self.best_sequence,
                      "best_rule": BEST_RULE, "best_entropy": self.best_entropy.tolist(), **self.converged,
                      "settled": self.settled, "mean_near_zero_by": self.mean_near_zero_by,
                      "best_direct": self.best_direct}}


def run(ctx) -> Result:
    st = Settings.from_settings(ctx.settings)
    model, _ = ctx.key_model()
    ctx.log(f"A: {st.sequences} random sequences of {st.length} tilts")
    ens = ctx.ensemble(model, st.sequences, "A", keep_entropy=True)
    best_index = best_settled(ens.entropy, st.epsilon, ens.best_index)
    best = [model.actions[a] for a in ens.sequences[best_index]]
    ctx.log(f"A: best sequence replayed in direct simulation ({st.check_trials} trials)")
    direct = ctx.direct(ctx.scene(), best, st.check_trials, "A.check", recorded=True)
    direct["zero_at"] = first_at_most(direct["entropy_bits"], 0.0)
    return Result(st, ens.entropy, ens.mean, ens.q25, ens.q75, best_index, best,
                  converged_summary(ens.convergence_steps), converged_summary(settled_steps(ens.entropy, st.epsilon)),
                  first_at_most(ens.mean, 0.1), direct)


def markdown(r: Result) -> str:
    return "\n".join([
        "![A](fig_a_random_sequences.png)",
        "",
        f"Best sequence (A; chosen as the one that {BEST_RULE}): "
        f"`{','.join(r.best_sequence)}`. Zero entropy on the report grid means one *cell*, not one pose: "
        "a sequence can reach it and split again, which is why reaching and staying are counted apart.",
        "",
    ])


def figures(r: Result, out: str) -> list[str]:
    fig, ax = pyplot().subplots(figsize=(6.5, 4))
    trend_axes(ax, r.entropy, r.mean, r.q25, r.q75,
               f"A: {len(r.entropy)} random sequences through the key's model", best=r.best_entropy)
    return save(fig, out, "fig_a_random_sequences.png")
