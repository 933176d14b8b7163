"""``kruskal fit --design``: which tilt sequence, and how many trials, pin the friction best.

Before any robot runs, the models answer how much a log of a given sequence says about ``mu``. The
Fisher information of one trial at ``mu0`` (Lehmann & Casella 1998, "Theory of Point Estimation",
sec. 2.6) is estimated from the models' predicted log-likelihoods: trials are simulated from the
model at ``mu0`` along the sequence (each observation the state's pose plus the camera's noise),
their log-likelihoods taken under the models at ``mu0 - d``, ``mu0`` and ``mu0 + d``
(:func:`analysis.fit.hmm.trial_loglik`), and the mean log-likelihood ratios are the
Kullback-Leibler divergences ``KL(mu0 || mu0 +- d) ~ I d^2 / 2``, so
``I ~ (KL_+ + KL_-) / d^2``. The predicted 90% interval width of ``M`` trials is
``2 z90 / sqrt(M I)`` (the trials' term of a fit's interval; the models' own error, which does
not shrink with trials, comes on top of it: docs/fit.md).

Candidates: ``sequences`` random sequences of ``tilts`` tilts (``random:N`` of ``--seed``, as every
command draws them) and one sequence *designed* by the models: greedily, each tilt the action
whose predicted report-cell distributions under ``mu0 - d`` and ``mu0 + d`` (each propagated from
the uniform start along the sequence so far) differ most in total variation at the point ``mu0``
of ``at`` where they differ least, never the previous tilt again (a first version repeated one
tilt, 48 of 50 times, and had a tenth of a random sequence's information).

*Maximin over the prior range* (``at``, default 0.2, 0.3, 0.4): a candidate's information is its
smallest over the points. A design made at one point (0.3) recommended a sequence with 1.2 times a
random one's information there but 1/85 of it at 0.2 and 0.3 of it at 0.375; its logs at truths of
0.35-0.39 were fitted with errors of 0.02-0.04 against 0.001-0.004 for a random sequence's
(docs/log/fit-fine.md): information at a guess says nothing about the coefficients away from it.
The recommended candidate is the one with the largest smallest information; its trials the fewest
whose predicted width reaches ``target``.

``d`` is the fit's refined spacing (0.025 by default): finite differences across neighbouring
builds would otherwise measure the builds' scatter, not the physics.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["DesignSettings", "design", "design_for_scene", "design_models", "designed_sequence", "fisher_information",
           "predicted_width"]

_Z90 = 1.6448536


@dataclass(frozen=True)
class DesignSettings:
    """What ``fit --design`` compares.

    Attributes
    ----------
    at : tuple of float
        The coefficients the design is made at (the prior range's points): each candidate's
        information is its smallest over them (a maximin design).
    step : float
        ``d`` of the finite differences.
    sequences : int
        Random candidate sequences.
    tilts : int
        Tilts of every candidate.
    trials : int
        The trial budget the widths are predicted at.
    target : float
        The 90% width the recommended trial count reaches.
    simulated : int
        Trials simulated per candidate for the information.
    camera : (float, float)
        Camera noise (mm, deg) of the simulated observations and the likelihood.
    seed : int
    """

    at: tuple = (0.2, 0.3, 0.4)
    step: float = 0.025
    sequences: int = 8
    tilts: int = 50
    trials: int = 500
    target: float = 0.02
    simulated: int = 200
    camera: tuple = (0.5, 0.5)
    seed: int = 0

    def __post_init__(self):
        if not self.at or not 0 < self.step < min(self.at):
            raise ValueError(f"the design's step must lie in (0, the smallest --at), got {self.step:g} and "
                             f"--at {','.join(f'{v:g}' for v in self.at)}")
        for name in ("sequences", "tilts", "trials", "simulated"):
            if getattr(self, name) < 1:
                raise ValueError(f"--{name} must be at least 1, got {getattr(self, name)}")
        if not self.target > 0:
            raise ValueError(f"the target width must be positive, got {self.target:g}")


def _cells(model, dist: np.ndarray) -> np.ndarray:
    return np.bincount(np.asarray(model.partition), weights=dist, minlength=model.n_cells)


def designed_sequence(pairs, tilts: int) -> list[int]:
    """Greedy: each tilt the action whose cell predictions under each pair of models ``(lo, hi)``
    differ most (TV) at the pair where they differ least (maximin), never the previous tilt again
    (a repeated tilt leaves the part where it rests)."""
    dists = [(np.asarray(lo.initial, dtype=float), np.asarray(hi.initial, dtype=float)) for lo, hi in pairs]
    seq = []
    for _ in range(tilts):
        best, best_tv, nxt = 0, -1.0, None
        for k in range(len(pairs[0][0].actions)):
            if seq and k == seq[-1]:
                continue
            step = [(lo.matrices[k].T @ a, hi.matrices[k].T @ b) for (lo, hi), (a, b) in zip(pairs, dists)]
            tv = min(0.5 * float(np.abs(_cells(lo, na) - _cells(hi, nb)).sum())
                     for (lo, hi), (na, nb) in zip(pairs, step))
            if tv > best_tv + 1e-12:
                best, best_tv, nxt = k, tv, step
        seq.append(best)
        dists = nxt
    return seq


def _simulated_log(model, seq, trials: int, camera, rng, grid):
    """A :class:`~analysis.fit.log.FitLog` of ``trials`` trials simulated from ``model`` along ``seq``:
    unobserved start, every later pose the state's pose plus the camera's noise."""
    from analysis.fit.goodness import _step
    from analysis.fit.log import FitLog

    init = np.asarray(model.initial, dtype=float)
    starts = np.flatnonzero(init > 0)
    state = rng.choice(starts, trials, p=init[starts] / init[starts].sum())
    poses = np.asarray(model.extras["state_poses"], dtype=float)
    L = len(seq)
    obs = np.full((trials, L + 1, 3), np.nan)
    for k, a in enumerate(seq, 1):
        state = _step(model.matrices[a], state, rng)
        p = poses[state].copy()
        p[:, :2] += rng.normal(0.0, camera[0], (trials, 2))
        p[:, 2] = np.mod(p[:, 2] + rng.normal(0.0, math.radians(camera[1]), trials), grid.theta_period)
        obs[:, k] = p
    obs[~np.all(np.isfinite(obs), axis=2)] = np.nan
    actions = np.repeat(np.asarray(seq, dtype=np.int64)[None, :], trials, axis=0)
    return FitLog(obs=obs, actions=actions, length=np.full(trials, L, dtype=np.int64),
                  trial_ids=np.arange(trials), action_names=tuple(model.actions), source="sequence")


def fisher_information(models, seq, step: float, trials: int, camera, rng, grid) -> dict:
    """Per-trial Fisher information at the middle model (``models`` = (lo, mid, hi)), from the two
    KL divergences (see the module); also their standard errors' share."""
    from analysis.fit.hmm import EmissionSettings, trial_loglik

    lo, mid, hi = models
    log = _simulated_log(mid, seq, trials, camera, rng, grid)
    em = EmissionSettings(*camera)
    ll = [trial_loglik(m, log, em, grid) for m in (lo, mid, hi)]
    kl_lo, kl_hi = ll[1] - ll[0], ll[1] - ll[2]
    info = float(max((kl_lo.mean() + kl_hi.mean()) / step ** 2, 0.0))
    se = float(np.sqrt((kl_lo + kl_hi).var(ddof=1) / trials)) / step ** 2
    return {"per_trial": info, "se": se, "kl_minus": float(kl_lo.mean()), "kl_plus": float(kl_hi.mean())}


def predicted_width(info: float, trials: int) -> float | None:
    """The 90% width ``2 z90 / sqrt(trials info)`` (None without information)."""
    return 2 * _Z90 / math.sqrt(trials * info) if info > 0 else None


def design(model_sets, actions, s: DesignSettings, grid, random_sequences) -> dict:
    """Candidates, their predicted widths and the recommendation (the JSON of ``fit --design``).

    Parameters
    ----------
    model_sets : list of (TransitionModel, TransitionModel, TransitionModel)
        For every point of ``s.at``, the models at ``mu0 - step``, ``mu0``, ``mu0 + step``.
    actions : sequence of str
        Action names.
    s : DesignSettings
    grid : ReportGrid
    random_sequences : list of list of int
        The random candidates (drawn by the caller from ``--seed``).

    Returns
    -------
    dict
        ``candidates`` (``sequence``, ``designed``, ``information_per_trial`` (the smallest over
        ``s.at``), ``information_by_point``, ``predicted_width_90`` ``{"mu": w}`` at ``s.trials``),
        ``recommended`` (``sequence``, ``trials``, ``predicted_width_90``).
    """
    from analysis.streams import salted_rng

    cands = [(list(q), False) for q in random_sequences]
    cands.append((designed_sequence([(m[0], m[2]) for m in model_sets], s.tilts), True))
    out = []
    for i, (seq, designed) in enumerate(cands):
        rng = salted_rng(s.seed, "fit", 3, i)
        infos = [fisher_information(m, seq, s.step, s.simulated, s.camera, rng, grid) for m in model_sets]
        info = min(v["per_trial"] for v in infos)
        out.append({"sequence": [actions[a] for a in seq], "designed": designed,
                    "information_per_trial": info, "information_by_point": [v["per_trial"] for v in infos],
                    "information_se": [v["se"] for v in infos],
                    "predicted_width_90": {"mu": predicted_width(info, s.trials)}})
    best = max(out, key=lambda c: c["information_per_trial"])
    info = best["information_per_trial"]
    trials = None if info <= 0 else max(1, math.ceil((2 * _Z90 / s.target) ** 2 / info))
    return {"candidates": out, "at": list(s.at), "step": s.step, "trials_budget": s.trials,
            "recommended": {"sequence": best["sequence"], "designed": best["designed"], "trials": trials,
                            "target_width_90": s.target,
                            "predicted_width_90": {"mu": None if trials is None else predicted_width(info, trials)}},
            "note": "predicted widths are the trials' term; the models' own error adds a floor that more trials "
                    "do not lower (docs/fit.md)"}


def design_models(scene, s: DesignSettings, build_settings, *, workers=None, scheduler=None, progress=None):
    """The models the design compares: for every point ``mu0`` of ``s.at``, cached builds of ``scene``
    at ``mu0 - s.step``, ``mu0`` and ``mu0 + s.step``.

    Parameters
    ----------
    scene : transition_builder.scene.Scene
        The tray and part (its engine and contact are the models'; its friction is replaced).
    s : DesignSettings
    build_settings : transition_builder.builder.BuildSettings
    workers, scheduler, progress
        Passed to :func:`transition_builder.cache.cached_build`.

    Returns
    -------
    model_sets : list of [TransitionModel, TransitionModel, TransitionModel]
    keys : list of str
        Every model's cache key, in build order.
    """
    from dataclasses import replace

    from transition_builder.cache import cache_key, cached_build
    from transition_builder.friction import parse_friction

    model_sets, keys = [], []
    for mu0 in s.at:
        models = []
        for mu in (mu0 - s.step, mu0, mu0 + s.step):
            res, path, _ = cached_build(replace(scene, friction=parse_friction(round(mu, 10))), build_settings,
                                        workers=workers, scheduler=scheduler, progress=progress)
            models.append(res.model)
            keys.append(cache_key(path))
        model_sets.append(models)
    return model_sets, keys


def design_for_scene(scene, s: DesignSettings, build_settings, *, grid="4x4x4", workers=None, scheduler=None,
                     progress=None) -> dict:
    """``kruskal fit --design`` for ``scene``: its models (:func:`design_models`), ``s.sequences``
    random candidates of ``s.tilts`` tilts (``--sequence random:N`` of ``s.seed``, as every command
    draws them) and :func:`design`; the command's JSON without ``seconds``.

    Parameters
    ----------
    scene : transition_builder.scene.Scene
    s : DesignSettings
    build_settings : transition_builder.builder.BuildSettings
    grid : str
        The report grid of the simulated observations.
    workers, scheduler, progress
        Passed to the builds.

    Returns
    -------
    dict
        :func:`design`'s keys and ``models`` (cache keys), ``camera_noise``, ``engine``, ``shape``.
    """
    from analysis.montecarlo import report_grid_for
    from analysis.sequences import sequence_rng

    model_sets, keys = design_models(scene, s, build_settings, workers=workers, scheduler=scheduler,
                                     progress=progress)
    rng = sequence_rng(s.seed)
    randoms = [list(rng.integers(0, len(scene.actions), s.tilts)) for _ in range(s.sequences)]
    out = design(model_sets, scene.actions, s, report_grid_for(scene, grid), randoms)
    out.update({"models": keys, "camera_noise": list(s.camera), "engine": scene.settings.engine,
                "shape": scene.shape.name})
    return out
