"""The paper's experiments A, B and C from built models, and what the paper could not do.

Mannam et al., "Sensorless Pose Determination using Randomized Action Sequences":

- **A** — the allen key under 43 random 50-tilt sequences (their Fig. 3): entropy trends, mean,
  interquartile range, how many converge, the mean convergence tilt, the best sequence. Here from
  the key's model; the best sequence is then replayed in direct simulation as a check.
- **B** — that best sequence on 15 random triangles (their Fig. 4). Here from one model per
  triangle (built at ``part_build`` settings), with each triangle's best sequence also simulated
  directly (``b_trials``), which gives the model-against-simulation rank correlation.
- **C** — that best sequence on the key over 20 friction maps, 13 low, 3 medium and 4 high (their
  Fig. 6). A friction map breaks the tray's symmetry (a model per map costs about four times a
  key model), so C is run by direct simulation, as in the paper, with ``c_trials`` trials per map.
- **Beyond the paper** — the same statistics over ``ensemble_count`` random sequences instead of
  43; the key's shortest synchronizing word, replayed in direct simulation with ``replay_trials``
  trials; the expected length of a random sequence; the key model against direct simulation
  (``kruskal validate``).

:func:`reproduce` runs every section of :mod:`analysis.experiments` (one module per section, in
the registry's order) and returns the :class:`~analysis.experiments.runner.Report`;
:mod:`analysis.report` writes it as ``index.md`` with figures. Every random choice flows from
``settings.seed`` through named streams (:meth:`analysis.experiments.context.Context.seed`).
"""
from __future__ import annotations

import dataclasses
import time

from analysis.experiments.context import direct_summary
from analysis.experiments.curves import first_at_most, settled_steps
from analysis.experiments.paper import PAPER
from analysis.orientability import CONVERGED_BITS
from transition_builder.builder.build_settings import COMPARED_RESOLUTION
from transition_builder.sim_settings import LEGACY_CHOICES

__all__ = ["PAPER", "ReproduceSettings", "direct_summary", "first_at_most", "reproduce", "settled_steps"]


#: the static/kinetic friction and tilt-time variants of issue 40 for ``sensitivity_physics``.
SENSITIVITY_PHYSICS = (("friction 0.5/0.3 (Simscape's defaults)", "0.5/0.3", 0.0),
                       ("tilt time 0.5 s", None, 0.5), ("0.5/0.3, tilt time 0.5 s", "0.5/0.3", 0.5))


@dataclasses.dataclass(frozen=True)
class ReproduceSettings:
    """What :func:`reproduce` runs; :meth:`full` is the paper's scale, :meth:`quick` a few minutes.

    ``friction`` is the floor's uniform friction coefficient (None: the scene default) of the key and
    the B parts; ``contact`` the floor contact of every scene (None: the simulator's default,
    ``coulomb``); ``key_build`` and ``part_build`` are :class:`~transition_builder.builder.BuildSettings`
    changes for the key's model and the B parts' models, and ``contact_build`` for the key's models
    under the simulator settings of ``compare_contacts`` (label, :class:`SimSettings` changes) and
    at the finer time steps of ``compare_refine`` (1/R of the default step, same rest-test
    interval); when ``contact_build`` differs from ``key_build`` the default contact is built with
    it too, so that every variant is compared at one resolution; ``judges`` runs the contact judges of
    :func:`transition_builder.judges.judges_table` for the compared contacts; ``parts`` are the B
    shape specs and ``maps`` the C friction specs; ``tray_mm`` the tray of every scene.

    Attributes
    ----------
    quick : bool
        The quick settings (:meth:`quick_settings`).
    seed : int
        Seed of every random choice.
    shape, tray_mm, friction, contact
        The key's shape spec, the tray of every scene, the floor friction and the floor contact
        (None: the defaults).
    length, a_sequences, ensemble_count
        Experiment A: tilts per sequence, sequences, and random sequences of the ensemble.
    parts, maps
        Experiment B's shape specs and experiment C's friction specs.
    key_build, part_build, contact_build : dict
        ``BuildSettings`` changes of the key's, the B parts' and the contact-model comparison's models.
    a_check_trials, b_trials, c_trials, replay_trials
        Direct-simulation trials of the checks, of B and C, and of the plan's replay.
    validate_sequences, validate_trials, validate_length
        The key model's validation against direct simulation.
    metrics_count, metrics_runs, sync_time_budget, part_sync_time_budget
        Orientability metrics: ensemble size, Monte Carlo runs, and exact-search budgets in seconds.
    compare_contacts, compare_refine, judges, contact_ensemble_count
        The other contact models and finer time steps compared, whether the contact judges run,
        and the comparison's ensemble size.
    epsilon : float
        The convergence threshold (bits).
    sensitivity, sensitivity_noise, sensitivity_mu, sensitivity_physics, sensitivity_check_mu, sensitivity_check_sequences, sensitivity_check_trials
        The sensitivity study (:mod:`analysis.sensitivity`): whether it runs, the pose noises, the
        static/kinetic pairs and tilt times (``(label, friction or None, tilt_time_s)``) and floor
        friction coefficients the key is rebuilt under, and the direct checks of the friction curve.
    tray_log, tray_log_trials, tray_log_tilts, tray_log_pair, tray_log_design, tray_log_models_engine
        The tray's-log section (:mod:`analysis.experiments.tray_log`): whether it runs, its log's size,
        whether the static/kinetic pair's log and fit and the log's design (``kruskal fit --design``)
        run with it, and the engine of their models.
    kits, kit_compartments, kit_build, kit_design_tray_mm, kit_design_tilt_deg, kit_replay_trials, kit_node_budget
        The kits section (:mod:`analysis.experiments.kits`): whether it runs, the kit (name, shape, x mm,
        y mm per compartment), its models' build settings, the key's design sweep (compartment sides and
        tilts), the replay's trials and the plan search's node budget.
    """

    quick: bool = False
    seed: int = 0
    shape: str = "allen-key"
    tray_mm: tuple = (200.0, 200.0)
    friction: float | None = None
    length: int = 50
    a_sequences: int = 43
    ensemble_count: int = 1_000_000
    parts: tuple = tuple(f"triangle:{i}" for i in range(1, 16))
    maps: tuple = (tuple(f"map:low:{i}" for i in range(1, 14)) + tuple(f"map:medium:{i}" for i in range(1, 4))
                   + tuple(f"map:high:{i}" for i in range(1, 5)))
    key_build: dict = dataclasses.field(default_factory=dict)
    part_build: dict = dataclasses.field(default_factory=lambda: {"tol_mm": 1.0, "tol_deg": 1.0,
                                                                  "recenter_rounds": 1, "start_samples": 1000})
    a_check_trials: int = 300
    b_trials: int = 100
    c_trials: int = 60
    replay_trials: int = 10_000
    validate_sequences: int = 2
    validate_trials: int = 300
    validate_length: int = 30
    metrics_count: int = 2000
    metrics_runs: int = 500
    sync_time_budget: float = 60.0
    part_sync_time_budget: float = 20.0
    #: when set, every shortest-word search stops after this many subsets per direction instead
    #: of at its time budget (results independent of the machine's speed; the tests use it)
    sync_node_budget: int | None = None
    plan_targets: tuple = ("cell", "probability:0.001")
    plan_words: int = 5000
    contact: str | None = None
    #: the physics engine of every scene (None: the simulator's default)
    engine: str | None = None
    #: the engine-against-engine section (analysis.experiments.engines): the key's answers from both engines'
    #: models at the compared resolution, and the judges on both (with ``judges``)
    engines: bool = True
    compare_contacts: tuple = (("sphere, 1/240 s (the old default)",
                                {"contact": "sphere", "time_step_s": 1.0 / 240.0, "substeps": 4, **LEGACY_CHOICES}),
                               ("coulomb, joint chain, all pairs, short steps (the default up to the sixth session)",
                                dict(LEGACY_CHOICES)))
    compare_refine: tuple = (4,)
    judges: bool = True
    contact_build: dict | None = dataclasses.field(default_factory=lambda: dict(COMPARED_RESOLUTION))
    contact_ensemble_count: int = 100_000
    epsilon: float = CONVERGED_BITS
    #: the sensitivity study (analysis.sensitivity): the key rebuilt at ``contact_build`` under half the
    #: time step, each pose noise and each floor friction coefficient; direct checks at ``sensitivity_check_mu``
    sensitivity: bool = True
    sensitivity_noise: tuple = ("pose:0.2,0.2", "pose:0.5,0.5")
    sensitivity_mu: tuple = (0.15, 0.2, 0.4, 0.5)
    #: static/kinetic pairs and tilt times of the sensitivity study: (label, friction spec or None for the
    #: key's, tilt time s); off by default (each is one more key build), e.g. SENSITIVITY_PHYSICS
    sensitivity_physics: tuple = ()
    sensitivity_check_mu: tuple = (0.15, 0.3, 0.5)
    sensitivity_check_sequences: int = 12
    sensitivity_check_trials: int = 60
    #: the friction study (analysis.friction_study: C read by mean and amplitude, the search for the
    #: physics of A); off by default (about 40 minutes of direct simulation on 2 cores at its defaults)
    friction_study: bool = False
    #: where the differences section finds a friction study run as its own command (its
    #: ``friction_study.json``) when the friction section did not run; None: nowhere
    friction_study_dir: str | None = None
    #: the tray's-log section (analysis.experiments.tray_log): a log of this many trials x tilts at a hidden
    #: coefficient, fitted (about ten coarse builds of the key; on in :meth:`full` only)
    tray_log: bool = False
    tray_log_trials: int = 500
    tray_log_tilts: int = 50
    #: with ``tray_log``: a second log (the scene's engine) at a hidden static/kinetic pair, fitted with
    #: ``--fit mu_s,mu_k`` on ``tray_log_models_engine``'s models (about 37 of them), and ``kruskal fit --design``
    #: on that engine's models (9); both off by default, on in :meth:`full`
    tray_log_pair: bool = False
    tray_log_design: bool = False
    tray_log_models_engine: str = "planar"
    #: the kits section (analysis.experiments.kits): a kit of parts in one tray, its common plan, replay and
    #: animation, and the key's tray design sweep; off by default (on in :meth:`full` and :meth:`quick_settings`)
    kits: bool = False
    kit_compartments: tuple = (("key", "allen-key", 120.0, 90.0), ("triangle 1", "triangle:1", 100.0, 80.0),
                               ("triangle 2", "triangle:2", 100.0, 100.0))
    kit_build: dict = dataclasses.field(default_factory=lambda: {"tol_mm": 1.0, "tol_deg": 1.0,
                                                                 "recenter_rounds": 1, "start_samples": 2000})
    kit_design_tray_mm: tuple = (80.0, 120.0, 160.0, 200.0)
    kit_design_tilt_deg: tuple = (20.0, 30.0, 40.0)
    kit_replay_trials: int = 1000
    kit_node_budget: int = 2_000_000

    @classmethod
    def full(cls, seed: int = 0) -> "ReproduceSettings":
        """The committed report's settings: every section but the friction study, which is its own
        command (``python -m analysis.friction_study``, about 40 minutes of direct simulation; its
        measured parts are committed beside the report in ``reports/full/friction_study/``)."""
        return cls(seed=seed, tray_log=True, tray_log_pair=True, tray_log_design=True,
                   friction_study_dir="reports/full/friction_study", kits=True)

    @classmethod
    def quick_settings(cls, seed: int = 0) -> "ReproduceSettings":
        """``--quick``: coarse models (1 mm / 1 degree), 3 triangles, 3 maps, few trials; no kits section
        (its settings here, 3 mm models and two design variants, apply when it is switched on)."""
        coarse = dict(COMPARED_RESOLUTION)
        return cls(quick=True, seed=seed, ensemble_count=10_000, parts=("triangle:1", "triangle:2", "triangle:3"),
                   maps=("map:low:1", "map:medium:1", "map:high:1"), key_build=coarse, part_build=coarse,
                   a_check_trials=200, b_trials=100, c_trials=60, replay_trials=500, validate_sequences=2,
                   validate_trials=200, validate_length=20, metrics_count=500, metrics_runs=200,
                   sync_time_budget=20.0, part_sync_time_budget=10.0, compare_contacts=(),
                   compare_refine=(), judges=False, sensitivity=False, engines=False,
                   # the kits section stays out of --quick while PyBullet is the default engine (its builds
                   # would add minutes to `make run`); with kits=True it runs on these coarse settings
                   kits=False,
                   kit_build={"tol_mm": 3.0, "tol_deg": 3.0, "recenter_rounds": 1, "start_samples": 200},
                   kit_design_tray_mm=(120.0, 200.0), kit_design_tilt_deg=(30.0,), kit_replay_trials=100,
                   kit_node_budget=500_000)


def reproduce(settings: ReproduceSettings, *, workers: int | None = None, progress=None,
              clock=time.perf_counter):
    """Run experiments A, B, C and the extras (see the module docstring); return every number.

    Parameters
    ----------
    settings : ReproduceSettings
    workers : int, optional
        Worker processes of builds and direct simulation (None: all cores).
    progress : callable, optional
        Told one line of text per step.
    clock : callable
        Seconds for the ``seconds`` entries.

    Returns
    -------
    Report
        Every section's result; a mapping with the ``results.json`` keys (``to_dict()``).
    """
    from analysis.experiments.runner import run_experiments

    return run_experiments(settings, workers=workers, progress=progress, clock=clock)
