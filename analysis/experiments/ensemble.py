"""Experiment A at scale: ``ensemble_count`` random sequences through the key's model instead of
43 (``ensemble``)."""
from __future__ import annotations

import dataclasses

import numpy as np

from analysis.experiments.curves import first_at_most, settled_steps
from analysis.experiments.model_answers import converged_summary
from analysis.experiments.plotting import pyplot, save
from analysis.experiments.text import fmt


@dataclasses.dataclass(frozen=True)
class Settings:
    """Random sequences of ``length`` tilts and the convergence threshold."""

    count: int
    length: int
    epsilon: float

    @classmethod
    def from_settings(cls, s) -> "Settings":
        return cls(s.ensemble_count, s.length, s.epsilon)


@dataclasses.dataclass(frozen=True)
class Result:
    """The ensemble's statistics (the sequences themselves are not kept) beside A's mean."""

    settings: Settings
    summary: dict
    a_mean: np.ndarray
    a_sequences: int

    def to_dict(self) -> dict:
        return {"ensemble": self.summary}


def run(ctx) -> Result:
    from kruskal_markov.ensemble import run_ensemble

    st = Settings.from_settings(ctx.settings)
    model, _ = ctx.key_model()
    a = ctx.result("A")
    ctx.log(f"{st.count:,} random sequences through the key's model")
    t0 = ctx.clock()
    big = run_ensemble(model, st.count, st.length, seed=ctx.seed("ensemble"), epsilon=st.epsilon, keep_entropy=True)
    steps = big.convergence_steps
    hist = np.bincount(steps[steps >= 0], minlength=st.length + 1)
    summary = {"count": st.count, "mean": big.mean.tolist(), "q25": big.q25.tolist(), "q75": big.q75.tolist(),
               **converged_summary(steps), "converged_by_tilt": np.cumsum(hist).tolist(),
               "mean_near_zero_by": first_at_most(big.mean, 0.1),
               "best_sequence": [model.actions[x] for x in big.best_sequence],
               "settled": converged_summary(settled_steps(big.entropy, st.epsilon)), "seconds": ctx.clock() - t0}
    return Result(st, summary, a.mean, len(a.entropy))


def markdown(r: Result) -> str:
    e, n = r.summary, r.settings.length
    a_mean = r.a_mean
    return "\n".join([
        "## Beyond the paper",
        "",
        f"**{e['count']:,} random sequences instead of 43** ({e['seconds']:.0f} s): {e['converged']:,} "
        f"({100 * e['converged'] / e['count']:.1f}%) reach zero within {n} tilts"
        + (f" and {e['settled']['converged']:,} ({100 * e['settled']['converged'] / e['count']:.1f}%) stay there"
           if "settled" in e else "") + ", the fastest in "
        f"{fmt(e['fastest'], 'd', '-')}; mean convergence tilt {fmt(e['mean_convergence_tilt'], '.1f')}; "
        f"mean entropy {e['mean'][min(20, n)]:.2f} bits at tilt 20 and {e['mean'][-1]:.2f} at tilt {n} "
        f"(the 43-sequence sample: {a_mean[min(20, n)]:.2f} and {a_mean[-1]:.2f}).",
        "",
        "![A at scale](fig_a_million.png)",
        "",
    ])


def figures(r: Result, out: str) -> list[str]:
    e = r.summary
    fig, (ax1, ax2) = pyplot().subplots(1, 2, figsize=(11, 4))
    x = np.arange(len(e["mean"]))
    ax1.fill_between(x, e["q25"], e["q75"], color="tab:blue", alpha=0.3, label=f"IQR, {e['count']:,} sequences")
    ax1.plot(x, e["mean"], color="tab:red", lw=2.5, label=f"mean, {e['count']:,} sequences")
    ax1.plot(x, r.a_mean, color="black", lw=1.2, ls="--", label=f"mean, {r.a_sequences} sequences (A)")
    ax1.set_xlabel("tilt"), ax1.set_ylabel("entropy (bits)"), ax1.legend(fontsize=7)
    ax1.set_title("A at scale: the mean and IQR", fontsize=10)
    ax2.plot(x, np.asarray(e["converged_by_tilt"]) / e["count"], color="tab:purple")
    ax2.set_xlabel("tilt"), ax2.set_ylabel("share of sequences converged")
    ax2.set_title(f"converged (entropy <= {r.settings.epsilon:g} bits) by tilt", fontsize=10)
    return save(fig, out, "fig_a_million.png")
