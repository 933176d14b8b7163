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

from transition_builder.builder.assembly import (_BORROW_RADIUS, STATE_REST, STATE_START, STATE_UNEXPLORED,  # noqa: F401
                                                 _aligned, _assemble, _check_snapped, _noise_stats)
from transition_builder.builder.driver import (BuildWarning, _MAX_WEIGHT_ROUNDS, _PROBE_STREAM, _START_STREAM,  # noqa: F401
                                               _TOPUP_ROUNDS, build_model)
from transition_builder.builder.representatives import (_PARALLEL_QUERY, _RECENTER_RADIUS, _members, _offer,  # noqa: F401
                                                        _query_workers, _recenter, _refinement_candidates,
                                                        _snap_spread, _with_rotations, compensated_noise)
from transition_builder.builder.settings import (_DEFAULT_NOISY_EXPLORE_WEIGHT, _DEFAULT_NOISY_HEAVY_WEIGHT,  # noqa: F401
                                                 _DEFAULT_NOISY_MAX_SAMPLES, _DEFAULT_NOISY_SAMPLES,
                                                 _DEFAULT_PROBE_DISTANCE, _DEFAULT_PROBE_WEIGHT,
                                                 _DEFAULT_PROBES, _DEFAULT_TOL_DETERMINISTIC,
                                                 _DEFAULT_TOL_NOISY, _LATER_OPTIONS, _SERVING_OPTIONS,
                                                 _WEIGHTED_DESIGN, BUILDER_VERSION, BuildResult,
                                                 BuildSettings, _package_version, build_key, settings_design)
from transition_builder.builder.state import (_CHECKPOINT_FORMAT, _PHASES, NOT_DRAWN, _Exploration)  # noqa: F401
from transition_builder.builder.tasks import (_CHUNK, _KEY_ORBIT, _KEY_PROBE, _KEY_REFINE, _KEY_START,  # noqa: F401
                                              _orbit_jobs, _run_tilts, _stream_tilts, tilt_chunk)
from transition_builder.builder.weights import (_WEIGHT_LENGTH, _WEIGHT_SEQUENCES, _WEIGHT_STREAM,  # noqa: F401
                                                _WEIGHT_THRESHOLD, _disputed_pairs, _heavy_orbits,
                                                _orbit_weights, _proportional_samples)

__all__ = ["BUILDER_VERSION", "BuildSettings", "BuildResult", "BuildWarning", "build_model", "build_key",
           "STATE_START", "STATE_REST", "STATE_UNEXPLORED"]
