"""Assembly: the build's counts become a :class:`~kruskal_markov.model.TransitionModel`.

Row-stochastic matrices (counts normalised over the non-faulted samples), the initial distribution
(one start state per report cell), the partition, the extras (counts, faults, state poses and
kinds, borrowed rows) and the statistics of ``kruskal build``.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from kruskal_markov.model import TransitionModel
from transition_builder.builder.build_settings import BUILDER_VERSION
from transition_builder.builder.representatives import _snap_spread, _with_rotations, compensated_noise
from transition_builder.builder.state import NOT_DRAWN
from transition_builder.status import OK, STATUS_NAMES

#: ``model.extras["state_kind"]`` values.
STATE_START, STATE_REST, STATE_UNEXPLORED = 0, 1, 2


_BORROW_RADIUS = 8.0        # tolerance units (half the snapping index's group spacing)


def _noise_stats(settings, ex, index, sym) -> dict:
    """Noisy builds: the snapping offset at the end (:func:`_snap_spread`) and the noise added to
    representatives (the process noise, or its part compensated for that final offset; the batches
    were sampled with the offset measured before each of them)."""
    if settings.noise_spec.is_zero:
        return {}
    spread = _snap_spread(ex, index, sym)
    added = compensated_noise(settings.noise_spec, *spread) if settings.snap_compensation else settings.noise_spec
    return {"snap_spread_mm": spread[0], "snap_spread_deg": spread[1], "representative_noise": str(added)}


def _assemble(scene, settings, sym, grid, index, ex, reps, key, run_stats):
    """Counts -> row-stochastic matrices, initial distribution, partition, extras, stats."""
    index.compact()
    G, n_act, K = sym.order, len(scene.actions), settings.samples
    n_orbits = len(ex.orbit_poses)
    n_rest = n_orbits * G
    # start states: one per report cell holding uniform starts
    n0 = len(ex.start_poses)
    start_rot = np.stack([sym.rotate_poses(ex.start_poses, j) for j in range(G)])       # (G, n0, 3)
    start_cells = grid.voxel_index(start_rot.reshape(-1, 3)).reshape(G, n0)
    cells_used, inverse = np.unique(start_cells, return_inverse=True)
    start_state = inverse.reshape(G, n0)
    n_start = len(cells_used)
    n = n_start + n_rest
    initial = np.bincount(start_state.ravel(), minlength=n_start).astype(np.float64)
    initial = np.concatenate([initial / initial.sum(), np.zeros(n_rest)])

    rows = [[] for _ in range(n_act)]
    cols = [[] for _ in range(n_act)]
    faults = np.zeros((n_act, n), dtype=np.int64)
    samples = np.zeros((n_act, n), dtype=np.int64)
    fault_kinds = np.zeros((n_act, len(STATUS_NAMES)), dtype=np.int64)
    # start rows
    for bi, b in enumerate(reps):
        for j in range(G):
            a = sym.rotate_action(b, j)
            src = start_state[j]
            st = ex.start_status[bi]
            ok = st == OK
            np.add.at(samples[a], src, 1)
            np.add.at(faults[a], src[~ok], 1)
            fault_kinds[a] += np.bincount(st, minlength=len(STATUS_NAMES))
            if ok.any():
                tgt = index.snap(sym.rotate_poses(ex.start_land[bi][ok], j))
                _check_snapped(tgt)
                rows[a].append(src[ok])
                cols[a].append(n_start + tgt)
    # rest rows of explored orbits: the first K samples, then those added in proportion to weight
    done = np.flatnonzero(ex.explored[:n_orbits])
    E = len(done)
    more_of_action = [np.flatnonzero(ex.more_src[:, 1] == b) for b in range(n_act)]
    for j in range(G):
        for b in range(n_act):
            a = sym.rotate_action(b, j)
            src = np.repeat(n_start + done * G + j, K)
            st = ex.status[done, b].reshape(-1)
            land = ex.land[done, b].reshape(-1, 3)
            more = more_of_action[b]
            if len(more):
                src = np.concatenate([src, n_start + ex.more_src[more, 0] * G + j])
                st = np.concatenate([st, ex.more_status[more]])
                land = np.concatenate([land, ex.more_land[more]])
            drawn = st != NOT_DRAWN
            ok = st == OK
            np.add.at(samples[a], src[drawn], 1)
            np.add.at(faults[a], src[drawn & ~ok], 1)
            fault_kinds[a] += np.bincount(st[drawn], minlength=len(STATUS_NAMES))
            if ok.any():
                tgt = index.snap(sym.rotate_poses(land[ok], j))
                _check_snapped(tgt)
                rows[a].append(src[ok])
                cols[a].append(n_start + tgt)
    kind = np.full(n, STATE_UNEXPLORED, dtype=np.int8)
    kind[:n_start] = STATE_START
    kind[(n_start + done[:, None] * G + np.arange(G)[None, :]).ravel()] = STATE_REST
    # weighted builds: an unexplored state borrows the row of the nearest explored one nearby
    borrowed_from = np.full(n, -1, dtype=np.int64)
    borrowed_far = 0
    if settings.explore_weight > 0 and E < n_orbits:
        unexplored = np.flatnonzero(kind[n_start:] == STATE_UNEXPLORED)
        lenders = np.flatnonzero(kind[n_start:] == STATE_REST)
        src = index.nearest_among(unexplored, lenders, _BORROW_RADIUS)
        far = src < 0               # nothing near in the cell and contact group: the nearest pose anywhere
        src[far] = index.nearest_among(unexplored[far], lenders, None)
        borrowed_far = int(np.sum(far & (src >= 0)))
        hit = src >= 0
        borrowed_from[n_start + unexplored[hit]] = n_start + src[hit]
    borrowers = np.flatnonzero(borrowed_from >= 0)
    lend = sp.csr_matrix((np.ones(len(borrowers)), (borrowers, borrowed_from[borrowers])), shape=(n, n))
    mats, count_data = [], {}
    imputed = 0
    self_loops = 0
    for a in range(n_act):
        r = np.concatenate(rows[a]) if rows[a] else np.zeros(0, dtype=np.int64)
        c = np.concatenate(cols[a]) if cols[a] else np.zeros(0, dtype=np.int64)
        C = sp.csr_matrix((np.ones(len(r), dtype=np.int64), (r, c)), shape=(n, n))
        C.sum_duplicates()
        C.sort_indices()
        rowsum = np.asarray(C.sum(axis=1)).ravel()
        empty = np.flatnonzero(rowsum == 0)
        extra_r, extra_c, extra_v = [], [], []
        # a start cell with no sample for this action: the pooled first-tilt landings of the action
        empty_start = empty[empty < n_start]
        if len(empty_start):
            pooled = np.asarray(C[:n_start].sum(axis=0)).ravel()
            nz = np.flatnonzero(pooled)
            for s in empty_start:
                extra_r.append(np.full(len(nz), s))
                extra_c.append(nz)
                extra_v.append(pooled[nz] / pooled.sum())
            imputed += len(empty_start)
        # unexplored states that borrow no row, and rows whose every sample faulted: stay put (reported)
        stay = empty[(empty >= n_start) & (borrowed_from[empty] < 0)]
        self_loops += len(stay)
        P = sp.csr_matrix((C.data / rowsum[np.repeat(np.arange(n), np.diff(C.indptr))], C.indices, C.indptr),
                          shape=(n, n))
        if len(stay) or len(extra_r):
            add_r = np.concatenate(extra_r + [stay])
            add_c = np.concatenate(extra_c + [stay])
            add_v = np.concatenate(extra_v + [np.ones(len(stay))])
            P = P + sp.csr_matrix((add_v, (add_r, add_c)), shape=(n, n))
        if len(borrowers):
            P = P + lend @ P         # a borrower's own row is empty
        P = sp.csr_matrix(P)
        P.sum_duplicates()
        P.eliminate_zeros()
        P.sort_indices()
        # counts aligned with P's stored entries (0 where a row was imputed or is a self-loop)
        count_data[f"counts_{a}"] = _aligned(P, C)
        mats.append(P)
    partition = np.empty(n, dtype=np.int64)
    partition[:n_start] = cells_used
    partition[n_start:] = index.cells[:n_rest]
    state_poses = np.full((n, 3), np.nan)
    state_poses[n_start:] = _with_rotations(sym, ex.orbit_poses)
    extras = {"state_poses": state_poses, "state_kind": kind, "faults": faults.astype(np.int32),
              "samples": samples.astype(np.int32), **count_data}
    if len(borrowers):
        extras["borrowed_from"] = borrowed_from
    total = int(samples.sum())
    n_faults = int(faults.sum())
    fault_by_action = {scene.actions[a]: {STATUS_NAMES[c]: int(fault_kinds[a, c])
                                          for c in range(len(STATUS_NAMES)) if c != OK}
                       for a in range(n_act)}
    period = 2 * math.pi / scene.shape.symmetry_order
    plain_voxels = (math.ceil(scene.tray_x_mm / settings.tol_mm) * math.ceil(scene.tray_y_mm / settings.tol_mm)
                    * math.ceil(period / math.radians(settings.tol_deg)))
    stats = {
        "states": n, "rest_states": E * G, "start_states": n_start,
        "unexplored_states": n_rest - E * G, "representatives": n_orbits,
        "voxels_total": plain_voxels, "report_voxels": grid.n_voxels,
        "symmetry_order": G, "symmetry": sym.reason,
        "samples_per_row": K, "start_samples": n0,
        "fault_rate": n_faults / total if total else 0.0, "faults": n_faults,
        "faults_per_action": fault_by_action, "sampled_transitions": total,
        "tilts_saved_by_symmetry": int(total * (G - 1) // G),
        "start_rows_imputed": imputed, "rows_without_samples": self_loops,
        "rows_borrowed": int(len(borrowers)), "rows_borrowed_from_afar": borrowed_far,
        "noise": settings.noise, **run_stats,
    }
    metadata = {
        "build_key": key,
        "kind": "kruskal.built_model", "scene": scene.to_dict(), "scene_hash": scene.content_hash(),
        "build_settings": settings.to_dict(), "builder_version": BUILDER_VERSION,
        "grid": grid.to_dict(), "noise": settings.noise, "symmetry_order": G,
        "stats": {k: v for k, v in stats.items() if k != "faults_per_action"},
    }
    model = TransitionModel(scene.actions, mats, initial=initial, partition=partition, n_cells=grid.n_voxels,
                            metadata=metadata, extras=extras)
    return model, stats


def _check_snapped(tgt):
    if np.any(tgt < 0):  # pragma: no cover - every landing founded or joined a representative
        raise RuntimeError("a landing has no representative within tolerance after exploration")


def _aligned(P: sp.csr_matrix, C: sp.csr_matrix) -> np.ndarray:
    """Counts of ``C`` at the stored entries of ``P`` (0 where C has none); C's pattern is within P's."""
    n = P.shape[0]
    key_p = np.repeat(np.arange(n, dtype=np.int64), np.diff(P.indptr)) * n + P.indices
    C = C.tocsr()
    C.sum_duplicates()
    C.eliminate_zeros()
    key_c = np.repeat(np.arange(n, dtype=np.int64), np.diff(C.indptr)) * n + C.indices
    order = np.argsort(key_c, kind="stable")
    key_c, val_c = key_c[order], C.data[order]
    pos = np.clip(np.searchsorted(key_c, key_p), 0, max(len(key_c) - 1, 0))
    out = np.zeros(P.nnz, dtype=np.int32)
    if len(key_c):
        hit = key_c[pos] == key_p
        out[hit] = val_c[pos[hit]]
    return out
