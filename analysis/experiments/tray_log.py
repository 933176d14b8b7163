"""A tray's log (``tray_log``): a log made by direct simulation of the key at a floor coefficient the
fit is not told (drawn from the report's seed, stream ``tray_log``), ``kruskal fit`` beside the truth,
and the key's answers and robust one-cell plan over the fitted interval
(:func:`analysis.fit.study.tray_log_study`; method and measurements in docs/fit.md). With
``tray_log_pair``, a second log (the scene's engine) at a hidden static/kinetic pair fitted with
``--fit mu_s,mu_k`` on ``tray_log_models_engine``'s models; with ``tray_log_design``, ``kruskal fit
--design`` on that engine's models.

Runs when ``ReproduceSettings.tray_log`` is set (the full report; ``--quick`` leaves it out: the fit's
grid is about ten coarse builds of the key).
"""
from __future__ import annotations

import dataclasses

from transition_builder.builder.build_settings import COMPARED_RESOLUTION


@dataclasses.dataclass(frozen=True)
class Settings:
    """Whether the section runs; the log's size; the fit grid's builds; the pair, the design and
    their models' engine."""

    enabled: bool
    trials: int
    tilts: int
    build: dict
    pair: bool = False
    design: bool = False
    models_engine: str = "planar"

    @classmethod
    def from_settings(cls, s) -> "Settings":
        from transition_builder.sim_settings import parse_engine

        return cls(bool(s.tray_log), int(s.tray_log_trials), int(s.tray_log_tilts),
                   dict(s.contact_build or COMPARED_RESOLUTION), bool(s.tray_log_pair), bool(s.tray_log_design),
                   parse_engine(s.tray_log_models_engine))


@dataclasses.dataclass(frozen=True)
class Result:
    """The study (None when not run)."""

    settings: Settings
    study: object | None

    def to_dict(self) -> dict:
        return {} if self.study is None else {"tray_log": self.study.to_dict()}


def run(ctx) -> Result:
    from analysis.fit.core import FitSettings
    from analysis.fit.study import tray_log_study
    from transition_builder.builder import BuildSettings

    st = Settings.from_settings(ctx.settings)
    if not st.enabled:
        return Result(st, None)
    ctx.log("tray_log: a log at a hidden coefficient, fitted"
            + (f"; a pair's log fitted on {st.models_engine} models" if st.pair else "")
            + (f"; the log's design on {st.models_engine} models" if st.design else ""))
    seed = ctx.seed("tray_log")
    bs = BuildSettings(seed=ctx.settings.seed, **st.build)
    study = tray_log_study(ctx.scene(), seed, trials=st.trials, tilts=st.tilts,
                           fit_settings=FitSettings(seed=seed), build_settings=bs, workers=ctx.workers,
                           pair=st.pair, design=st.design, models_engine=st.models_engine)
    return Result(st, study)


def markdown(r: Result) -> str:
    return "" if r.study is None else r.study.markdown()


def figures(r: Result, out: str) -> list[str]:
    return [] if r.study is None else r.study.figures(out)
