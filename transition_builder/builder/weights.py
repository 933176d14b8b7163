"""Weights: how much probability a row carries along random sequences through the model so far.

Weighted exploration, adaptive top-ups, samples in proportion to weight and member probes all
decide from these weights (``_WEIGHT_SEQUENCES`` random ``_WEIGHT_LENGTH``-tilt sequences, seed
stream ``_WEIGHT_STREAM``).
"""
from __future__ import annotations

import numpy as np

from transition_builder._propagation import max_probability_along
from transition_builder.builder.assembly import STATE_START, _assemble
from transition_builder.builder.state import NOT_DRAWN, _Exploration
from transition_builder.grid import ReportGrid
from transition_builder.status import OK

_WEIGHT_SEQUENCES = 200     # random sequences that weigh the rows of an adaptive build
_WEIGHT_LENGTH = 30
_WEIGHT_THRESHOLD = 1e-3
_WEIGHT_STREAM = 12


def _orbit_weights(scene, settings, sym, grid, index, ex, reps, key) -> tuple[np.ndarray, np.ndarray]:
    """Weight of every orbit: the largest probability any of its states holds at some step of one of
    ``_WEIGHT_SEQUENCES`` random sequences through the model built so far (an unexplored orbit
    passes its mass on through the row it borrows); and which orbits the first tilt reaches (the
    uniform starts spread their mass thinly over many of those, so no single one weighs much)."""
    model, _ = _assemble(scene, settings, sym, grid, index, ex, reps, key, {})
    n_start = int(np.sum(model.extras["state_kind"] == STATE_START))
    rng = np.random.default_rng([settings.seed, _WEIGHT_STREAM])
    seqs = rng.integers(0, model.n_actions, size=(_WEIGHT_SEQUENCES, _WEIGHT_LENGTH))
    weight = max_probability_along(model.matrices, model.initial, seqs)
    first = np.zeros(model.n_states, dtype=bool)
    for P in model.matrices:
        first[P[:n_start].indices] = True
    G = sym.order
    return weight[n_start:].reshape(-1, G).max(axis=1), first[n_start:].reshape(-1, G).any(axis=1)


def _disputed_pairs(ex: _Exploration, grid: ReportGrid, orbits: np.ndarray, k1: int, k: int) -> np.ndarray:
    """The (orbit, action) pairs among ``orbits`` whose first ``k1`` samples are drawn, the rest up
    to ``k`` not yet, and which disagree: a fault, or landings in more than one report cell.
    Sorted by orbit, then action (an (m, 2) integer array)."""
    orbits = np.asarray(orbits, dtype=np.int64)
    st = ex.status[orbits, :, :k1]                                   # (m, n_act, k1)
    ready = np.all(st != NOT_DRAWN, axis=2) & (ex.status[orbits, :, k - 1] == NOT_DRAWN)
    ok = st == OK
    cells = np.full(st.shape, -1, dtype=np.int64)
    cells[ok] = grid.voxel_index(ex.land[orbits, :, :k1][ok])
    disagree = ~np.all(ok, axis=2) | np.any(cells != cells[:, :, :1], axis=2)
    o, b = np.nonzero(ready & disagree)
    return np.column_stack([orbits[o], b]).astype(np.int64)


def _proportional_samples(weight: np.ndarray, samples: int, heavy_weight: float, max_samples: int) -> np.ndarray:
    """Samples per action for rows of weight ``weight`` (``BuildSettings.max_samples``): ``samples``,
    or ``samples * weight / heavy_weight`` rounded up to a multiple of ``samples`` from
    ``heavy_weight`` on, at most ``max_samples``."""
    k = samples * np.ceil(np.asarray(weight, dtype=np.float64) / heavy_weight - 1e-12)
    return np.clip(k, samples, max(samples, max_samples)).astype(np.int64)


def _heavy_orbits(scene, settings, sym, grid, index, ex, reps, key) -> np.ndarray:
    """Explored orbits whose weight (:func:`_orbit_weights`) is at least 1e-3 (sorted ids)."""
    w, _ = _orbit_weights(scene, settings, sym, grid, index, ex, reps, key)
    return np.flatnonzero((w >= _WEIGHT_THRESHOLD) & ex.explored[:ex.n_orbits])
