"""The explicit context of one build: what every phase reads and the little it changes.

The phases (:mod:`~transition_builder.builder.exploration`, :mod:`~transition_builder.builder.refinement`)
are functions of a :class:`_BuildContext`: the scene and settings, the derived sample counts, the
symmetry, grids and snapping index, the executor, the resumable state ``ex``, and the run's counters
(tilts simulated, whether the state cap stopped exploration, when the last checkpoint was taken).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

from transition_builder.builder.build_settings import BuildSettings
from transition_builder.builder.representatives import _snap_spread, compensated_noise
from transition_builder.builder.state import _Exploration
from transition_builder.grid import ReportGrid
from transition_builder.scene import Scene
from transition_builder.snapping import PoseIndex
from transition_builder.symmetry import TraySymmetry


@dataclass
class _BuildContext:
    """One build in progress.

    Attributes
    ----------
    scene, settings, key
        What is built and its cache key (the checkpoint is tagged with the key).
    K, K0, K1 : int
        Samples per row; samples drawn first (adaptive sampling); samples of the agreement stage.
    n_act : int
        Number of actions.
    sym, grid, index
        The tray's symmetry, the report grid and the snapping index of the representatives.
    reps : list of int
        One action per action orbit (the start poses are tilted under these only).
    executor : transition_builder.tilting.TiltEngine
        Where the tilts run (the one tilt engine: executor and progress bar).
    ex : _Exploration
        The resumable state (checkpointed).
    batch, batch_tilts : int
        Orbits per exploration batch, and the tilts per batch it was derived from.
    compensate : bool
        Snap compensation is on (the noise is worked out anew before every batch).
    checkpoint, checkpoint_interval_s
        Checkpoint path (or None) and the seconds between checkpoints.
    bar
        A tqdm progress bar, or None.
    tilts : int
        Tilts simulated by this run.
    tilts_before : int
        Tilts simulated by earlier runs up to the checkpoint this run resumed from.
    capped : bool
        The state cap (``max_states``) stopped exploration.
    """

    scene: Scene
    settings: BuildSettings
    key: str
    K: int
    K0: int
    K1: int
    n_act: int
    sym: TraySymmetry
    grid: ReportGrid
    index: PoseIndex
    reps: list
    executor: object
    batch_tilts: int
    compensate: bool
    checkpoint: str | None
    checkpoint_interval_s: float
    bar: object = None
    ex: _Exploration | None = None
    batch: int = 1
    tilts: int = 0
    tilts_before: int = 0
    capped: bool = False
    last_ckpt: float = field(default_factory=time.perf_counter)

    @property
    def G(self) -> int:
        return self.sym.order

    def done(self, n: int) -> None:
        """Progress: ``n`` more tilts came back."""
        if self.bar is not None:
            self.bar.update(n)
            self.bar.set_postfix(states=len(self.index), explored=int(self.ex.explored.sum()) * self.G,
                                 refresh=False)

    def maybe_checkpoint(self, force: bool = False) -> None:
        """Save the state if a checkpoint is kept and ``force`` or the interval has passed."""
        if self.checkpoint and (force or time.perf_counter() - self.last_ckpt >= self.checkpoint_interval_s):
            self.ex.tilts_done = self.tilts_before + self.tilts
            self.ex.save(self.checkpoint, self.key)
            self.last_ckpt = time.perf_counter()

    def sample_noise(self) -> str:
        """The noise a representative is perturbed with (compensated for the snapping offset, if on)."""
        if self.compensate:
            return str(compensated_noise(self.settings.noise_spec, *_snap_spread(self.ex, self.index, self.sym)))
        return self.settings.noise
