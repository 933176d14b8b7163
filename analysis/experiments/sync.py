"""The key's optimal sensorless plan and the expected length of a random sequence, from its model;
the plan replayed in direct simulation (``key_metrics``, ``sync_replay``)."""
from __future__ import annotations

import dataclasses

import numpy as np

from analysis.experiments.model_answers import key_metrics
from analysis.experiments.plotting import pyplot, save
from analysis.experiments.text import expected_text


@dataclasses.dataclass(frozen=True)
class Settings:
    """The search's time budget, the replay's trials, the Monte Carlo runs and the threshold."""

    sync_time_budget: float
    replay_trials: int
    runs: int
    epsilon: float

    @classmethod
    def from_settings(cls, s) -> "Settings":
        return cls(s.sync_time_budget, s.replay_trials, s.metrics_runs, s.epsilon)


@dataclasses.dataclass(frozen=True)
class Result:
    """The key's :class:`~analysis.orientability.PartMetrics` and, when a word was found, its replay."""

    settings: Settings
    metrics: object
    replay: dict | None

    def to_dict(self) -> dict:
        out = {"key_metrics": self.metrics.to_dict()}
        if self.replay is not None:
            out["sync_replay"] = self.replay
        return out


def run(ctx) -> Result:
    from kruskal_markov.entropy import entropy_trajectory

    st = Settings.from_settings(ctx.settings)
    model, _ = ctx.key_model()
    ctx.log("the key's shortest synchronizing word and expected random lengths")
    km = key_metrics(ctx, model, sync_time_budget=st.sync_time_budget)
    replay = None
    if km.sync_word:
        model_curve = entropy_trajectory(model, km.sync_word).entropy_bits
        ctx.log(f"sync word ({km.sync_length} tilts) replayed with {st.replay_trials} trials")
        replay = ctx.direct(ctx.scene(), km.sync_word, st.replay_trials, "sync.replay")
        replay["model_entropy_bits"] = model_curve.tolist()
    return Result(st, km, replay)


def markdown(r: Result) -> str:
    km = r.metrics.to_dict()
    lines = [
        f"**Expected length of a random sequence**: {expected_text(km, 'random_tilts', 'random_tilts_ci95', 'random_tilts_lower')} random "
        f"tilts until the predicted entropy is <= {r.settings.epsilon:g} bits ({km['random_tilts_censored']} of "
        f"{r.settings.runs} runs not converged within 1,000 tilts); "
        f"{expected_text(km, 'random_sync_length', 'random_sync_ci95', 'random_sync_lower')} tilts until every start state of the support "
        f"automaton is merged ({km['random_sync_censored']} runs censored).",
        "",
    ]
    if r.replay is not None:
        rep = r.replay
        proof = ("proven shortest" if km["sync_exact"]
                 else f"not proven shortest; lower bound {km['sync_lower_bound']}")
        lines += [
            f"**The shortest synchronizing word** (plan target `{km.get('sync_target', 'state')}`) for the key: "
            f"`{','.join(km['sync_word'])}` ({km['sync_length']} tilts, "
            f"{proof}). "
            f"Replayed in direct simulation with {rep['trials']:,} trials it ends at {rep['entropy_bits'][-1]:.3f} bits "
            f"({sum(rep['faults'].values())} faulted trials); the model predicts {rep['model_entropy_bits'][-1]:.3f}.",
            "",
            "![sync](fig_sync_replay.png)",
            "",
        ]
    return "\n".join(lines)


def figures(r: Result, out: str) -> list[str]:
    if r.replay is None:
        return []
    rep = r.replay
    fig, ax = pyplot().subplots(figsize=(6.5, 4))
    x = np.arange(len(rep["entropy_bits"]))
    ax.plot(x, rep["model_entropy_bits"], "o-", color="tab:blue", label="model")
    ax.plot(x, rep["entropy_bits"], "s--", color="tab:red", label=f"direct simulation, M = {rep['trials']:,}")
    ax.set_xticks(x, ["start"] + list(r.metrics.sync_word), fontsize=7)
    ax.set_ylabel("entropy (bits)"), ax.legend(fontsize=8)
    ax.set_title("the key's synchronizing word (optimal sensorless plan) replayed", fontsize=10)
    return save(fig, out, "fig_sync_replay.png")
