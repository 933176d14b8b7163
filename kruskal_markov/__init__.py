"""Pure mathematics of the tray model: transition models, entropy, ensembles, synchronization.

Imports numpy, scipy and numba only -- never pybullet, ``transition_builder`` or ``analysis``.

The API by topic
----------------
Models
    :class:`TransitionModel` (one row-stochastic CSR matrix per action, initial distribution,
    partition; ``save``/``load``, ``to_networkx``), :class:`ModelError`, :func:`model_from_automaton`,
    :func:`automaton_from_model`, :func:`load_automaton_dict`, :func:`atomic_savez`,
    :func:`atomic_write_text`.
Entropy along sequences
    :func:`entropy_trajectory` (:class:`EntropyTrajectory`), :func:`propagate`,
    :func:`batch_entropy` (:class:`BatchEntropy`), :func:`distribution_entropy_bits`,
    :func:`partition_entropy_bits`, :func:`histogram_entropy_bits`.
Random-sequence ensembles
    :func:`run_ensemble` (:class:`EnsembleResult`), :func:`random_sequences`.
Structure
    :func:`analyze_structure` (:class:`StructureReport`): can the entropy reach zero at all?
Synchronization
    :func:`support_automaton` (:class:`SyncAutomaton`), :func:`start_set`,
    :func:`shortest_synchronizing_word`, :func:`greedy_synchronizing_word`,
    :func:`epsilon_synchronizing_word`, :func:`is_synchronizing_word` (:class:`SyncResult`).
Expected length of random synchronizing sequences
    :func:`expected_sync_length`, :func:`exact_expected_length`, :func:`monte_carlo_sync_length`,
    :func:`pair_chain_bounds`, :func:`monte_carlo_entropy_tilts`, :func:`default_mc_steps`.
Error bands
    :func:`resample_model` (Dirichlet posterior of a built model's rows), :func:`entropy_range_tv`,
    :func:`band_with_structure`, :func:`structural_score`, :func:`conformal_quantile`,
    :data:`STRUCTURAL_DELTA` (the model's structural error, calibrated by split conformal prediction);
    how sure a measured coverage is, with the sequence as the unit: :func:`sequence_bootstrap_interval`,
    :func:`calibration_study`, :func:`sequence_risk_delta`; the plug-in estimate's bias and noise:
    :func:`expected_plugin_entropy`, :func:`bootstrap_entropy_sd`.
"""
from kruskal_markov.lazy import lazy_exports

#: public name -> the module that defines it (imported on first use, so that ``import kruskal_markov`` and
#: the command line stay fast; PEP 562).
_EXPORTS = {
    "TransitionModel": "model",
    "ModelError": "model",
    "atomic_savez": "model",
    "atomic_write_text": "model",
    "model_from_automaton": "automaton_json",
    "automaton_from_model": "automaton_json",
    "load_automaton_dict": "automaton_json",
    "distribution_entropy_bits": "entropy",
    "partition_entropy_bits": "entropy",
    "histogram_entropy_bits": "entropy",
    "EntropyTrajectory": "entropy",
    "entropy_trajectory": "entropy",
    "propagate": "entropy",
    "CONVERGED_BITS": "entropy",
    "ZERO_BITS": "entropy",
    "BatchEntropy": "entropy",
    "batch_entropy": "entropy",
    "EnsembleResult": "ensemble",
    "run_ensemble": "ensemble",
    "random_sequences": "ensemble",
    "StructureReport": "closed_classes",
    "analyze_structure": "closed_classes",
    "SyncAutomaton": "sync",
    "SyncResult": "sync",
    "PlanResult": "sync",
    "shortest_word": "sync",
    "support_automaton": "sync",
    "start_set": "sync",
    "shortest_synchronizing_word": "sync",
    "greedy_synchronizing_word": "sync",
    "epsilon_synchronizing_word": "sync",
    "is_synchronizing_word": "sync",
    "expected_sync_length": "convergence",
    "exact_expected_length": "convergence",
    "monte_carlo_sync_length": "convergence",
    "default_mc_steps": "convergence",
    "pair_chain_bounds": "convergence",
    "monte_carlo_entropy_tilts": "convergence",
    "resample_model": "posterior",
    "Estimate": "estimate",
    "STRUCTURAL_DELTA": "structural",
    "entropy_range_tv": "structural",
    "structural_share": "structural",
    "band_with_structure": "structural",
    "structural_score": "structural",
    "conformal_quantile": "structural",
    "sequence_bootstrap_interval": "coverage",
    "calibration_study": "coverage",
    "sequence_risk_delta": "coverage",
    "expected_plugin_entropy": "plugin_entropy",
    "bootstrap_entropy_sd": "plugin_entropy",
}
__all__ = sorted(_EXPORTS)

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
