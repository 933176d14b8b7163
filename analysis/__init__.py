"""What users run: the ``kruskal`` command line, direct simulation, experiments, figures and reports.

The API by topic
----------------
Direct simulation, the ground truth
    :func:`run_direct` (:class:`DirectResult`), :func:`write_poses_csv`, :func:`read_poses_csv`,
    :func:`entropy_by_step`, :func:`random_sequences_for`.
Models against the physics
    :func:`validate_model`.
Orientability
    :func:`part_metrics` (:class:`PartMetrics`), :func:`rank_parts`.
The paper's experiments
    :func:`reproduce` (:class:`ReproduceSettings`; returns a :class:`Report`), :func:`write_report`;
    the report's sections are :mod:`analysis.experiments` (one module each, an ordered registry,
    :class:`Context` with named random streams, :class:`ModelAnswers`).
"""
from kruskal_markov.lazy import lazy_exports

#: public name -> the module that defines it (imported on first use, so that ``import analysis`` and
#: the command line stay fast; PEP 562).
_EXPORTS = {
    "run_direct": "montecarlo",
    "DirectResult": "montecarlo",
    "read_poses_csv": "montecarlo",
    "write_poses_csv": "montecarlo",
    "entropy_by_step": "montecarlo",
    "validate_model": "validate",
    "random_sequences_for": "sequences",
    "PartMetrics": "orientability",
    "part_metrics": "orientability",
    "rank_parts": "orientability",
    "ReproduceSettings": "reproduce",
    "reproduce": "reproduce",
    "write_report": "report",
    "Report": "experiments.runner",
    "Context": "experiments.context",
    "ModelAnswers": "experiments.model_answers",
}
__all__ = sorted(_EXPORTS)

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
