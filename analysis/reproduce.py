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

:func:`reproduce` runs everything and returns the numbers; :mod:`analysis.report` writes them as
``index.md`` with figures. Every random choice flows from ``settings.seed``.
"""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from analysis.orientability import CONVERGED_BITS, part_metrics

__all__ = ["PAPER", "ReproduceSettings", "direct_summary", "first_at_most", "reproduce", "settled_steps"]

#: the paper's own figures (Sec. V A-C), for the side-by-side table.
PAPER = {
    "A": {"sequences": 43, "converged": 29, "near_zero_by": 20, "best_length": 8, "trials": 10_000},
    "B": {"parts": 15, "converged": 10, "near_zero_by": 27, "trials": 10_000},
    "C": {"low": (10, 13), "medium": (0, 3), "high": (0, 4), "trials": 1_000},
    "erdmann_mason_plan_length": 5,
}


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
        static/kinetic pairs and tilt times (``(label, friction, tilt_time_s)``) and floor
        friction coefficients the key is rebuilt under, and the direct checks of the friction curve.
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
    compare_contacts: tuple = (("sphere, 1/240 s (the old default)",
                                {"contact": "sphere", "time_step_s": 1.0 / 240.0, "substeps": 4}),)
    compare_refine: tuple = (4,)
    judges: bool = True
    contact_build: dict | None = dataclasses.field(default_factory=lambda: {
        "tol_mm": 1.0, "tol_deg": 1.0, "recenter_rounds": 1, "start_samples": 2000})
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

    @classmethod
    def full(cls, seed: int = 0) -> "ReproduceSettings":
        """The committed report's settings (about an hour on 2 cores with the key's model cached)."""
        return cls(seed=seed)

    @classmethod
    def quick_settings(cls, seed: int = 0) -> "ReproduceSettings":
        """``--quick``: coarse models (1 mm / 1 degree), 3 triangles, 3 maps, few trials."""
        coarse = {"tol_mm": 1.0, "tol_deg": 1.0, "recenter_rounds": 1, "start_samples": 2000}
        return cls(quick=True, seed=seed, ensemble_count=10_000, parts=("triangle:1", "triangle:2", "triangle:3"),
                   maps=("map:low:1", "map:medium:1", "map:high:1"), key_build=coarse, part_build=coarse,
                   a_check_trials=200, b_trials=100, c_trials=60, replay_trials=500, validate_sequences=2,
                   validate_trials=200, validate_length=20, metrics_count=500, metrics_runs=200,
                   sync_time_budget=20.0, part_sync_time_budget=10.0, compare_contacts=(),
                   compare_refine=(), judges=False, sensitivity=False)


def _log(progress, text):
    if progress is not None:
        progress(text)


def settled_steps(entropy, epsilon: float) -> np.ndarray:
    """Per row of ``entropy`` (sequences x steps): the step from which the entropy stays ``<= epsilon``
    to the end, -1 if it ends above. (Zero entropy on the report grid is one *cell*, not one pose, so
    a sequence can reach it and split again; "converged" in the paper's sense is reached and stayed.)

    >>> settled_steps([[3.0, 0.0, 1.0, 0.0], [3.0, 0.0, 0.0, 0.0], [3.0, 1.0, 0.0, 1.0]], 1e-3).tolist()
    [3, 1, -1]
    """
    h = np.asarray(entropy, dtype=float)
    if h.ndim == 1:
        h = h[None, :]
    above = h > epsilon
    n = h.shape[1]
    last_above = np.where(above.any(axis=1), n - 1 - np.argmax(above[:, ::-1], axis=1), -1)
    return np.where(last_above < n - 1, last_above + 1, -1).astype(np.int64)


def _best_settled(h: np.ndarray, epsilon: float, fallback: int) -> int:
    """The sequence that settles first (ties: lowest mean entropy); ``fallback`` if none settles."""
    st = settled_steps(h, epsilon)
    ok = np.flatnonzero(st >= 0)
    if not ok.size:
        return fallback
    return int(min(ok, key=lambda i: (st[i], h[i].mean(), i)))


def _converged_summary(steps: np.ndarray) -> dict:
    ok = steps[steps >= 0]
    return {"converged": int(ok.size), "of": int(steps.size),
            "mean_convergence_tilt": float(ok.mean()) if ok.size else None,
            "fastest": int(ok.min()) if ok.size else None}


def direct_summary(scene, sequence, trials, seed, workers, recorded: bool = False) -> dict:
    """Direct simulation of one sequence (:func:`analysis.montecarlo.run_direct`) as a JSON-ready summary.

    With ``recorded``, the trials also go the way a robot's log would: written as a ``--poses`` CSV,
    read back and binned on the report grid (``entropy_bits_log``), so the format round trip is checked
    on every report.
    """
    from analysis.montecarlo import entropy_by_step, read_poses_csv, run_direct, write_poses_csv

    res = run_direct(scene, sequence, trials, seed=seed, workers=workers)
    out = {"entropy_bits": res.entropy_bits.tolist(), "trials": int(trials), "faults": dict(res.faults),
           "tilts": int(res.tilts_simulated)}
    if recorded:
        import os
        import tempfile

        with tempfile.TemporaryDirectory() as d:
            log = read_poses_csv(write_poses_csv(os.path.join(d, "log.csv"), res))
            out["entropy_bits_log"] = entropy_by_step(log, res.grid).tolist()
    return out


def first_at_most(curve, eps) -> int | None:
    """First step of ``curve`` with entropy ``<= eps`` (None if never): one row of
    :func:`kruskal_markov.ensemble.convergence_steps`."""
    from kruskal_markov.ensemble import convergence_steps

    step = int(convergence_steps(np.atleast_2d(np.asarray(curve, dtype=float)), eps)[0])
    return None if step < 0 else step


def _build(scene, changes, seed, workers, progress, what):
    from transition_builder.builder import BuildSettings
    from transition_builder.cache import cached_build

    t0 = time.perf_counter()
    result, path, cached = cached_build(scene, BuildSettings(seed=seed, **changes), workers=workers)
    st = result.stats
    _log(progress, f"{what}: model with {result.model.n_states} states "
                   f"({'cached' if cached else f'built in {time.perf_counter() - t0:.0f} s'})")
    return result.model, {"path": path, "cached": cached, "states": result.model.n_states,
                          "tilts": st.get("tilts_simulated"), "fault_rate": st.get("fault_rate"),
                          "seconds": time.perf_counter() - t0, "settings": dict(changes)}


def reproduce(settings: ReproduceSettings, *, workers: int | None = None, progress=None) -> dict:
    """Run experiments A, B, C and the extras (see the module docstring); return every number.

    ``progress`` (a callable taking one line of text) is told what is being done.
    """
    from analysis.validate import validate_model
    from kruskal_markov.ensemble import run_ensemble
    from kruskal_markov.entropy import entropy_trajectory
    from transition_builder.scene import scene_from_options

    s = settings
    t_all = time.perf_counter()
    eps = s.epsilon
    out = {"settings": dataclasses.asdict(s), "paper": PAPER}
    fr = {} if s.friction is None else {"friction_spec": s.friction}
    if s.contact is not None:
        fr["contact"] = s.contact
    key_scene = scene_from_options(s.shape, tray_mm=s.tray_mm, **fr)
    key, out["key_model"] = _build(key_scene, s.key_build, s.seed, workers, progress, s.shape)
    names = key.actions

    # --- A: 43 random sequences through the model --------------------------------------------
    _log(progress, f"A: {s.a_sequences} random sequences of {s.length} tilts")
    ens = run_ensemble(key, s.a_sequences, s.length, seed=s.seed, epsilon=eps, keep_entropy=True)
    best_index = _best_settled(ens.entropy, eps, ens.best_index)
    best = [names[a] for a in ens.sequences[best_index]]
    a = {"entropy": ens.entropy.tolist(), "mean": ens.mean.tolist(), "q25": ens.q25.tolist(),
         "q75": ens.q75.tolist(), "best_index": best_index, "best_sequence": best,
         "best_rule": "settles first (reaches entropy <= epsilon and stays there), else reaches first",
         "best_entropy": ens.entropy[best_index].tolist(), **_converged_summary(ens.convergence_steps),
         "settled": _converged_summary(settled_steps(ens.entropy, eps)),
         "mean_near_zero_by": first_at_most(ens.mean, 0.1)}
    _log(progress, f"A: best sequence replayed in direct simulation ({s.a_check_trials} trials)")
    a["best_direct"] = direct_summary(key_scene, best, s.a_check_trials, s.seed, workers, recorded=True)
    a["best_direct"]["zero_at"] = first_at_most(a["best_direct"]["entropy_bits"], 0.0)
    out["A"] = a

    # --- beyond: a million sequences ----------------------------------------------------------
    _log(progress, f"{s.ensemble_count:,} random sequences through the key's model")
    t0 = time.perf_counter()
    big = run_ensemble(key, s.ensemble_count, s.length, seed=s.seed + 1, epsilon=eps, keep_entropy=True)
    steps = big.convergence_steps
    settled = _converged_summary(settled_steps(big.entropy, eps))
    hist = np.bincount(steps[steps >= 0], minlength=s.length + 1)
    out["ensemble"] = {"count": s.ensemble_count, "mean": big.mean.tolist(), "q25": big.q25.tolist(),
                       "q75": big.q75.tolist(), **_converged_summary(steps),
                       "converged_by_tilt": np.cumsum(hist).tolist(),
                       "mean_near_zero_by": first_at_most(big.mean, 0.1),
                       "best_sequence": [names[x] for x in big.best_sequence], "settled": settled,
                       "seconds": time.perf_counter() - t0}
    del big

    # --- beyond: the optimal plan and the expected random length ------------------------------
    _log(progress, "the key's shortest synchronizing word and expected random lengths")
    km = _key_metrics(key, s)
    out["key_metrics"] = km.to_dict()
    if km.sync_word:
        model_curve = entropy_trajectory(key, km.sync_word).entropy_bits
        _log(progress, f"sync word ({km.sync_length} tilts) replayed with {s.replay_trials} trials")
        replay = direct_summary(key_scene, km.sync_word, s.replay_trials, s.seed + 2, workers)
        replay["model_entropy_bits"] = model_curve.tolist()
        out["sync_replay"] = replay
    out["plans"] = key_plans(key, s)
    for i, (target, entry) in enumerate(out["plans"].items()):
        if entry.get("plan") and entry["plan"]["word"]:
            _log(progress, f"{target} plan replayed with {s.replay_trials} trials")
            entry["replay"] = plan_replay(key_scene, entry["plan"], s.replay_trials, s.seed + 10 + i, workers)

    # --- does the answer depend on the contact model? ------------------------------------------
    default_contact = key_scene.settings.contact
    out["contact_models"] = {default_contact: _contact_summary(key, km, s, names)}
    st = key_scene.settings
    compare_build = s.key_build if s.contact_build is None else s.contact_build
    variants = []
    if compare_build != s.key_build and (s.compare_contacts or s.compare_refine):
        variants.append((f"{default_contact} (compared resolution)", key_scene))
    variants += [(str(label), key_scene.with_settings(**dict(changes))) for label, changes in s.compare_contacts]
    variants += [(f"{default_contact}, 1/{r} step", key_scene.with_settings(**st.finer_step(r)))
                 for r in s.compare_refine]
    for label, scene_k in variants:
        model_k, info = _build(scene_k, compare_build, s.seed, workers, progress, f"{s.shape}, {label}")
        out["contact_models"][label] = {**_contact_summary(model_k, _key_metrics(model_k, s), s, names),
                                        "model": info}
    if s.judges:
        from transition_builder.judges import JUDGE_TARGETS, judges_table
        _log(progress, "the contact judges (free sliding against the integration of Coulomb's law)")
        out["contact_judges"] = {"table": judges_table((default_contact, "sphere", "legs:4", "legs:25")),
                                 "targets": JUDGE_TARGETS}
        from transition_builder.judges import PAIR_JUDGE_TARGETS, pair_judges
        _log(progress, "the static/kinetic judges (a part on an incline against the block-on-a-slope laws)")
        out["contact_judges"]["pairs"] = {"table": {pair: pair_judges(pair, shapes=("allen-key",))["allen-key"]
                                                    for pair in ("0.5/0.3", "0.61/0.47")},
                                          "targets": PAIR_JUDGE_TARGETS}

    if s.sensitivity:
        from analysis.sensitivity import sensitivity_study

        out["sensitivity"] = sensitivity_study(
            key_scene, s, workers=workers, progress=progress,
            build=lambda sc, changes, what: _build(sc, changes, s.seed, workers, progress, what))

    # --- B: the best sequence on other parts ---------------------------------------------------
    parts = {}
    for spec in s.parts:
        scene = scene_from_options(spec, tray_mm=s.tray_mm, **fr)
        model, info = _build(scene, s.part_build, s.seed, workers, progress, f"B: {spec}")
        curve = entropy_trajectory(model, best).entropy_bits
        metrics = part_metrics(model, seed=s.seed, count=s.metrics_count, runs=s.metrics_runs, epsilon=eps,
                               sync_time_budget=s.part_sync_time_budget, sync_node_budget=s.sync_node_budget)
        _log(progress, f"B: {spec}: best sequence in direct simulation ({s.b_trials} trials)")
        direct = direct_summary(scene, best, s.b_trials, s.seed, workers)
        parts[spec] = {"model": info, "entropy_bits": curve.tolist(), "converged_at": first_at_most(curve, eps),
                       "direct": direct, "direct_zero_at": first_at_most(direct["entropy_bits"], 0.0),
                       "metrics": metrics.to_dict()}
    curves = np.array([p["entropy_bits"] for p in parts.values()]) if parts else np.zeros((0, s.length + 1))
    out["B"] = {"parts": parts, "converged": sum(p["converged_at"] is not None for p in parts.values()),
                "converged_direct": sum(p["direct_zero_at"] is not None for p in parts.values()),
                "mean": curves.mean(axis=0).tolist() if parts else [],
                "mean_near_zero_by": first_at_most(curves.mean(axis=0), 0.1) if parts else None,
                "rank_correlation": _rank_correlation(parts)}

    # --- C: friction maps (direct simulation) --------------------------------------------------
    maps = {}
    for spec in s.maps:
        scene = scene_from_options(s.shape, friction_spec=spec, tray_mm=s.tray_mm,
                                   **({} if s.contact is None else {"contact": s.contact}))
        _log(progress, f"C: {spec}: best sequence in direct simulation ({s.c_trials} trials)")
        d = direct_summary(scene, best, s.c_trials, s.seed, workers)
        d["zero_at"] = first_at_most(d["entropy_bits"], 0.0)
        maps[spec] = d
    levels = {}
    for level in ("low", "medium", "high"):
        group = [m for k, m in maps.items() if k.split(":")[1] == level]
        if group:
            c = np.array([m["entropy_bits"] for m in group])
            levels[level] = {"maps": len(group), "converged": sum(m["zero_at"] is not None for m in group),
                             "mean": c.mean(axis=0).tolist(), "q25": np.quantile(c, 0.25, axis=0).tolist(),
                             "q75": np.quantile(c, 0.75, axis=0).tolist(),
                             "mean_zero_at": _mean_or_none([m["zero_at"] for m in group])}
    out["C"] = {"maps": maps, "levels": levels}

    # --- the key's model against direct simulation ---------------------------------------------
    _log(progress, f"validation: {s.validate_sequences} sequences x {s.validate_length} tilts, "
                   f"M = {s.validate_trials}")
    val = validate_model(key, s.validate_sequences, s.validate_trials, s.seed + 3, s.validate_length,
                         workers=workers)
    out["validation"] = val
    out["seconds"] = time.perf_counter() - t_all
    return out


def plan_replay(scene, plan: dict, trials: int, seed: int, workers) -> dict:
    """Replay a plan in direct simulation: the entropy after its last tilt, the faults, and the share
    of trials that end in the plan's final report cell (``final_cell``) as the model predicts."""
    from analysis.montecarlo import run_direct

    res = run_direct(scene, plan["word"], trials, seed=seed, workers=workers)
    last = res.poses[:, -1, :]
    ok = np.all(np.isfinite(last), axis=1)
    cells = res.grid.voxel_index(last[ok])
    share = float(np.count_nonzero(cells == plan["final_cell"]) / trials)
    return {"entropy_bits": float(res.entropy_bits[-1]), "trials": int(trials), "faults": dict(res.faults),
            "share_in_final_cell": share, "model_success": plan["success_probability"]}


def key_plans(model, s: ReproduceSettings) -> dict:
    """The shortest plan of every target of ``s.plan_targets`` (and ``state``) on ``model``, and how
    rare good plans are: the probability that a random word of length L meets the target, L = 0..N,
    from ``s.plan_words`` random words (:func:`kruskal_markov.sync.random_word_success`)."""
    from kruskal_markov.sync import random_word_success, shortest_plan

    out = {}
    for i, target in enumerate(("state",) + tuple(s.plan_targets)):
        entry = {"success": random_word_success(model, target, max_length=s.length, words=s.plan_words,
                                                seed=[s.seed, 5, i])}
        if target != "state":      # the state plan is the key's synchronizing word above
            budget = {} if s.sync_node_budget is None else {"node_budget": s.sync_node_budget}
            plan = shortest_plan(model, target, time_budget=s.sync_time_budget, **budget)
            entry["plan"] = plan.to_dict()
            if plan.word:
                from kruskal_markov.answers import plan_success_interval

                entry["plan"]["success_interval"] = plan_success_interval(
                    model, [model.actions.index(a) if isinstance(a, str) else int(a) for a in plan.word],
                    plan.success_probability, draws=20, seed=s.seed, final_cell=plan.final_cell)
        out[target] = entry
    return out


def _key_metrics(model, s: ReproduceSettings):
    """:func:`analysis.orientability.part_metrics` of a key model with the settings' counts, epsilon
    and the key's search budgets (the key's own metrics and the contact section's)."""
    return part_metrics(model, seed=s.seed, count=s.metrics_count, runs=s.metrics_runs, epsilon=s.epsilon,
                        sync_time_budget=s.sync_time_budget, sync_node_budget=s.sync_node_budget)


def _contact_summary(model, metrics, s: ReproduceSettings, names) -> dict:
    """The paper-level answers of one key model: A's 43 sequences, a large ensemble, the plan."""
    from kruskal_markov.ensemble import run_ensemble

    a = run_ensemble(model, s.a_sequences, s.length, seed=s.seed, epsilon=s.epsilon)
    big = run_ensemble(model, s.contact_ensemble_count, s.length, seed=s.seed + 1, epsilon=s.epsilon)
    conv = _converged_summary(big.convergence_steps)
    return {"states": model.n_states, "a_converged": a.converged, "a_sequences": s.a_sequences,
            "ensemble_count": s.contact_ensemble_count, "converging_share": conv["converged"] / s.contact_ensemble_count,
            "mean_convergence_tilt": conv["mean_convergence_tilt"], "mean_entropy_20": float(big.mean[min(20, s.length)]),
            "mean_entropy_end": float(big.mean[-1]), "sync_length": metrics.sync_length,
            "sync_exact": metrics.sync_exact, "sync_lower_bound": metrics.sync_lower_bound,
            "random_tilts": metrics.random_tilts, "random_tilts_censored": metrics.random_tilts_censored}


def _mean_or_none(values):
    v = [x for x in values if x is not None]
    return float(np.mean(v)) if v else None


def _rank_correlation(parts: dict) -> dict | None:
    """Spearman correlation of the model's and direct simulation's final entropy along the best
    sequence, over the B parts (None for fewer than 3 parts)."""
    if len(parts) < 3:
        return None
    from scipy.stats import spearmanr

    model = [p["entropy_bits"][-1] + 1e-3 * np.mean(p["entropy_bits"]) for p in parts.values()]
    direct = [p["direct"]["entropy_bits"][-1] + 1e-3 * np.mean(p["direct"]["entropy_bits"]) for p in parts.values()]
    rho, pval = spearmanr(model, direct)
    return {"spearman": None if not np.isfinite(rho) else float(rho),
            "p_value": None if not np.isfinite(pval) else float(pval), "parts": len(parts),
            "on": "final entropy along the best sequence (ties broken by the mean over the sequence)"}
