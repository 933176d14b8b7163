"""One type for "a model's paper-level answers": :class:`ModelAnswers`, computed by :func:`model_answers`.

The contact-model comparison and the sensitivity study ask every key model the same questions
(experiment A's count, the converging share of random sequences, mean entropies, the shortest
plans, the expected random tilts); this is the one place they are computed, on the same random
streams for every model (``A`` and ``answers``), so that the models are compared on the same
sequences. The orientability metrics themselves are :func:`analysis.orientability.part_metrics`.
"""
from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["ModelAnswers", "converged_summary", "key_metrics", "model_answers"]


def converged_summary(steps: np.ndarray) -> dict:
    """How many of ``steps`` (first converged step per sequence, -1: never) converge, of how many,
    their mean convergence step and the fastest."""
    ok = steps[steps >= 0]
    return {"converged": int(ok.size), "of": int(steps.size),
            "mean_convergence_tilt": float(ok.mean()) if ok.size else None,
            "fastest": int(ok.min()) if ok.size else None}


@dataclasses.dataclass(frozen=True)
class ModelAnswers:
    """The paper-level answers of one model.

    Attributes
    ----------
    states : int
        States of the model.
    a_converged, a_sequences : int
        Of experiment A's random sequences (stream ``A``), how many converge.
    ensemble_count : int
        Random sequences of the ensemble (stream ``answers``).
    converging_share, mean_convergence_tilt, mean_entropy_20, mean_entropy_end
        The ensemble's converging share, mean convergence tilt (converging ones) and mean entropy
        (bits) at tilt 20 and at its last tilt.
    metrics : PartMetrics
        The orientability metrics (shortest word, expected random tilts).
    intervals : dict or None
        :func:`kruskal_markov.answers.answer_intervals` of the ensemble's answers (None: not asked).
    cell_plan : dict or None
        The shortest one-cell plan's ``length``, ``exact`` and ``lower_bound`` (None: not asked).
    """

    states: int
    a_converged: int
    a_sequences: int
    ensemble_count: int
    converging_share: float
    mean_convergence_tilt: float | None
    mean_entropy_20: float
    mean_entropy_end: float
    metrics: object
    intervals: dict | None = None
    cell_plan: dict | None = None

    def to_dict(self) -> dict:
        """The contact comparison's row (``contact_models`` entries of ``results.json``)."""
        m = self.metrics
        return {"states": self.states, "a_converged": self.a_converged, "a_sequences": self.a_sequences,
                "ensemble_count": self.ensemble_count, "converging_share": self.converging_share,
                "mean_convergence_tilt": self.mean_convergence_tilt, "mean_entropy_20": self.mean_entropy_20,
                "mean_entropy_end": self.mean_entropy_end, "sync_length": m.sync_length,
                "sync_exact": m.sync_exact, "sync_lower_bound": m.sync_lower_bound,
                "random_tilts": m.random_tilts, "random_tilts_censored": m.random_tilts_censored}

    def interval_dict(self) -> dict:
        """The answers with their intervals (the sensitivity study's ``settings`` entries)."""
        out = {k: v for k, v in (self.intervals or {}).items() if k != "settings"}
        out["random_tilts"] = self.metrics.intervals["random_tilts"]
        out["cell_plan"] = self.cell_plan
        out["a_converged"] = self.a_converged
        out["a_sequences"] = self.a_sequences
        out["states"] = self.states
        return out


def key_metrics(ctx, model, *, sync_time_budget: float, draws: int = 10):
    """:func:`analysis.orientability.part_metrics` with the run's counts, epsilon, node budget and
    the stream ``metrics``, once per model and budget."""
    from analysis.orientability import part_metrics

    s = ctx.settings
    return ctx.memo(("metrics", id(model), sync_time_budget, draws), lambda: part_metrics(
        model, seed=ctx.seed("metrics"), count=s.metrics_count, runs=s.metrics_runs, epsilon=s.epsilon,
        sync_time_budget=sync_time_budget, sync_node_budget=s.sync_node_budget, draws=draws))


def model_answers(ctx, model, metrics, *, intervals: bool = False) -> ModelAnswers:
    """The paper-level answers of ``model`` (see :class:`ModelAnswers`).

    Parameters
    ----------
    ctx : Context
        Counts, epsilon and budgets (``ctx.settings``), the memo and the streams.
    model : TransitionModel
    metrics : PartMetrics
        The model's orientability metrics (:func:`key_metrics`).
    intervals : bool
        Also the answers' intervals (:func:`kruskal_markov.answers.answer_intervals`) and the
        shortest one-cell plan within ``part_sync_time_budget``.
    """
    s = ctx.settings
    a = ctx.ensemble(model, s.a_sequences, "A")
    big = ctx.ensemble(model, s.contact_ensemble_count, "answers")
    conv = converged_summary(big.convergence_steps)
    iv = plan = None
    if intervals:
        from kruskal_markov.answers import answer_intervals
        from kruskal_markov.sync import shortest_plan

        iv = answer_intervals(model, seed=ctx.seed("answers"), count=s.contact_ensemble_count, length=s.length,
                              epsilon=s.epsilon, ensemble=big, draws=10, draw_count=1000, structural_sequences=100)
        budget = {} if s.sync_node_budget is None else {"node_budget": s.sync_node_budget}
        p = shortest_plan(model, "cell", time_budget=s.part_sync_time_budget, **budget)
        plan = {"length": p.length, "exact": bool(p.exact), "lower_bound": p.lower_bound}
    return ModelAnswers(states=int(model.n_states), a_converged=int(a.converged), a_sequences=int(s.a_sequences),
                        ensemble_count=int(s.contact_ensemble_count),
                        converging_share=conv["converged"] / s.contact_ensemble_count,
                        mean_convergence_tilt=conv["mean_convergence_tilt"],
                        mean_entropy_20=float(big.mean[min(20, s.length)]), mean_entropy_end=float(big.mean[-1]),
                        metrics=metrics, intervals=iv, cell_plan=plan)
