"""The tray-log section's pair (issue 57, item 6): a second log made by direct simulation at a hidden
static/kinetic pair, fitted by ``kruskal fit --fit mu_s,mu_k`` on models of another engine.

The log is made with the report's own engine (the scene's: PyBullet in the full report), the models
by ``models_engine`` (the planar engine by default, about 10 s a model against PyBullet's 100 s; a
pair fit is about 37 models), so in the full report the fit is one across physics. Every random
number comes from the section's seed: the pair (:func:`hidden_pair`, stream ``[seed, tray_log, 2]``),
the tilt sequence (``[seed, tray_log, 3]``), the start poses (a seed drawn from ``[seed, tray_log,
4]``) and the camera noise (``[seed, tray_log.camera, 1]``); the fit's bootstrap uses the section's
seed as ``kruskal fit --seed`` does.
"""
from __future__ import annotations

from analysis.streams import salted_rng

__all__ = ["ENGINE_NAMES", "PAIR_RANGE", "hidden_pair", "pair_fit_settings", "pair_study",
           "pair_markdown", "covers"]

#: how the text names an engine.
ENGINE_NAMES = {"pybullet": "PyBullet", "planar": "the planar engine"}
#: the pair's range of both coefficients (``--range 0.1..0.55``, the fit's default).
PAIR_RANGE = (0.1, 0.55)
_KINETIC = (0.15, 0.35)
_GAP = 0.15


def hidden_pair(seed: int) -> tuple[float, float]:
    """The pair ``(mu_s, mu_k)`` of the pair's log, drawn from the section's ``seed`` (stream
    ``[seed, tray_log, 2]``): ``mu_k`` uniform on 0.15..0.35, then ``mu_s = mu_k`` plus uniform
    on 0..0.15, each rounded to 3 decimals.

    Parameters
    ----------
    seed : int

    Returns
    -------
    (float, float)
    """
    rng = salted_rng(seed, "tray_log", 2)
    k = float(rng.uniform(*_KINETIC))
    s = k + float(rng.uniform(0.0, _GAP))
    return round(s, 3), round(k, 3)


#: calibration logs of the section's pair fit (``FitSettings.calibrate``: one 3 x 3 design).
PAIR_CALIBRATION_LOGS = 9


def pair_fit_settings(seed: int, camera, **changes):
    """The pair fit's :class:`~analysis.fit.core.FitSettings`: ``mu_s, mu_k`` on :data:`PAIR_RANGE`,
    the camera noise given, the bootstrap's seed ``seed``; ``changes`` replace any field."""
    from analysis.fit.core import FitSettings
    from analysis.fit.pair import PAIR

    base = {"params": PAIR, "ranges": {"mu_s": PAIR_RANGE, "mu_k": PAIR_RANGE}, "camera": tuple(camera),
            "seed": seed, "calibrate": PAIR_CALIBRATION_LOGS}
    return FitSettings(**{**base, **changes})


def gap_interval(fit: dict):
    """The fit's 90% interval of ``mu_s - mu_k``: the calibrated one when the fit was calibrated, else
    the bootstrap's ``pair.difference_interval_90``."""
    cal = fit.get("calibration")
    if cal is not None:
        return cal.get("difference_interval_90")
    return (fit.get("pair") or {}).get("difference_interval_90")


def covers(interval, value: float) -> bool | None:
    """Whether ``[lo, hi]`` holds ``value`` (None without an interval)."""
    return None if interval is None else bool(interval[0] <= value <= interval[1])


def pair_study(scene, seed: int, *, trials: int, tilts: int, camera, models_engine: str = "planar",
               fit_settings=None, build_settings=None, workers=None) -> tuple[dict | None, str | None]:
    """Make the pair's log and fit it (module docstring).

    Parameters
    ----------
    scene : transition_builder.scene.Scene
        The section's scene: its engine makes the log; its friction is replaced by the pair.
    seed : int
        The section's seed.
    trials, tilts : int
        The log's size.
    camera : (float, float)
        Camera noise of the log (mm, degrees), given to the fit.
    models_engine : str
        The engine of the fit's models.
    fit_settings : FitSettings, optional
        Default :func:`pair_fit_settings` of ``seed`` and ``camera``.
    build_settings : BuildSettings, optional
    workers : int, optional

    Returns
    -------
    pair : dict or None
        ``truth``, ``log_engine``, ``models_engine``, ``sequence``, ``trials``, ``log_seed``,
        ``camera``, ``fit`` (the ``kruskal fit`` JSON), ``covers`` (per coefficient and ``gap``).
    skipped : str or None
        Why the pair was not run (a sentence for the report), else None.
    """
    from analysis.fit.core import fit_log
    from analysis.fit.study import simulated_fit_log

    contact = scene.settings.contact
    if contact != "coulomb":
        return None, (f"The static/kinetic pair is not fitted: the scene's {contact} contact has one coefficient, "
                      "static and kinetic alike (a pair needs the coulomb contact).")
    try:
        fit_scene = scene.with_settings(engine=models_engine)
    except ValueError as exc:
        return None, f"The static/kinetic pair is not fitted: {exc}."
    s, k = hidden_pair(seed)
    seq = salted_rng(seed, "tray_log", 3).integers(0, len(scene.actions), tilts)
    log_seed = int(salted_rng(seed, "tray_log", 4).integers(0, 2 ** 31))
    log = simulated_fit_log(scene, f"{s:g}/{k:g}", seq, trials, log_seed, camera, seed, 1, workers=workers)
    fs = fit_settings or pair_fit_settings(seed, camera)
    fit = fit_log(fit_scene, log, fs, build_settings=build_settings, workers=workers).to_dict()
    iv = fit["interval_90"] or {}
    gap_iv = gap_interval(fit)
    pair = {"truth": {"mu_s": s, "mu_k": k}, "log_engine": scene.settings.engine, "models_engine": models_engine,
            "sequence": [scene.actions[a] for a in seq], "trials": trials, "log_seed": log_seed,
            "camera": list(camera), "fit": fit,
            "covers": {"mu_s": covers(iv.get("mu_s"), s), "mu_k": covers(iv.get("mu_k"), k),
                       "gap": covers(gap_iv, s - k)}}
    return pair, None


def _yes_no(flag) -> str:
    return "-" if flag is None else ("covers" if flag else "misses")


def _interval_text(iv) -> str:
    return "none (at the range's edge)" if iv is None else f"{iv[0]:.4f}..{iv[1]:.4f}"


def physics_sentence(log_engine: str, models_engine: str) -> str:
    """Which physics made the log and which built the models, and whether the fit crosses physics."""
    log_name, model_name = (ENGINE_NAMES.get(e, e) for e in (log_engine, models_engine))
    if log_engine == models_engine:
        return f"The log and the models are both {model_name}'s physics."
    return f"The log is {log_name}'s physics and the models {model_name}'s: a fit across physics."


def pair_markdown(pair: dict | None, skipped: str | None) -> list[str]:
    """The pair's lines of the section (none when not run; the reason when skipped)."""
    if skipped:
        return [skipped, ""]
    if pair is None:
        return []
    f, t = pair["fit"], pair["truth"]
    est, iv = f["estimate"], f["interval_90"] or {}
    gap_iv = gap_interval(f)
    gof = f["goodness_of_fit"]
    verdict = gof.get("verdict") or "not measured"
    p = (gof.get("test") or {}).get("p_value")
    log_name = ENGINE_NAMES.get(pair["log_engine"], pair["log_engine"])
    model_name = ENGINE_NAMES.get(pair["models_engine"], pair["models_engine"])
    rows = [("mu_s", t["mu_s"], est["mu_s"], iv.get("mu_s"), pair["covers"]["mu_s"]),
            ("mu_k", t["mu_k"], est["mu_k"], iv.get("mu_k"), pair["covers"]["mu_k"]),
            ("mu_s - mu_k", t["mu_s"] - t["mu_k"], est["mu_s"] - est["mu_k"], gap_iv, pair["covers"]["gap"])]
    lines = ["**The static/kinetic pair.** A second log, made by direct simulation in "
             f"{log_name}: {pair['trials']} trials of its own random {len(pair['sequence'])}-tilt sequence, the same "
             f"camera noise, at a static/kinetic pair drawn from the report's seed and not told to the fit: "
             f"mu_s = {t['mu_s']:.3f}, mu_k = {t['mu_k']:.3f}. `kruskal fit --fit mu_s,mu_k` (camera noise given) "
             f"fitted it on {len(f['models'])} models built by {model_name}. "
             + physics_sentence(pair["log_engine"], pair["models_engine"]), "",
             "| | truth | estimate | 90% interval | the interval |", "|---|---|---|---|---|"]
    lines += [f"| {name} | {tv:.3f} | {ev:.4f} | {_interval_text(i)} | {_yes_no(c)} |" for name, tv, ev, i, c in rows]
    cal = f.get("calibration")
    how = ("The intervals are calibrated: " + f"{cal['logs']} logs simulated by {model_name} around the estimate "
           "and fitted by the same models (`--calibrate`, docs/fit.md)" + (f"; {cal['note']}" if cal.get("note") else "")
           + ". ") if cal else ("The intervals are the trials' bootstrap (uncalibrated; on the key they under-cover, "
                                "docs/fit.md). ")
    lines += ["", f"Goodness of fit: {verdict}" + ("" if p is None else f" (p = {p:.3f})") + ". " + how
              + "On the key at a 30 degree tilt the part breaks away whatever mu_s, which acts only where it comes "
              "to rest: a log pins mu_k and says little of mu_s.", ""]
    return lines
