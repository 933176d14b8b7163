"""Exploration: the start tilts, breadth-first and weighted exploration, adaptive top-ups.

Every function takes the build's :class:`~transition_builder.builder.context._BuildContext` ``c``;
landings are always offered in orbit order, so the batching never changes the model.
"""
from __future__ import annotations

import numpy as np

from transition_builder.builder.context import _BuildContext
from transition_builder.builder.representatives import _offer, _recenter, _with_rotations
from transition_builder.builder.state import NOT_DRAWN, _Exploration
from transition_builder.builder.tasks import _KEY_ORBIT, _KEY_START, _orbit_jobs, _run_tilts, _stream_tilts
from transition_builder.builder.weights import (
    _WEIGHT_THRESHOLD,
    _disputed_pairs,
    _heavy_orbits,
    _orbit_weights,
    _proportional_samples,
)
from transition_builder.sampling import sample_start_poses

_START_STREAM = 11          # seed stream of the start poses
_MAX_WEIGHT_ROUNDS = 200    # weighted exploration: at most this many weigh-and-expand rounds
_TOPUP_ROUNDS = 4           # adaptive sampling: at most this many weigh-and-top-up rounds


def start_phase(c: _BuildContext) -> None:
    """Tilt the uniform start poses under one action per action orbit and offer their landings."""
    scene, settings = c.scene, c.settings
    c.ex = ex = _Exploration(c.n_act, c.K)
    rng = np.random.default_rng([settings.seed, _START_STREAM])
    ex.start_poses = sample_start_poses(scene.shape, scene.tray_x_mm, scene.tray_y_mm,
                                        settings.start_samples, rng)
    n0 = len(ex.start_poses)
    jobs = [(scene.actions[b], ex.start_poses,
             np.column_stack([np.full(n0, _KEY_START), np.arange(n0), np.full(n0, b)]))
            for b in c.reps]
    res = _run_tilts(c.executor, scene, settings.noise, settings.seed, jobs, c.done)
    ex.start_land = np.stack([r[0] for r in res])
    ex.start_status = np.stack([r[1] for r in res])
    c.tilts += len(c.reps) * n0
    # offering order: start i, then its action, then the rotation
    _offer(c.index, ex, c.sym, _with_rotations(c.sym, ex.start_land.transpose(1, 0, 2)))
    c.maybe_checkpoint(force=True)


def offer_part(c: _BuildContext, part, res, k_lo, k_hi) -> None:
    """Store samples ``k_lo..k_hi-1`` of the orbits ``part`` (``res``: one (rest, status) per action)
    and offer their landings."""
    ex = c.ex
    c.tilts += c.n_act * (k_hi - k_lo) * len(part)
    for b in range(c.n_act):
        ex.land[part, b, k_lo:k_hi] = res[b][0].reshape(len(part), k_hi - k_lo, 3)
        ex.status[part, b, k_lo:k_hi] = res[b][1].reshape(len(part), k_hi - k_lo)
    ex.explored[part] = True
    _offer(c.index, ex, c.sym, _with_rotations(c.sym, ex.land[part, :, k_lo:k_hi]))


def sample_orbits(c: _BuildContext, orbits, k_lo, k_hi) -> None:
    """Tilt samples k_lo..k_hi-1 of ``orbits`` under every action, offer the landings (in
    orbit order, so the batching never changes the model), batch after batch, streamed."""
    parts = [orbits[lo:lo + c.batch] for lo in range(0, len(orbits), c.batch)]
    _stream_tilts(c.executor, c.scene, c.sample_noise(), c.settings.seed,
                  [_orbit_jobs(c.scene, c.ex, part, k_lo, k_hi, _KEY_ORBIT) for part in parts],
                  lambda i, res: offer_part(c, parts[i], res, k_lo, k_hi), c.done)


def explore_batches(c: _BuildContext, parts) -> bool:
    """The exploration's next batches of orbits (samples 0..K0-1), streamed: before each
    but the first the state cap is checked, after each a checkpoint may be taken, as when
    they were run one by one. False if the cap stopped it."""
    def offer(i, res):
        if i and c.ex.n_orbits * c.G >= c.settings.max_states:
            return False
        offer_part(c, parts[i], res, 0, c.K0)
        c.maybe_checkpoint()
        return True

    return _stream_tilts(c.executor, c.scene, c.sample_noise(), c.settings.seed,
                         [_orbit_jobs(c.scene, c.ex, part, 0, c.K0, _KEY_ORBIT) for part in parts], offer, c.done)


def sample_more(c: _BuildContext, orbits, k_lo, k_hi) -> None:
    """Tilt samples ``k_lo[i]..k_hi[i]-1`` (beyond ``samples``) of ``orbits[i]`` under every
    action and offer the landings in orbit order (batches of about ``batch_tilts``)."""
    ex, n_act = c.ex, c.n_act
    noise_text = c.sample_noise()
    cnt_all = (k_hi - k_lo).astype(np.int64)
    start = 0
    while start < len(orbits):
        end, acc = start + 1, n_act * cnt_all[start]
        while end < len(orbits) and acc + n_act * cnt_all[end] <= c.batch_tilts:
            acc += n_act * cnt_all[end]
            end += 1
        part, lo, hi, cnt = orbits[start:end], k_lo[start:end], k_hi[start:end], cnt_all[start:end]
        res = _run_tilts(c.executor, c.scene, noise_text, c.settings.seed,
                         _orbit_jobs(c.scene, ex, part, lo, hi, _KEY_ORBIT), c.done)
        c.tilts += n_act * int(cnt.sum())
        offs = np.concatenate([[0], np.cumsum(cnt)])
        srcs, lands, stats_ = [], [], []
        for i, o in enumerate(part):
            sl = slice(offs[i], offs[i + 1])
            land_o = np.stack([res[b][0][sl] for b in range(n_act)])        # (n_act, c, 3)
            stat_o = np.stack([res[b][1][sl] for b in range(n_act)])
            k = int(cnt[i])
            srcs.append(np.column_stack([np.full(n_act * k, o), np.repeat(np.arange(n_act), k),
                                         np.tile(np.arange(lo[i], hi[i]), n_act)]))
            lands.append(land_o.reshape(-1, 3))
            stats_.append(stat_o.reshape(-1))
        _offer(c.index, ex, c.sym, _with_rotations(c.sym, np.concatenate(lands)))
        ex.more_src = np.concatenate([ex.more_src] + srcs).astype(np.int64)
        ex.more_land = np.concatenate([ex.more_land] + lands)
        ex.more_status = np.concatenate([ex.more_status] + stats_).astype(np.int8)
        start = end


def sample_pairs(c: _BuildContext, pairs, k_lo, k_hi) -> None:
    """Tilt samples k_lo..k_hi-1 of the (orbit, action) ``pairs`` (sorted by orbit, then
    action) and offer the landings in that order."""
    ex = c.ex
    noise_text = c.sample_noise()
    step = max(1, int(c.batch_tilts) // (k_hi - k_lo))
    for lo in range(0, len(pairs), step):
        part = pairs[lo:lo + step]
        jobs, slots = [], []
        for b in np.unique(part[:, 1]):
            orbits = part[part[:, 1] == b, 0]
            jobs += _orbit_jobs(c.scene, ex, orbits, k_lo, k_hi, _KEY_ORBIT, actions=[b])
            slots.append((orbits, b))
        res = _run_tilts(c.executor, c.scene, noise_text, c.settings.seed, jobs, c.done)
        c.tilts += len(part) * (k_hi - k_lo)
        for (orbits, b), (rest, status) in zip(slots, res):
            ex.land[orbits, b, k_lo:k_hi] = rest.reshape(len(orbits), k_hi - k_lo, 3)
            ex.status[orbits, b, k_lo:k_hi] = status.reshape(len(orbits), k_hi - k_lo)
        _offer(c.index, ex, c.sym, _with_rotations(c.sym, ex.land[part[:, 0], part[:, 1], k_lo:k_hi]))


def weighted_exploration(c: _BuildContext) -> None:
    """Weighted exploration: expand only what carries mass (package docstring); one checkpoint
    per round, so a resumed build makes exactly the same decisions."""
    ex, settings, K, K0, K1 = c.ex, c.settings, c.K, c.K0, c.K1
    while ex.phase[1] < _MAX_WEIGHT_ROUNDS:
        w, first = _orbit_weights(c.scene, settings, c.sym, c.grid, c.index, ex, c.reps, c.key)
        n = ex.n_orbits
        expl = ex.explored[:n]
        todo = np.flatnonzero(~expl & ((w >= settings.explore_weight) | first))
        heavy = expl & (w >= _WEIGHT_THRESHOLD)
        top = np.flatnonzero(heavy & (ex.status[:n, 0, K1 - 1] == NOT_DRAWN)) \
            if K0 < K else np.zeros(0, dtype=np.int64)
        disputed = _disputed_pairs(ex, c.grid, np.flatnonzero(heavy), K1, K) if K1 < K \
            else np.zeros((0, 2), dtype=np.int64)
        more = np.zeros(0, dtype=np.int64)
        if settings.max_samples:
            # samples in proportion to weight: only rows whose first K samples are drawn
            target = _proportional_samples(w, K, settings.heavy_weight, settings.max_samples)
            have = K + ex.more_count[:n]
            more = np.flatnonzero(expl & (ex.status[:n, 0, K - 1] != NOT_DRAWN) & (target > have))
        if len(todo) == 0 and len(top) == 0 and len(disputed) == 0 and len(more) == 0:
            break
        if ex.n_orbits * c.G >= settings.max_states:
            c.capped = True
            break
        sample_orbits(c, todo, 0, K0)
        if len(top):
            sample_orbits(c, top, K0, K1)
            ex.topup_tilts += c.n_act * (K1 - K0) * len(top)
        if len(disputed):
            sample_pairs(c, disputed, K1, K)
            ex.topup_tilts += (K - K1) * len(disputed)
        if len(more):
            sample_more(c, more, have[more], target[more])
        ex.phase = ("explore", ex.phase[1] + 1)
        c.maybe_checkpoint(force=True)
    ex.phase = ("done", ex.phase[1])


def explore_queue(c: _BuildContext) -> None:
    """Breadth-first: tilt every unexplored orbit until none is left or the state cap is reached."""
    ex = c.ex
    while not c.capped:
        queue = np.flatnonzero(~ex.explored[:ex.n_orbits])
        if len(queue) == 0:
            break
        if ex.n_orbits * c.G >= c.settings.max_states:
            c.capped = True
            break
        # the next len(queue) // batch batches are known now (landings found new orbits at
        # the end of the queue), so they run as one stream; with snap compensation the
        # noise is worked out anew before each batch, so one at a time
        known = 1 if c.compensate else max(1, len(queue) // c.batch)
        if not explore_batches(c, [queue[i * c.batch:(i + 1) * c.batch] for i in range(known)]):
            c.capped = True
            break


def recenter_round(c: _BuildContext) -> bool:
    """One recentring round (deterministic builds) if one is due; True if representatives moved
    (exploration then continues from them)."""
    ex = c.ex
    if c.capped or c.K != 1 or ex.recentered >= c.settings.recenter_rounds:
        return False
    ex.recentered += 1
    moved = _recenter(ex, c.index, c.sym)
    ex.moved += moved
    c.maybe_checkpoint(force=True)
    if moved:
        return True
    ex.recentered = c.settings.recenter_rounds
    return False


def plan_topup(c: _BuildContext) -> bool:
    """Adaptive sampling: the heavy rows still missing samples become the candidates of a top-up
    round; False if there are none."""
    ex = c.ex
    heavy = _heavy_orbits(c.scene, c.settings, c.sym, c.grid, c.index, ex, c.reps, c.key)
    need = heavy[ex.status[heavy, 0, c.K0] == NOT_DRAWN] if len(heavy) else heavy
    if len(need) == 0:
        return False
    ex.phase = ("topup", ex.phase[1] + 1)
    ex.candidates = need.astype(np.float64)[:, None]
    return True


def topup_phase(c: _BuildContext) -> None:
    """Adaptive sampling: rows that carry mass get the remaining K - K0 samples."""
    ex, K, K0 = c.ex, c.K, c.K0
    cand = ex.candidates[:, 0].astype(np.int64)
    tbatch = max(1, int(c.batch_tilts) // (c.n_act * (K - K0)))
    while ex.cand_done < len(cand):
        lo, hi = ex.cand_done, min(len(cand), ex.cand_done + tbatch)
        sample_orbits(c, cand[lo:hi], K0, K)
        ex.topup_tilts += c.n_act * (K - K0) * (hi - lo)
        ex.cand_done = hi
        c.maybe_checkpoint()
    ex.phase = ("explore", ex.phase[1])
