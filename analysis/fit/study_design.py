"""The tray-log section's design (issue 57, item 6): ``kruskal fit --design`` for the section's part,
made by :func:`analysis.fit.design.design_for_scene` (the function the command calls) on models of
``models_engine`` at the section's seed, its widths predicted at the log's trial count.

What the prediction is: the trials' term of a fit's 90% interval only. The models' own error comes
on top of it and no number of trials lowers it (docs/fit.md: on the key the realised intervals are
far wider than the predicted ones).
"""
from __future__ import annotations

__all__ = ["default_design_settings", "design_study", "design_markdown"]


def default_design_settings(seed: int, *, trials: int, tilts: int, camera):
    """The section's :class:`~analysis.fit.design.DesignSettings`: the command's defaults (8 random
    candidates and one designed, maximin over mu = 0.2, 0.3, 0.4, a 0.02 target width) at the log's
    trials, tilts and camera noise and the section's ``seed``."""
    from analysis.fit.design import DesignSettings

    return DesignSettings(trials=trials, tilts=tilts, camera=tuple(camera), seed=seed)


def design_study(scene, settings, *, models_engine: str = "planar", build_settings=None,
                 workers=None) -> tuple[dict | None, str | None]:
    """``fit --design`` for ``scene`` on ``models_engine``'s models.

    Parameters
    ----------
    scene : transition_builder.scene.Scene
        The section's scene (its engine is replaced by ``models_engine``).
    settings : DesignSettings
    models_engine : str
    build_settings : BuildSettings, optional
        Default: the fit's (``BuildSettings.compared()``).
    workers : int, optional

    Returns
    -------
    design : dict or None
        The ``fit --design`` JSON (without ``seconds``) and ``seed``.
    skipped : str or None
        Why the design was not made (a sentence for the report), else None.
    """
    from analysis.fit.design import design_for_scene
    from transition_builder.builder import BuildSettings

    try:
        sc = scene.with_settings(engine=models_engine)
    except ValueError as exc:
        return None, f"The log's design is not made: {exc}."
    out = design_for_scene(sc, settings, build_settings or BuildSettings.compared(), workers=workers)
    out["seed"] = settings.seed
    return out, None


def _width(w) -> str:
    return "-" if w is None else f"{w:.2g}"


def candidate_label(candidates: list, i: int) -> str:
    """``random 3`` (the third random candidate) or ``designed``."""
    if candidates[i]["designed"]:
        return "designed"
    return f"random {sum(not c['designed'] for c in candidates[:i + 1])}"


def recommended_index(design: dict) -> int:
    """Index of the recommended candidate among ``design["candidates"]``."""
    rec = design["recommended"]
    return next(i for i, c in enumerate(design["candidates"])
                if c["sequence"] == rec["sequence"] and c["designed"] == rec["designed"])


def _realised_text(fit: dict | None) -> str:
    """The single fit's interval width beside its trials-only width (when both are known)."""
    if not fit:
        return ""
    iv = (fit.get("interval_90") or {}).get("mu")
    only = (fit.get("interval_90_trials_only") or {}).get("mu")
    if iv is None or only is None:
        return ""
    return (f" The fit above: its 90% interval is {iv[1] - iv[0]:.4f} wide, its trials-only interval "
            f"{only[1] - only[0]:.4f}.")


def design_markdown(design: dict | None, skipped: str | None, fit: dict | None = None) -> list[str]:
    """The design's lines of the section (none when not run; the reason when skipped); ``fit`` is the
    section's single-coefficient fit, whose realised widths are set beside the prediction."""
    if skipped:
        return [skipped, ""]
    if design is None:
        return []
    from analysis.fit.study_pair import ENGINE_NAMES

    cands, rec = design["candidates"], design["recommended"]
    at = ", ".join(f"{v:g}" for v in design["at"])
    engine = ENGINE_NAMES.get(design["engine"], design["engine"])
    trials = design["trials_budget"]
    lines = [f"**The log's design** (`kruskal fit --design --seed {design['seed']}`, the section's seed): "
             f"{len(design['models'])} models of {engine} at mu = {at} and +-{design['step']:g} rank "
             f"{len(cands)} candidate {len(cands[0]['sequence'])}-tilt sequences by their smallest Fisher "
             f"information per trial over those points (nats per unit mu squared).", "",
             f"| candidate | smallest information per trial | predicted 90% width at {trials} trials |",
             "|---|---|---|"]
    lines += [f"| {candidate_label(cands, i)} | {c['information_per_trial']:.3g} | "
              f"{_width(c['predicted_width_90']['mu'])} |" for i, c in enumerate(cands)]
    n = rec["trials"]
    need = ("no number of trials (no information)" if n is None else
            f"{n} trial{'s reach' if n != 1 else ' reaches'} the target 90% width of {rec['target_width_90']:g} "
            f"(predicted {_width(rec['predicted_width_90']['mu'])})")
    lines += ["", f"Recommended: {candidate_label(cands, recommended_index(design))} "
                  f"(`{','.join(rec['sequence'])}`); {need}. What the prediction is: the trials' term of the "
                  "interval only; the models' own error comes on top of it and no number of trials lowers it "
                  "(docs/fit.md)." + _realised_text(fit), ""]
    return lines
