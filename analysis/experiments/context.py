"""What an experiment is given: settings, builds, direct simulation, progress, workers, a memo of
shared results and named random streams (:class:`Context`)."""
from __future__ import annotations

import dataclasses
import importlib
import os
import tempfile
import time
from typing import Callable

import numpy as np

from analysis.streams import stream_seed

__all__ = ["Context", "ModelInfo", "direct_summary", "stream_seed"]


@dataclasses.dataclass(frozen=True)
class ModelInfo:
    """How a model of the report was obtained (the ``key_model`` and every ``model`` entry).

    ``cache_key`` names the model by its file in the model cache
    (:func:`transition_builder.cache.cache_key`), never by a machine's path.
    """

    cache_key: str
    cached: bool
    states: int
    tilts: int | None
    fault_rate: float | None
    seconds: float
    settings: dict

    def to_dict(self) -> dict:
        """The JSON entry (the field names)."""
        return dataclasses.asdict(self)


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
        with tempfile.TemporaryDirectory() as d:
            log = read_poses_csv(write_poses_csv(os.path.join(d, "log.csv"), res))
            out["entropy_bits_log"] = entropy_by_step(log, res.grid).tolist()
    return out


class Context:
    """One reproduce run as the experiments see it.

    Parameters
    ----------
    settings : ReproduceSettings
        The run's settings; each experiment reads its own view (its ``Settings.from_settings``).
    workers : int, optional
        Worker processes of builds and direct simulation (None: all cores).
    progress : callable, optional
        Told one line of text per step.
    clock : callable
        Seconds (the ``seconds`` entries); injected by tests.

    Notes
    -----
    Random choices come from named streams (:meth:`seed`, :meth:`rng`; every name the report uses is
    listed in :data:`analysis.streams.REPORT_STREAMS`): ``ctx.seed("A")`` is the
    same in every experiment that asks for it (common random numbers where a comparison wants the
    same sequences) and unrelated to every other name and every other ``--seed``. Model builds keep
    ``settings.seed`` as their build seed (the model cache's key).
    """

    def __init__(self, settings, *, workers=None, progress: Callable | None = None,
                 clock: Callable[[], float] = time.perf_counter):
        self.settings = settings
        self.workers = workers
        self.progress = progress
        self.clock = clock
        self._memo: dict = {}
        self._alive: dict = {}
        self._results: dict = {}
        self._running: list = []

    # --- progress and randomness ----------------------------------------------------------------
    def log(self, text: str) -> None:
        """Tell ``progress`` what is being done."""
        if self.progress is not None:
            self.progress(text)

    def seed(self, name: str) -> int:
        """The integer seed of the random stream ``name`` (:func:`stream_seed`)."""
        return stream_seed(self.settings.seed, name)

    def rng(self, name: str) -> np.random.Generator:
        """A generator on the random stream ``name``."""
        return np.random.default_rng(self.seed(name))

    # --- shared results ---------------------------------------------------------------------------
    def model_key(self, model) -> int:
        """A memo key for ``model``: its ``id``, kept unique by holding the model for the run."""
        self._alive[id(model)] = model
        return id(model)

    def memo(self, key, compute: Callable):
        """``compute()`` once per ``key`` in this run; later calls return the same object."""
        if key not in self._memo:
            self._memo[key] = compute()
        return self._memo[key]

    def has_result(self, name: str) -> bool:
        """Whether the experiment ``name`` has run."""
        return name in self._results

    def result(self, name: str):
        """The result of the experiment ``name`` (run now if it has not run yet)."""
        if name not in self._results:
            if name in self._running:
                raise RuntimeError(f"experiments depend on each other in a cycle: {self._running + [name]}")
            from analysis.experiments import EXPERIMENTS

            module = importlib.import_module(EXPERIMENTS[name])
            self._running.append(name)
            try:
                self._results[name] = module.run(self)
            finally:
                self._running.pop()
        return self._results[name]

    # --- models and simulation ------------------------------------------------------------------
    def build(self, scene, changes: dict, what: str, *, build_seed: int | None = None):
        """The model of ``scene`` under ``BuildSettings`` ``changes`` (build seed ``build_seed``,
        default ``settings.seed``), from the model cache when built before; once per run.
        Returns ``(model, ModelInfo)``."""
        from transition_builder.builder import BuildSettings, build_key

        seed = self.settings.seed if build_seed is None else build_seed
        settings = BuildSettings(seed=seed, **changes)
        return self.memo(("build", build_key(scene, settings)), lambda: self._build(scene, settings, changes, what))

    def _build(self, scene, settings, changes, what):
        from transition_builder.cache import cache_key, cached_build

        t0 = self.clock()
        result, path, cached = cached_build(scene, settings, workers=self.workers)
        st = result.stats
        seconds = self.clock() - t0
        self.log(f"{what}: model with {result.model.n_states} states "
                 f"({'cached' if cached else f'built in {seconds:.0f} s'})")
        return result.model, ModelInfo(cache_key=cache_key(path), cached=cached, states=result.model.n_states,
                                       tilts=st.get("tilts_simulated"), fault_rate=st.get("fault_rate"),
                                       seconds=seconds, settings=dict(changes))

    def scene(self, shape: str | None = None, friction_spec: str | None = None):
        """The scene of ``shape`` (default the key) in the run's tray, floor friction and contact."""
        from transition_builder.scene import scene_from_options

        s = self.settings
        options = {}
        if friction_spec is not None:
            options["friction_spec"] = friction_spec
        elif s.friction is not None:
            options["friction_spec"] = s.friction
        if s.contact is not None:
            options["contact"] = s.contact
        if getattr(s, "engine", None) is not None:
            options["engine"] = s.engine
        return scene_from_options(shape or s.shape, tray_mm=s.tray_mm, **options)

    def key_model(self):
        """The key's model at ``key_build`` (``(model, ModelInfo)``), built once."""
        s = self.settings
        return self.build(self.scene(), s.key_build, s.shape)

    def ensemble(self, model, count: int, stream: str, *, keep_entropy: bool = False):
        """:func:`~kruskal_markov.ensemble.run_ensemble` of ``count`` random ``settings.length``-tilt
        sequences on the stream ``stream``, once per model, count and stream."""
        from kruskal_markov.ensemble import run_ensemble

        s = self.settings
        key = ("ensemble", self.model_key(model), int(count), stream)
        found = self._memo.get(key)
        if found is None or (keep_entropy and found.entropy is None):
            found = self._memo[key] = run_ensemble(model, count, s.length, seed=self.seed(stream), epsilon=s.epsilon,
                                                   keep_entropy=keep_entropy)
        return found

    def direct(self, scene, sequence, trials: int, stream: str, *, recorded: bool = False) -> dict:
        """Direct simulation of ``sequence`` on the stream ``stream`` (:func:`direct_summary`)."""
        return direct_summary(scene, sequence, trials, self.seed(stream), self.workers, recorded=recorded)
