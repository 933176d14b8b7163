"""The report's section "A tray's log": a log made at a coefficient the fit is not told, the fit
beside the truth, and the key's answers and robust plan over the fitted interval.

:func:`tray_log_study` returns a frozen :class:`TrayLogStudy` with ``to_dict``, ``markdown`` and
``figures`` (the shape of the report's experiments, so that it becomes one module of
``analysis/experiments/`` once that registry exists).
"""
from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass, replace

from analysis.streams import salted_rng

__all__ = ["TrayLogStudy", "tray_log_study", "hidden_coefficient", "add_camera_noise"]


def hidden_coefficient(seed: int, lo: float = 0.15, hi: float = 0.45) -> float:
    """The coefficient a study's log is made at, drawn from the report's ``seed`` (3 decimals)."""
    return round(float(salted_rng(seed, "tray_log").uniform(lo, hi)), 3)


def add_camera_noise(result, sigma_mm: float, sigma_deg: float, seed: int, *index: int):
    """A copy of a :class:`~analysis.montecarlo.DirectResult` whose poses carry Gaussian camera noise
    (x and y in mm, theta in degrees, theta wrapped to [0, 2 pi)); faults stay NaN. The noise is
    stream ``[seed, tray_log.camera, *index]`` (no index: the first log's; ``1``: the pair's)."""
    from analysis.fit.log import add_camera_noise_to

    return replace(result, poses=add_camera_noise_to(result.poses, sigma_mm, sigma_deg,
                                                     salted_rng(seed, "tray_log.camera", *index)))


def _camera_text(cam: dict) -> str:
    if cam.get("identifiable") is False:
        tol = cam["model_tolerance"]
        return (f"the camera noise is not identifiable below the models' {tol['mm']:g} mm / {tol['deg']:g} degree "
                f"tolerance (best candidate {cam['mm']:g} mm)")
    return f"camera noise {'estimated at' if cam.get('estimated') else 'given as'} {cam['mm']:g} mm"


def _dominant_text(fit: dict) -> str:
    need = fit.get("trials_needed") or {}
    if need.get("dominated_by") == "model":
        return (f" The interval is dominated by the models' own error (sd of the estimate {need['model_sd']:.4f} "
                f"from the builds, {need['bootstrap_sd']:.4f} from the log's trials): more trials would not narrow it.")
    return ""


@dataclass(frozen=True)
class TrayLogStudy:
    """Outcome of :func:`tray_log_study`; ``pair`` and ``design`` (with why they were skipped, if so)
    are :func:`analysis.fit.study_pair.pair_study`'s and :func:`analysis.fit.study_design.design_study`'s."""

    truth: float
    fit: dict
    sequence: list
    trials: int
    camera: tuple
    interval_models: list
    answers: dict
    plan: dict
    pair: dict | None = None
    pair_skipped: str | None = None
    design: dict | None = None
    design_skipped: str | None = None

    def to_dict(self) -> dict:
        return {"truth": self.truth, "fit": self.fit, "sequence": self.sequence, "trials": self.trials,
                "camera": list(self.camera), "interval_models": self.interval_models, "answers": self.answers,
                "plan": self.plan, "pair": self.pair, "pair_skipped": self.pair_skipped, "design": self.design,
                "design_skipped": self.design_skipped}

    def markdown(self) -> str:
        from analysis.fit.study_design import design_markdown
        from analysis.fit.study_pair import pair_markdown

        lines = self._single_lines()
        extra = pair_markdown(self.pair, self.pair_skipped) + design_markdown(self.design, self.design_skipped,
                                                                                 self.fit)
        if not extra:
            return "\n".join(lines) + "\n"
        return "\n".join(lines + [""] + extra).rstrip("\n") + "\n"

    def _single_lines(self) -> list:
        """The single coefficient's log, fit, answers and plan."""
        f = self.fit
        est = f["estimate"]["mu"]
        iv = (f["interval_90"] or {}).get("mu")
        ivt = "at the range's edge: no interval" if iv is None else f"90% interval {iv[0]:.3f}..{iv[1]:.3f}"
        covered = "" if iv is None else (" (covers the truth)" if iv[0] <= self.truth <= iv[1] else
                                         " (misses the truth)")
        lines = ["## A tray's log", "",
                 f"A log made by direct simulation of the key: {self.trials} trials of one random "
                 f"{len(self.sequence)}-tilt sequence, camera noise {self.camera[0]:g} mm / {self.camera[1]:g} degree, "
                 f"at a floor coefficient drawn from the report's seed and not told to the fit: mu = {self.truth:.3f}.",
                 "", f"`kruskal fit` estimates mu = {est:.3f}, {ivt}{covered}; {_camera_text(f['camera_noise'])}; "
                 f"{len(f['models'])} models.{_dominant_text(f)}", ""]
        if self.answers:
            lines.append("Answers over the fitted interval (models at " + ", ".join(self.interval_models) + "):")
            lines.append("")
            for k, v in self.answers.items():
                lines.append(f"- {k}: {v[0]:.3g} .. {v[1]:.3g}")
        if self.plan.get("word") is not None:
            lines += ["", f"Robust one-cell plan over the interval: {','.join(self.plan['word'])} "
                          f"(length {self.plan['length']}, success probability per model "
                          f"{_probabilities_text(self.plan['success_probability'])})."]
        return lines

    def figures(self, directory) -> list:
        from analysis.fit.figure import fit_figure

        out = [fit_figure(self.fit, os.path.join(directory, "fig_tray_log.png"), truth=self.truth)]
        if self.pair is not None:
            t = self.pair["truth"]
            out.append(fit_figure(self.pair["fit"], os.path.join(directory, "fig_tray_log_pair.png"),
                                  truth=(t["mu_s"], t["mu_k"])))
        return out


def _probabilities_text(p) -> str:
    """``0.999, 1.000`` for a list (or one number) of probabilities, three decimals each."""
    values = p if isinstance(p, (list, tuple)) else [p]
    return ", ".join(f"{float(v):.3f}" for v in values)


def simulated_fit_log(scene, friction, seq, trials: int, start_seed: int, camera, seed: int, *camera_index: int,
                      workers=None):
    """A log as a camera gives it: ``trials`` trials of ``seq`` (action indices) simulated directly in
    ``scene`` at ``friction`` (start poses from ``start_seed``), camera noise ``camera`` (mm, degrees)
    from stream ``[seed, tray_log.camera, *camera_index]``, written as a ``--poses`` CSV and read back
    by :func:`analysis.fit.log.read_fit_log` (so faults and misreads are read as ``kruskal fit`` reads them).

    Returns
    -------
    FitLog
    """
    from analysis.fit.log import read_fit_log
    from analysis.montecarlo import run_direct, write_poses_csv
    from transition_builder.friction import parse_friction

    names = [scene.actions[a] for a in seq]
    res = run_direct(replace(scene, friction=parse_friction(friction)), names, trials, seed=start_seed, workers=workers)
    noisy = add_camera_noise(res, camera[0], camera[1], seed, *camera_index)
    with tempfile.TemporaryDirectory() as d:
        path = write_poses_csv(os.path.join(d, "log.csv"), noisy)
        return read_fit_log(path, scene.actions, (scene.tray_x_mm, scene.tray_y_mm), seq)


def tray_log_study(scene, seed: int, *, trials: int = 500, tilts: int = 50, camera=(0.5, 0.5), fit_settings=None,
                   build_settings=None, workers=None, count: int = 500, pair: bool = False, design: bool = False,
                   models_engine: str = "planar", pair_settings=None, design_settings=None) -> TrayLogStudy:
    """Run the study (see the module docstring).

    Parameters
    ----------
    scene : transition_builder.scene.Scene
        The key's scene (its friction is replaced by the hidden coefficient).
    seed : int
        The section's seed: the hidden coefficient, the sequence, the starts, the camera noise, the fit
        (and the pair's and the design's draws).
    trials, tilts : int
    camera : (float, float)
        Camera noise added to the log (mm, degrees).
    fit_settings : FitSettings, optional
    build_settings : BuildSettings, optional
        The fit grid's builds (default: the fit's); also the pair's and the design's.
    workers : int, optional
    count : int
        Random sequences of the converging-share answer.
    pair : bool
        Also the static/kinetic pair's log and fit (:func:`analysis.fit.study_pair.pair_study`).
    design : bool
        Also ``kruskal fit --design`` (:func:`analysis.fit.study_design.design_study`).
    models_engine : str
        The engine of the pair's and the design's models (the single fit's are the scene's).
    pair_settings : FitSettings, optional
        The pair fit's (default :func:`analysis.fit.study_pair.pair_fit_settings`).
    design_settings : DesignSettings, optional
        The design's (default :func:`analysis.fit.study_design.default_design_settings`: the log's
        trials, tilts and camera noise, the section's seed).

    Returns
    -------
    TrayLogStudy
    """
    from analysis.fit.core import FitSettings, fit_log
    from analysis.fit.study_design import default_design_settings, design_study
    from analysis.fit.study_pair import pair_study

    truth = hidden_coefficient(seed)
    seq = salted_rng(seed, "tray_log", 1).integers(0, len(scene.actions), tilts)
    log = simulated_fit_log(scene, truth, seq, trials, seed, camera, seed, workers=workers)
    fs = fit_settings or FitSettings(seed=seed)
    fit = fit_log(scene, log, fs, build_settings=build_settings, workers=workers).to_dict()
    specs, answers, plan = _answers_over_interval(scene, fit, seed, count, build_settings, workers)
    extras = {}
    if pair:
        extras["pair"], extras["pair_skipped"] = pair_study(
            scene, seed, trials=trials, tilts=tilts, camera=camera, models_engine=models_engine,
            fit_settings=pair_settings, build_settings=build_settings, workers=workers)
    if design:
        ds = design_settings or default_design_settings(seed, trials=trials, tilts=tilts, camera=camera)
        extras["design"], extras["design_skipped"] = design_study(
            scene, ds, models_engine=models_engine, build_settings=build_settings, workers=workers)
    return TrayLogStudy(truth=truth, fit=fit, sequence=[scene.actions[a] for a in seq], trials=trials,
                        camera=tuple(camera), interval_models=specs, answers=answers, plan=plan, **extras)


def _answers_over_interval(scene, fit: dict, seed: int, count: int, build_settings, workers):
    """Models at 3 coefficients across the fit's 90% interval, the converging share's range over them
    and their robust one-cell plan: (model specs, answers, plan); empty without an interval."""
    from analysis.friction_range import FrictionRange, models_over_range
    from kruskal_markov.ensemble import run_ensemble
    from kruskal_markov.sync.plan import shortest_plan
    from kruskal_markov.sync.targets import parse_target

    iv = (fit["interval_90"] or {}).get("mu")
    if iv is None:
        return [], {}, {}
    lo, hi = round(iv[0], 3), round(iv[1], 3)
    models = models_over_range(scene, FrictionRange((lo, lo), (hi, hi)), 3, build_settings, workers=workers)
    shares = [run_ensemble(m, count, 50, seed=seed).converged / count for _, m, _ in models]
    answers = {"converging share of random 50-tilt sequences": (min(shares), max(shares))}
    p = shortest_plan([m for _, m, _ in models], parse_target("cell"), node_budget=5_000_000, time_budget=60)
    plan = {k: v for k, v in p.to_dict().items() if k in ("word", "length", "exact", "success_probability")}
    return [s for s, _, _ in models], answers, plan
