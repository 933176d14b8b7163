"""Tilt tasks of a build: the keys of their noise streams and the jobs the phases send.

The task itself, the chunker and the stream of tasks are the one tilt engine's
(:mod:`transition_builder.tilting`: :func:`~transition_builder.tilting.tilt_task`,
:func:`~transition_builder.tilting.stream_tilts`); the names below are kept for the phases.
A tilt's noise stream is named by its key (``_KEY_*`` first, then the orbit, action and sample),
so every landing is the same on any executor and any number of workers.
"""
from __future__ import annotations

import numpy as np

from transition_builder.tilting import TILT_CHUNK as _CHUNK  # noqa: F401
from transition_builder.tilting import run_tilts as _run_tilts  # noqa: F401
from transition_builder.tilting import stream_tilts as _stream_tilts  # noqa: F401
from transition_builder.tilting import tilt_task as tilt_chunk  # noqa: F401

_KEY_START, _KEY_ORBIT, _KEY_REFINE, _KEY_PROBE = 1, 2, 3, 4   # first key of a sampled tilt's noise stream


def _orbit_jobs(scene, ex, orbits, k_lo, k_hi, key_tag, actions=None):
    """Tilt jobs for samples ``k_lo..k_hi-1`` of every orbit under every action (or the action
    indices ``actions``), one job per action; a noise stream per (orbit, action, sample).
    ``k_lo`` and ``k_hi`` are numbers, or arrays with one range per orbit."""
    lo = np.broadcast_to(np.asarray(k_lo, dtype=np.int64), len(orbits))
    hi = np.broadcast_to(np.asarray(k_hi, dtype=np.int64), len(orbits))
    poses = np.repeat(ex.orbit_poses[orbits], hi - lo, axis=0)
    ids = np.repeat(orbits, hi - lo)
    ks = np.concatenate([np.arange(a, b) for a, b in zip(lo, hi)]) if len(orbits) else np.zeros(0, dtype=np.int64)
    return [(scene.actions[b], poses, np.column_stack([np.full(len(poses), key_tag), ids, np.full(len(poses), b), ks]))
            for b in (range(len(scene.actions)) if actions is None else actions)]
