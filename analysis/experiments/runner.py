"""Run every registered experiment (:data:`analysis.experiments.EXPERIMENTS`) into one :class:`Report`."""
from __future__ import annotations

import dataclasses
import functools
import importlib
import time
from collections.abc import Mapping

from analysis.experiments import EXPERIMENTS
from analysis.experiments.context import Context

__all__ = ["Report", "run_experiments"]


@dataclasses.dataclass(frozen=True, eq=False)
class Report(Mapping):
    """Every section's result, in the report's order; reads as the ``results.json`` mapping.

    Attributes
    ----------
    settings : ReproduceSettings
    results : dict
        Section name -> its ``Result``.
    seconds : float
        Wall time of the run.
    """

    settings: object
    results: dict
    seconds: float

    @functools.cached_property
    def _json(self) -> dict:
        out = {"settings": dataclasses.asdict(self.settings), "engine": self.engine}
        for result in self.results.values():
            out.update(result.to_dict())
        out["seconds"] = self.seconds
        return out

    @property
    def engine(self) -> str:
        """The physics engine that answered (the settings' engine, else the simulator's default)."""
        from transition_builder.sim_settings import SimSettings
        return getattr(self.settings, "engine", None) or SimSettings().engine

    def to_dict(self) -> dict:
        """``results.json``: ``settings``, ``engine``, every section's entries, ``seconds``."""
        return self._json

    def __getitem__(self, key):
        return self._json[key]

    def __iter__(self):
        return iter(self._json)

    def __len__(self) -> int:
        return len(self._json)

    def sections(self):
        """``(module, result)`` per section, in the report's order."""
        return [(importlib.import_module(EXPERIMENTS[name]), self.results[name]) for name in self.results]


def run_experiments(settings, *, workers=None, progress=None, clock=time.perf_counter,
                    only: tuple | None = None) -> Report:
    """Run the registered experiments (``only``: these and what they need) on one :class:`Context`."""
    t0 = clock()
    ctx = Context(settings, workers=workers, progress=progress, clock=clock)
    names = [n for n in EXPERIMENTS if only is None or n in only]
    for name in names:
        ctx.result(name)
    results = {n: ctx.result(n) for n in EXPERIMENTS if n in names or ctx.has_result(n)}
    return Report(settings, results, clock() - t0)
