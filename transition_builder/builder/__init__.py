"""Build a :class:`~kruskal_markov.model.TransitionModel` of a scene by sampling the physics engine.

The design (measured against direct simulation in ``docs/builder.md`` and ``benchmarks/``):

**States are representative rest poses** (a "particle" variant of Ulam's method: Ulam 1960; Froyland,
"Extracting dynamical behaviour via Markov models", 2001). A pose that the physics produced
(a landing) joins the nearest representative within ``tol_mm`` / ``tol_deg`` *in the same report
cell and with the same wall contacts* (:mod:`transition_builder.snapping`; without noise also on
the same end of an edge lying flush with a wall, ``flush_side``), or it founds a new one. Parts
come to rest on thin sets (against a wall at 0/90/180/270 degrees, wedged in corners), so a few
thousand representatives cover everything a scene can reach, where a plain voxel grid at
the same resolution would have ~10^8 voxels.

**Only what the scene reaches** is explored: ``start_samples`` uniform collision-free start poses
(the paper's initial distribution) are tilted under every action and their landings found the
first representatives; every new representative is tilted ``samples`` times under every action,
breadth-first, until no landing founds a new one (or ``max_states`` is reached: the rest is
reported as unexplored, never silently dropped). Noisy scenes explore by weight instead
(``explore_weight``): only states that carry probability along random sequences are expanded, and
an unexplored state borrows the row of the nearest explored one in its report cell.

**Start states.** The uniform start distribution is not a set of rest poses; it enters the model
as one *start state per report cell* (Ulam's method proper): its initial probability is the share
of uniform starts in that cell, its row under an action the landings of those starts. Step 0 of a
prediction is therefore the start distribution's report-grid entropy, as in direct simulation.

**Symmetry** (:mod:`transition_builder.symmetry`): with a tray rotation group of order ``G`` every
representative stands for an orbit of ``G`` states; one set of tilts per orbit gives all ``G``
rows (``tilt(R p, R a) = R tilt(p, a)``), and the start poses are tilted under one action per
action orbit only.

**Process noise** (:mod:`transition_builder.noise`): before every sampled tilt the pose is perturbed
exactly as direct simulation perturbs it, so rows become genuinely stochastic and are estimated
from ``samples`` draws. Without noise the physics is deterministic and one sample per row is exact.

**Counts.** Every sampled tilt is accounted for: per action and row, ``counts`` (landings per target
state) + ``faults`` = ``samples`` drawn. Rows are the counts normalised over the non-faulted
samples (conditioning on survival, as direct simulation does when it drops faulted trials); the
fault counts are kept in the model (``model.extras``) and reported. The counts are what the
Dirichlet posterior (:mod:`kruskal_markov.posterior`) resamples for error bands.

Every random choice flows from ``seed`` through per-tilt keys, and landings are snapped in a fixed
order in this process, so the model is the same for any executor and number of workers.
"""
from __future__ import annotations

from kruskal_markov.lazy import lazy_exports

#: name -> the phase module that defines it (imported on first use, PEP 562; private names are here
#: for the tests and benchmarks that import them from the package)
_EXPORTS = {
    "STATE_REST": "assembly",
    "STATE_START": "assembly",
    "STATE_UNEXPLORED": "assembly",
    "_BORROW_RADIUS": "assembly",
    "_aligned": "assembly",
    "_assemble": "assembly",
    "_check_snapped": "assembly",
    "_noise_stats": "assembly",
    "BuildWarning": "driver",
    "_MAX_WEIGHT_ROUNDS": "driver",
    "_PROBE_STREAM": "driver",
    "_START_STREAM": "driver",
    "_TOPUP_ROUNDS": "driver",
    "build_model": "driver",
    "BUILD_OPTIONS": "options",
    "BuildOption": "options",
    "options_markdown": "options",
    "_PARALLEL_QUERY": "representatives",
    "_RECENTER_RADIUS": "representatives",
    "_members": "representatives",
    "_offer": "representatives",
    "_query_workers": "representatives",
    "_recenter": "representatives",
    "_refinement_candidates": "representatives",
    "_snap_spread": "representatives",
    "_with_rotations": "representatives",
    "compensated_noise": "representatives",
    "BUILDER_VERSION": "build_settings",
    "BuildResult": "build_settings",
    "BuildSettings": "build_settings",
    "COMPARED_RESOLUTION": "build_settings",
    "_DEFAULT_NOISY_EXPLORE_WEIGHT": "options",
    "_DEFAULT_NOISY_HEAVY_WEIGHT": "options",
    "_DEFAULT_NOISY_MAX_SAMPLES": "options",
    "_DEFAULT_NOISY_SAMPLES": "options",
    "_DEFAULT_PROBES": "options",
    "_DEFAULT_PROBE_DISTANCE": "options",
    "_DEFAULT_PROBE_WEIGHT": "options",
    "_DEFAULT_TOL_DETERMINISTIC": "options",
    "_DEFAULT_TOL_NOISY": "options",
    "_LATER_OPTIONS": "build_settings",
    "_SERVING_OPTIONS": "build_settings",
    "_WEIGHTED_DESIGN": "build_settings",
    "_package_version": "build_settings",
    "build_key": "build_settings",
    "settings_design": "build_settings",
    "CheckpointError": "state",
    "NOT_DRAWN": "state",
    "_CHECKPOINT_FORMAT": "state",
    "_Exploration": "state",
    "_PHASES": "state",
    "_CHUNK": "tasks",
    "_KEY_ORBIT": "tasks",
    "_KEY_PROBE": "tasks",
    "_KEY_REFINE": "tasks",
    "_KEY_START": "tasks",
    "_orbit_jobs": "tasks",
    "_run_tilts": "tasks",
    "_stream_tilts": "tasks",
    "tilt_chunk": "tasks",
    "_WEIGHT_LENGTH": "weights",
    "_WEIGHT_SEQUENCES": "weights",
    "_WEIGHT_STREAM": "weights",
    "_WEIGHT_THRESHOLD": "weights",
    "_disputed_pairs": "weights",
    "_heavy_orbits": "weights",
    "_orbit_weights": "weights",
    "_proportional_samples": "weights",
}
__all__ = ["BUILDER_VERSION", "COMPARED_RESOLUTION", "BuildSettings", "BuildResult", "BuildWarning", "build_model", "build_key",
           "settings_design", "compensated_noise", "tilt_chunk", "BUILD_OPTIONS", "BuildOption",
           "options_markdown", "STATE_START", "STATE_REST", "STATE_UNEXPLORED", "NOT_DRAWN"]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
