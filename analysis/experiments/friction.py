"""The paper's experiments explained by friction (issue 40): C read by mean and by amplitude, and
the search for the physics (friction pair, tilt time) that reproduces A, by direct simulation
(:mod:`analysis.friction_study`; ``friction_study``). Off unless ``ReproduceSettings.friction_study``:
it is about 40 minutes of direct simulation on 2 cores at its defaults (docs/friction_study.md)."""
from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Settings:
    """Whether the study runs, and its M per map and per search sequence (``c_trials`` of the report
    at least 200, the brief's minimum for C)."""

    enabled: bool
    trials: int

    @classmethod
    def from_settings(cls, s) -> "Settings":
        return cls(bool(s.friction_study), max(200, int(s.c_trials)))


@dataclasses.dataclass(frozen=True)
class Result:
    """The study's :class:`~analysis.friction_study.FrictionStudyResult` (None when not run)."""

    settings: Settings
    study: object | None

    def to_dict(self) -> dict:
        return {} if self.study is None else {"friction_study": self.study.to_dict()}


def run(ctx) -> Result:
    st = Settings.from_settings(ctx.settings)
    if not st.enabled:
        return Result(st, None)
    from analysis.friction_study import FrictionStudySettings, run_friction_study

    fs = FrictionStudySettings(trials=st.trials, seed=ctx.seed("friction_study"), workers=ctx.workers)
    return Result(st, run_friction_study(fs, progress=ctx.log))


def markdown(r: Result) -> str:
    return "" if r.study is None else r.study.markdown()


def figures(r: Result, out: str) -> list[str]:
    return [] if r.study is None else r.study.figures(out)
