"""The resumable state of a build and its checkpoint format.

:class:`_Exploration` holds the representatives found so far, the landings of the explored ones and
the phase the build is in; :meth:`_Exploration.save` / :meth:`_Exploration.load` write and read it
as one ``.npz`` (format ``_CHECKPOINT_FORMAT``), so a killed build resumes where it stopped.
"""
from __future__ import annotations

import numpy as np

from kruskal_markov.model import atomic_savez

_CHECKPOINT_FORMAT = 5
#: status of a sample slot not drawn (yet); adaptive builds draw fewer samples for light rows.
NOT_DRAWN = -1
_PHASES = ("explore", "refine", "topup", "done")


class CheckpointError(ValueError):
    """A checkpoint that cannot be resumed: unreadable, of another build, or not replaying."""


class _Exploration:
    """Representatives found so far, the landings of the explored ones, and where the build is.

    ``phase`` is ``("explore", round)`` while the breadth-first queue is being emptied after
    refinement round ``round`` (0: none yet), or ``("refine", round)`` while the candidates of
    that refinement round are being tilted (``candidates``, ``cand_done`` of them done).
    """

    def __init__(self, n_actions: int, samples: int):
        self.n_actions, self.samples = n_actions, samples
        self.orbit_poses = np.zeros((0, 3))
        self.land = np.zeros((0, n_actions, samples, 3))
        self.status = np.zeros((0, n_actions, samples), dtype=np.int8)
        self.explored = np.zeros(0, dtype=bool)
        self.split_from = np.zeros(0, dtype=np.int64)     # -1, or the orbit a refinement split it off
        self.start_poses = None
        self.start_land = None      # (n action representatives, N0, 3)
        self.start_status = None
        self.phase = ("explore", 0)
        self.candidates = np.zeros((0, 4))                 # (orbit, x, y, theta) of refinement members
        self.cand_done = 0
        self.splits = 0
        self.refine_tilts = 0
        self.topup_tilts = 0
        self.recentered = 0         # recentring rounds done
        self.moved = 0              # representatives moved by recentring
        self.probed = 0             # 1 once the member probes are done
        self.probe_tilts = 0
        self.tilts_done = 0         # tilts simulated up to the checkpoint, by every run so far
        # samples beyond ``samples`` (max_samples): one row per tilt, (orbit, action, k) in ``more_src``
        self.more_src = np.zeros((0, 3), dtype=np.int64)
        self.more_land = np.zeros((0, 3))
        self.more_status = np.zeros(0, dtype=np.int8)

    @property
    def n_orbits(self) -> int:
        return len(self.orbit_poses)

    @property
    def more_count(self) -> np.ndarray:
        """Per orbit: samples per action drawn beyond ``samples`` (from ``more_src``)."""
        count = np.zeros(self.n_orbits, dtype=np.int64)
        np.maximum.at(count, self.more_src[:, 0], self.more_src[:, 2] + 1 - self.samples)
        return count

    def add_orbits(self, poses: np.ndarray, split_from: int = -1):
        n_old = self.n_orbits
        n = n_old + len(poses)
        self.orbit_poses = np.concatenate([self.orbit_poses, poses])
        self.split_from = np.concatenate([self.split_from, np.full(len(poses), split_from, dtype=np.int64)])
        if n > len(self.land):
            cap = max(n, 2 * len(self.land), 64)
            land = np.full((cap, self.n_actions, self.samples, 3), np.nan)
            status = np.full((cap, self.n_actions, self.samples), NOT_DRAWN, dtype=np.int8)
            explored = np.zeros(cap, dtype=bool)
            land[:n_old], status[:n_old], explored[:n_old] = self.land[:n_old], self.status[:n_old], \
                self.explored[:n_old]
            self.land, self.status, self.explored = land, status, explored

    def save(self, path: str, key: str):
        n = self.n_orbits
        arrays = {"format": np.array(_CHECKPOINT_FORMAT), "key": np.frombuffer(key.encode(), dtype=np.uint8),
                  "orbit_poses": self.orbit_poses, "explored": self.explored[:n], "split_from": self.split_from,
                  "land": self.land[:n], "status": self.status[:n],
                  "start_poses": self.start_poses, "start_land": self.start_land,
                  "start_status": self.start_status,
                  "phase": np.array([_PHASES.index(self.phase[0]), self.phase[1]]),
                  "more_src": self.more_src, "more_land": self.more_land, "more_status": self.more_status,
                  "candidates": self.candidates, "counters": np.array([self.cand_done, self.splits,
                                                                       self.refine_tilts, self.topup_tilts,
                                                                       self.recentered, self.moved,
                                                                       self.probed, self.probe_tilts]),
                  "tilts_done": np.array(self.tilts_done)}
        atomic_savez(path, arrays, prefix=".ckpt-")

    @classmethod
    def load(cls, path: str, key: str, n_actions: int, samples: int) -> "_Exploration | None":
        """The checkpoint at ``path`` if it belongs to this build (``key``), else None."""
        try:
            return cls.read(path, key, n_actions, samples)
        except CheckpointError:
            return None

    @classmethod
    def read(cls, path: str, key: str, n_actions: int, samples: int) -> "_Exploration":
        """The checkpoint at ``path``; :class:`CheckpointError` (one line, why) if it is unreadable,
        of another format or build (``key``), or of other dimensions."""
        try:
            with np.load(path, allow_pickle=False) as z:
                if int(z["format"]) != _CHECKPOINT_FORMAT:
                    raise CheckpointError(f"it has format {int(z['format'])}, not {_CHECKPOINT_FORMAT}")
                if z["key"].tobytes().decode() != key:
                    raise CheckpointError("it belongs to another build")
                ex = cls(n_actions, samples)
                ex.orbit_poses = np.array(z["orbit_poses"])
                ex.explored = np.array(z["explored"], dtype=bool)
                ex.split_from = np.array(z["split_from"], dtype=np.int64)
                ex.land = np.array(z["land"])
                ex.status = np.array(z["status"])
                ex.start_poses = np.array(z["start_poses"])
                ex.start_land = np.array(z["start_land"])
                ex.start_status = np.array(z["start_status"])
                ph = z["phase"]
                ex.phase = (_PHASES[int(ph[0])], int(ph[1]))
                ex.candidates = np.array(z["candidates"])
                ex.more_src = np.array(z["more_src"], dtype=np.int64)
                ex.more_land = np.array(z["more_land"])
                ex.more_status = np.array(z["more_status"], dtype=np.int8)
                (ex.cand_done, ex.splits, ex.refine_tilts, ex.topup_tilts, ex.recentered,
                 ex.moved, ex.probed, ex.probe_tilts) = (int(v) for v in z["counters"])
                ex.tilts_done = int(z["tilts_done"]) if "tilts_done" in z.files else 0
        except CheckpointError:
            raise
        except Exception:
            raise CheckpointError("it does not read as a checkpoint (damaged or truncated)") from None
        n = ex.n_orbits
        if ex.land.shape != (n, n_actions, samples, 3) or len(ex.explored) != n or len(ex.split_from) != n:
            raise CheckpointError("its arrays do not fit together")
        return ex
