"""A built model's predictions against direct simulation, side by side with the judge's own uncertainty.

For K random sequences (drawn from ``seed``; the model's process noise applied to the reference),
the model's report-grid entropy curve is compared with direct Monte Carlo of M trials
(:func:`analysis.montecarlo.run_direct`, the paper's method). Three numbers stand side by side:

* the model's error (mean and max absolute difference over steps 1..N, share of steps above 0.25
  bits, total variation distance of the final report-grid distributions);
* the reference's own sampling noise (bootstrap standard deviation of each step's plug-in entropy
  over the M trials);
* with ``spread=True``, the physics' own numerical uncertainty: the same trials re-simulated at
  half the time step (1/480 s, 8 sub-steps: the rest test keeps its interval), against the default.

Like with like: the reference is a plug-in estimate from M samples (biased low by about
``(occupied cells - 1) / (2 M ln 2)`` bits), so the model's curve is passed through the same
estimator — the expected plug-in entropy of M draws from the model's report-grid distribution
(Monte Carlo, 200 draws per step) — before the two are compared. The exact model curve is
reported too (``model_exact``).

The model's band: ``bands`` draws from the Dirichlet posterior of its rows
(:mod:`kruskal_markov.posterior`) give a 90% band of the exact curve; it is moved by the plug-in
bias and widened by the reference's bootstrap noise in quadrature (``1.645 sd``) — the
``band_coverage_dirichlet`` band, which knows only sampling noise — and then by the model's
structural error (:mod:`kruskal_markov.structural`: every report-cell distribution within a
relative total-variation distance ``structural_delta`` of the model's). ``band_coverage`` is the
share of steps 1..N at which the reference lies inside, with its Wilson 95% interval over steps
(steps of one sequence are correlated, so the per-sequence coverages are given too). Each step's
``structural_needed`` is the smallest ``delta`` whose band would have held the reference: their
split-conformal 90% quantile (``structural_delta_q90``) is what this run would calibrate.
"""
from __future__ import annotations

import math
import time

import numpy as np

from analysis.montecarlo import run_direct
from analysis.sequences import random_sequences_for
from analysis.streams import salted_rng
from kruskal_markov.answers import wilson_interval
from kruskal_markov.entropy import entropy_trajectory
from kruskal_markov.model import ModelError, TransitionModel
from kruskal_markov.plugin_entropy import bootstrap_entropy_sd, expected_plugin_entropy
from kruskal_markov.posterior import has_counts, resample_model
from kruskal_markov.structural import (
    band_with_structure,
    conformal_quantile,
    structural_flow,
    structural_score,
    structural_term,
)
from kruskal_markov.validation import check_int
from transition_builder.grid import ReportGrid
from transition_builder.scene import Scene
from transition_builder.status import OK

__all__ = ["model_scene", "model_grid", "reference_seed", "validate_model", "random_sequences_for",
           "wilson_interval", "model_band", "coverage_verdict", "COVERAGE_WINDOW"]

#: The coverage a nominal 90% band should show: a band outside it is too narrow or too wide.
COVERAGE_WINDOW = (0.85, 0.95)

_Z90 = 1.6448536269514722


def model_scene(model: TransitionModel) -> Scene:
    """The scene a built model was sampled from (ModelError for a model without one)."""
    data = model.metadata.get("scene")
    if not isinstance(data, dict):
        raise ModelError("the model records no scene (only models from `kruskal build` can be validated)")
    return Scene.from_dict(data)


def model_grid(model: TransitionModel) -> ReportGrid:
    """The report grid a built model's partition is on."""
    g = model.metadata.get("grid")
    if not isinstance(g, dict):
        raise ModelError("the model records no report grid")
    return ReportGrid(g["tray_x_mm"], g["tray_y_mm"], g["nx"], g["ny"], g["ntheta"],
                      symmetry_order=g["symmetry_order"], theta_offset=g["theta_offset"])


def reference_seed(seed: int, i: int) -> int:
    """The trial seed of the direct-simulation reference of random sequence ``i`` under ``seed``."""
    return int(salted_rng(seed, "validate.reference", i).integers(0, 2 ** 31 - 1))


def _cell_labels(result, grid: ReportGrid) -> list[np.ndarray]:
    out = []
    for k in range(result.poses.shape[1]):
        ok = result.status[:, k] == OK
        out.append(grid.voxel_index(result.poses[ok, k]))
    return out


def _finite_or_none(x: float):
    return float(x) if math.isfinite(x) else None


def coverage_verdict(covered: int, steps: int, window: tuple[float, float] = COVERAGE_WINDOW) -> str:
    """Judge a band's coverage against ``window``: ``"too narrow"`` when the Wilson 95% interval of
    ``covered / steps`` lies wholly below it, ``"too wide"`` when wholly above, else ``"consistent"``.

    Examples
    --------
    >>> coverage_verdict(90, 100), coverage_verdict(100, 100), coverage_verdict(60, 100)
    ('consistent', 'too wide', 'too narrow')
    """
    lo, hi = wilson_interval(int(covered), int(steps))
    if hi < window[0]:
        return "too narrow"
    if lo > window[1]:
        return "too wide"
    return "consistent"


def _inside(x, lo, hi) -> np.ndarray:
    return (x >= lo - 1e-12) & (x <= hi + 1e-12)


def model_band(model: TransitionModel, sequence, draws, surviving, reference_sd, structural_delta: float,
               rng) -> dict:
    """The model's predictive 90% band of a plug-in entropy curve from ``surviving`` trials per step.

    Parameters
    ----------
    model : TransitionModel
        The model (its partition gives the report cells).
    sequence : sequence of int
        Action indices.
    draws : list of TransitionModel or None
        Posterior draws (:func:`kruskal_markov.posterior.resample_model`); an empty list means a
        one-point posterior, None no band.
    surviving : array_like of int
        The reference's trial count at each step 0..N (the plug-in estimator's sample size).
    reference_sd : array_like
        The reference's sampling noise at each step (bootstrap standard deviation).
    structural_delta : float
        Relative structural error (:mod:`kruskal_markov.structural`).
    rng : numpy.random.Generator
        For the Monte Carlo of the plug-in estimator.

    Returns
    -------
    dict
        ``cells`` (steps x cells), ``exact`` (the model's curve), ``matched`` (its expected plug-in
        curve at the reference's sample sizes), ``flow`` (the row variance the sequence has flowed
        through, :func:`kruskal_markov.structural.structural_flow`: a diagnostic, not used by the band)
        and, with draws, ``centre`` and ``width`` (the
        Dirichlet band: posterior 5-95% quantiles moved by the plug-in bias, widened by ``1.645
        reference_sd`` in quadrature) and ``lo``, ``hi`` (that band with the structural term).
    """
    traj = entropy_trajectory(model, sequence, return_distributions=True)
    cells = np.stack([np.bincount(model.partition, weights=p, minlength=model.n_cells)
                      for p in traj.distributions])
    matched = np.array([expected_plugin_entropy(cells[k], int(surviving[k]), rng) for k in range(len(cells))])
    exact = traj.entropy_bits
    out = {"cells": cells, "matched": matched, "exact": exact,
           "flow": structural_flow(model, sequence, traj.distributions)}
    if draws is not None:
        curves = np.stack([entropy_trajectory(d, sequence).entropy_bits for d in draws] or [exact])
        post_sd = curves.std(axis=0, ddof=1) if len(curves) > 1 else np.zeros(len(exact))
        centre = curves.mean(axis=0) + (matched - exact)
        width = _Z90 * np.sqrt(post_sd ** 2 + np.asarray(reference_sd, dtype=np.float64) ** 2)
        lo, hi = band_with_structure(cells, centre, width, structural_delta)
        out.update(centre=centre, width=width, lo=lo, hi=hi)
    return out


def validate_model(model: TransitionModel, sequences: int = 6, trials: int = 1000, seed: int = 0,
                   length: int = 50, spread: bool = False, bands: int = 40, workers=None, scheduler=None,
                   progress: bool | None = False, simulate=None, contact: str | None = None, engine: str | None = None,
                   structural_delta: float | None = None) -> dict:
    """Compare ``model`` with direct simulation on ``sequences`` random sequences (see module docstring).

    ``simulate(scene, sequence, trials, seed, noise)``, if given, replaces
    :func:`analysis.montecarlo.run_direct` (e.g. a benchmark that caches references shared by
    several models). ``contact`` (a :func:`transition_builder.sim_settings.parse_contact` spec) simulates
    the reference under another floor contact than the model's own. Returns the ``kruskal validate``
    JSON keys (without ``seconds``); ``contact`` is the reference's, ``model_contact`` the model's.

    Parameters
    ----------
    model : TransitionModel
        A built model (its metadata holds the scene and the noise).
    sequences, trials, length : int
        Random sequences, direct-simulation trials per sequence, and tilts per sequence.
    seed : int
        Seed of the sequences and of the simulation.
    spread : bool
        Also simulate at half the time step: the simulator's own spread beside the error.
    bands : int
        Posterior draws of the model's rows for the error band (0: none).
    workers, scheduler
        Where the simulation runs (:func:`transition_builder.executors.make_executor`).
    progress : bool or None
        A progress bar (None: on a terminal).
    simulate : callable, optional
        Replaces the direct simulation.
    contact : str, optional
        The reference's floor contact (default the model's).
    engine : str, optional
        The reference's physics engine (``planar`` or ``pybullet``; default the model's): a model built in
        one engine judged by direct simulation in the other.
    structural_delta : float, optional
        Relative structural error of the band (:mod:`kruskal_markov.structural`; 0: the
        Dirichlet band alone; None: the model's own, :func:`kruskal_markov.structural.structural_term`).

    Returns
    -------
    dict
        The ``kruskal validate`` JSON keys.
    """
    if simulate is None:
        def simulate(sc, sq, m, sd, nz):
            return run_direct(sc, sq, m, seed=sd, workers=workers, scheduler=scheduler, progress=progress,
                              grid=grid, noise=nz)
    for name, val, lo in (("sequences", sequences, 1), ("trials", trials, 2), ("length", length, 1),
                          ("bands", bands, 0)):
        check_int(val, name, lo=lo)
    if structural_delta is not None and not (isinstance(structural_delta, (int, float))
                                             and not isinstance(structural_delta, bool)
                                             and math.isfinite(structural_delta) and structural_delta >= 0):
        raise ValueError(f"structural_delta must be a non-negative number, got {structural_delta!r}")
    term = structural_term(model, structural_delta)
    structural_delta = term.delta
    scene = model_scene(model)
    model_contact = scene.settings.contact
    model_engine = scene.settings.engine
    if contact is not None:
        scene = scene.with_settings(contact=contact)
    if engine is not None:
        scene = scene.with_settings(engine=engine)
    grid = model_grid(model)
    if model.partition is None or model.n_cells != grid.n_voxels:
        raise ModelError("the model's partition is not on its report grid")
    noise = model.metadata.get("noise", "none")
    seqs = random_sequences_for(model.n_actions, sequences, length, seed)
    rng = salted_rng(seed, "validate.bootstrap")
    draws = []
    t_model = time.perf_counter()
    if bands and has_counts(model):
        draws = [resample_model(model, salted_rng(seed, "validate.posterior", r)) for r in range(bands)]
    model_seconds = time.perf_counter() - t_model
    sim_seconds = 0.0
    per_seq = []
    all_err, all_err_exact, all_noise, covered, covered_dir, spread_diffs = [], [], [], [], [], []
    scores = []
    tvs = []
    for i, seq in enumerate(seqs):
        t = time.perf_counter()
        ref = simulate(scene, seq, trials, reference_seed(seed, i), noise)
        sim_seconds += time.perf_counter() - t
        t = time.perf_counter()
        labels = _cell_labels(ref, grid)
        sd = np.array([bootstrap_entropy_sd(lab, grid.n_voxels, rng) for lab in labels])
        band = model_band(model, seq, draws if bands else None, ref.surviving, sd, structural_delta, rng)
        cells, matched, exact = band["cells"], band["matched"], band["exact"]
        model_seconds += time.perf_counter() - t
        href = ref.entropy_bits
        err = np.abs(matched - href)[1:]
        err_exact = np.abs(exact - href)[1:]
        final_ref = np.bincount(labels[-1], minlength=grid.n_voxels) / max(len(labels[-1]), 1)
        tv = 0.5 * float(np.abs(cells[-1] / cells[-1].sum() - final_ref).sum())
        entry = {"sequence": [model.actions[a] for a in seq], "reference_seed": reference_seed(seed, i),
                 "reference": href.tolist(), "model": matched.tolist(), "model_exact": exact.tolist(),
                 "mean_abs_error_bits": float(err.mean()), "max_abs_error_bits": float(err.max()),
                 "reference_noise_bits": float(sd[1:].mean()), "final_tv_distance": tv,
                 "faults": ref.faults}
        if bands:
            inside_dir = _inside(href, band["centre"] - band["width"], band["centre"] + band["width"])
            inside = _inside(href, band["lo"], band["hi"])
            need = structural_score(cells, band["centre"], band["width"], href)
            entry["band_centre"] = band["centre"].tolist()
            entry["band_width"] = band["width"].tolist()
            entry["band_lo"] = band["lo"].tolist()
            entry["band_hi"] = band["hi"].tolist()
            entry["band_coverage"] = float(inside[1:].mean())
            entry["band_coverage_dirichlet"] = float(inside_dir[1:].mean())
            entry["structural_needed"] = [x if math.isfinite(x) else None for x in need.tolist()]
            covered.append(inside[1:])
            covered_dir.append(inside_dir[1:])
            scores.append(need[1:])
        entry["reference_sd"] = sd.tolist()
        if spread:
            t = time.perf_counter()
            half_scene = scene.with_settings(**scene.settings.finer_step(2))
            ref2 = simulate(half_scene, seq, trials, reference_seed(seed, i), noise)
            sim_seconds += time.perf_counter() - t
            d = np.abs(ref2.entropy_bits - href)[1:]
            entry["half_time_step"] = ref2.entropy_bits.tolist()
            entry["simulation_spread_bits"] = {"mean": float(d.mean()), "max": float(d.max())}
            entry["model_vs_half_time_step"] = {"mean": float(np.abs(matched - ref2.entropy_bits)[1:].mean()),
                                                "max": float(np.abs(matched - ref2.entropy_bits)[1:].max())}
            spread_diffs.append(d)
        per_seq.append(entry)
        all_err.append(err)
        all_err_exact.append(err_exact)
        all_noise.append(sd[1:])
        tvs.append(tv)
    err = np.concatenate(all_err)
    out = {
        "mean_abs_error_bits": float(err.mean()),
        "max_abs_error_bits": float(err.max()),
        "median_abs_error_bits": float(np.median(err)),
        "share_steps_above_0_25": float((err > 0.25).mean()),
        "mean_abs_error_bits_exact_curve": float(np.concatenate(all_err_exact).mean()),
        "final_tv_distance": float(np.mean(tvs)),
        "reference_noise_bits": float(np.concatenate(all_noise).mean()),
        "reference_noise_bits_max": float(np.concatenate(all_noise).max()),
        "band_coverage": float(np.concatenate(covered).mean()) if covered else None,
        "band_coverage_ci95": (list(wilson_interval(int(np.concatenate(covered).sum()), len(np.concatenate(covered))))
                               if covered else None),
        "band_coverage_dirichlet": float(np.concatenate(covered_dir).mean()) if covered_dir else None,
        "band_coverage_dirichlet_ci95": (list(wilson_interval(int(np.concatenate(covered_dir).sum()),
                                                              len(np.concatenate(covered_dir))))
                                         if covered_dir else None),
        "band_steps": int(sum(len(c) for c in covered)),
        "band_verdict": (coverage_verdict(int(np.concatenate(covered).sum()), len(np.concatenate(covered)))
                         if covered else None),
        **term.to_dict(),
        "structural_delta_q90": (_finite_or_none(conformal_quantile(np.concatenate(scores), 0.9))
                                 if scores else None),
        "band_draws": len(draws),
        "per_sequence": per_seq,
        "sequences": sequences, "trials": trials, "length": length, "seed": seed, "noise": noise,
        "steps_compared": "1..N (step 0 is the start distribution)",
        "estimator": "model curve = expected plug-in entropy of M draws from its report-grid distribution",
        "model_seconds": model_seconds,
        "simulation_seconds": sim_seconds,
        "states": model.n_states,
        "contact": scene.settings.contact, "model_contact": model_contact,
        "engine": scene.settings.engine, "model_engine": model_engine,
    }
    if spread:
        d = np.concatenate(spread_diffs)
        out["simulation_spread_bits"] = {"mean": float(d.mean()), "max": float(d.max())}
    if not math.isfinite(out["mean_abs_error_bits"]):  # pragma: no cover - defensive
        raise RuntimeError("validation produced a non-finite error")
    return out
