"""Refinement of deterministic builds: member probes and splitting representatives.

Both tilt *members* of a representative (landings snapped to it) and act where the physics is
sensitive inside its tolerance: probes turn the row into the members' landings
(``BuildSettings.probes``), refinement splits the member off as a representative of its own
(``BuildSettings.refine_rounds``).
"""
from __future__ import annotations

import numpy as np

from transition_builder.builder.context import _BuildContext
from transition_builder.builder.representatives import _members, _offer, _refinement_candidates, _with_rotations
from transition_builder.builder.tasks import _KEY_PROBE, _KEY_REFINE, _run_tilts
from transition_builder.builder.weights import _orbit_weights
from transition_builder.status import OK

_PROBE_STREAM = 13          # seed stream of the members a probed row tilts


def probe_members(c: _BuildContext) -> int:
    """Member probes (``BuildSettings.probes``): tilt members of the heavy representatives,
    keep them where the physics is sensitive inside the tolerance; returns orbits founded."""
    ex, settings, scene, grid, index, n_act = c.ex, c.settings, c.scene, c.grid, c.index, c.n_act
    w, _ = _orbit_weights(scene, settings, c.sym, grid, index, ex, c.reps, c.key)
    heavy = np.flatnonzero((w >= settings.probe_weight) & ex.explored[:ex.n_orbits])
    _, orbit, members, _, _ = _members(ex, index, c.sym)
    rng = np.random.default_rng([settings.seed, _PROBE_STREAM])
    by_orbit = np.argsort(orbit, kind="stable")
    bounds = np.searchsorted(orbit[by_orbit], np.stack([heavy, heavy + 1]))
    ids, poses = [], []
    for o, lo, hi in zip(heavy, bounds[0], bounds[1]):
        mine = by_orbit[lo:hi]
        pick = mine if len(mine) <= settings.probes else \
            np.sort(rng.choice(mine, settings.probes, replace=False))
        ids.append(np.full(len(pick), o))
        poses.append(members[pick])
    ids = np.concatenate(ids) if ids else np.zeros(0, dtype=np.int64)
    poses = np.concatenate(poses) if poses else np.zeros((0, 3))
    k = np.arange(len(ids)) - np.searchsorted(ids, ids) + 1        # 1.. within an orbit
    jobs = [(scene.actions[b], poses, np.column_stack([np.full(len(ids), _KEY_PROBE), ids,
                                                      np.full(len(ids), b), k]))
            for b in range(n_act)]
    res = _run_tilts(c.executor, scene, settings.noise, settings.seed, jobs, c.done)
    c.tilts += n_act * len(ids)
    ex.probe_tilts += n_act * len(ids)
    src, land, status = [], [], []
    for b in range(n_act):
        rest, st = res[b]
        rep_st = ex.status[ids, b, 0]
        rep_cell = np.full(len(ids), -1, dtype=np.int64)
        ok_rep = rep_st == OK
        rep_cell[ok_rep] = grid.voxel_index(ex.land[ids[ok_rep], b, 0])
        cell = np.full(len(ids), -1, dtype=np.int64)
        ok = st == OK
        cell[ok] = grid.voxel_index(rest[ok])
        differs = (cell != rep_cell) | (ok != ok_rep)
        if settings.probe_distance > 0:
            both = ok & ok_rep
            far = np.zeros(len(ids), dtype=bool)
            far[both] = index.distance(rest[both], ex.land[ids[both], b, 0]) > settings.probe_distance
            differs |= far
        sensitive = np.isin(ids, ids[differs])                   # every member of such a row
        src.append(np.column_stack([ids[sensitive], np.full(int(sensitive.sum()), b), k[sensitive]]))
        land.append(rest[sensitive])
        status.append(st[sensitive])
    src, land, status = np.concatenate(src), np.concatenate(land), np.concatenate(status)
    order = np.lexsort((src[:, 2], src[:, 1], src[:, 0]))          # by orbit, action, member
    src, land, status = src[order], land[order], status[order]
    ex.more_src = np.concatenate([ex.more_src, src]).astype(np.int64)
    ex.more_land = np.concatenate([ex.more_land, land])
    ex.more_status = np.concatenate([ex.more_status, status]).astype(np.int8)
    ex.probed = 1
    return _offer(index, ex, c.sym, _with_rotations(c.sym, land)) if len(land) else 0


def plan_refinement(c: _BuildContext) -> None:
    """The next refinement round's candidates: the farthest member of every explored orbit."""
    ex = c.ex
    ex.phase = ("refine", ex.phase[1] + 1)
    ex.candidates = _refinement_candidates(ex, c.index, c.sym, c.settings.refine_min_distance)


def refine_phase(c: _BuildContext) -> None:
    """Refinement: tilt the farthest member of each orbit; split where a landing's report cell
    differs from the representative's."""
    ex, scene, grid, index, sym, n_act = c.ex, c.scene, c.grid, c.index, c.sym, c.n_act
    cand = ex.candidates
    rbatch = max(1, int(c.batch_tilts) // n_act)
    while ex.cand_done < len(cand):
        lo, hi = ex.cand_done, min(len(cand), ex.cand_done + rbatch)
        orbit = cand[lo:hi, 0].astype(np.int64)
        member = cand[lo:hi, 1:]
        jobs = [(scene.actions[b], member,
                 np.column_stack([np.full(hi - lo, _KEY_REFINE), np.full(hi - lo, ex.phase[1]),
                                  np.arange(lo, hi), np.full(hi - lo, b)])) for b in range(n_act)]
        res = _run_tilts(c.executor, scene, c.settings.noise, c.settings.seed, jobs, c.done)
        c.tilts += n_act * (hi - lo)
        ex.refine_tilts += n_act * (hi - lo)
        mland = np.stack([r[0] for r in res], axis=1)          # (c, n_act, 3)
        mstat = np.stack([r[1] for r in res], axis=1)
        for i in range(hi - lo):
            o = orbit[i]
            rep_land = ex.land[o, :, 0]
            ok = (mstat[i] == OK) & (ex.status[o, :, 0] == OK)
            if not ok.any():
                continue
            diverge = grid.voxel_index(mland[i][ok]) != grid.voxel_index(rep_land[ok])
            if not diverge.any():
                continue
            p = member[i:i + 1]
            index.add(_with_rotations(sym, p))
            new = ex.n_orbits
            ex.add_orbits(p, split_from=o)
            ex.land[new, :, 0] = mland[i]
            ex.status[new, :, 0] = mstat[i]
            ex.explored[new] = True
            ex.splits += 1
            _offer(index, ex, sym, _with_rotations(sym, ex.land[new]))
        ex.cand_done = hi
        c.maybe_checkpoint()
    ex.phase = ("explore", ex.phase[1])
