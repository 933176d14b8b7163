"""The driver: :func:`build_model` runs the phases of a build in order (see the package docstring)."""
from __future__ import annotations

import os
import sys
import time

import numpy as np

from transition_builder.builder.assembly import _assemble, _noise_stats
from transition_builder.builder.representatives import (
    _members,
    _offer,
    _recenter,
    _refinement_candidates,
    _snap_spread,
    _with_rotations,
    compensated_noise,
)
from transition_builder.builder.settings import BuildResult, BuildSettings, build_key
from transition_builder.builder.state import NOT_DRAWN, _Exploration
from transition_builder.builder.tasks import (
    _KEY_ORBIT,
    _KEY_PROBE,
    _KEY_REFINE,
    _KEY_START,
    _orbit_jobs,
    _run_tilts,
    _stream_tilts,
)
from transition_builder.builder.weights import (
    _WEIGHT_THRESHOLD,
    _disputed_pairs,
    _heavy_orbits,
    _orbit_weights,
    _proportional_samples,
)
from transition_builder.executors import make_executor
from transition_builder.grid import ReportGrid, parse_grid
from transition_builder.sampling import sample_start_poses
from transition_builder.scene import Scene
from transition_builder.snapping import PoseIndex
from transition_builder.status import OK
from transition_builder.symmetry import tray_symmetry

_START_STREAM = 11          # seed stream of the start poses
_MAX_WEIGHT_ROUNDS = 200    # weighted exploration: at most this many weigh-and-expand rounds
_TOPUP_ROUNDS = 4           # adaptive sampling: at most this many weigh-and-top-up rounds
_PROBE_STREAM = 13          # seed stream of the members a probed row tilts


def build_model(scene: Scene, settings: BuildSettings | None = None, *, executor=None, workers=None,
                scheduler=None, checkpoint: str | None = None, checkpoint_interval_s: float = 30.0,
                progress: bool | None = False, batch_tilts: int = 3000) -> BuildResult:
    """Sample the physics engine into a :class:`TransitionModel` of ``scene`` (see the module docstring).

    Parameters
    ----------
    scene : Scene
    settings : BuildSettings, optional
    executor : transition_builder.executors.Executor, optional
        Where the tilts run; default ``make_executor(workers, scheduler)``.
    checkpoint : str, optional
        Path of a checkpoint file: written atomically every ``checkpoint_interval_s`` seconds
        and after the start phase; a build started again with the same scene and settings resumes
        from it (a checkpoint of another build is ignored). Removed when the build finishes.
    progress : bool or None
        A tqdm bar on standard error (tilts, states, rate); None: only on a terminal.
    batch_tilts : int
        Tilts per exploration batch. Landings are offered in orbit order whatever the batch, but
        the batch decides how tilts are grouped into executor tasks of 48, and the tilts of one
        task share the simulator's worlds, which carry a little state from trial to trial (rare
        landings move by up to 1e-3 rad; docs/simulator.md). So a build is reproduced exactly
        (by any executor, or resumed from a checkpoint) with the same batch; cached builds use the
        default. The batch also decides where ``max_states`` cuts off and how often a checkpoint
        can be taken.

    Returns
    -------
    BuildResult
    """
    if not isinstance(scene, Scene):
        raise ValueError(f"build_model needs a Scene, got {type(scene).__name__}")
    settings = settings or BuildSettings()
    t0 = time.perf_counter()
    key = build_key(scene, settings)
    K = settings.samples
    n_act = len(scene.actions)
    sym = tray_symmetry(scene, settings.symmetry)
    G = sym.order
    grid = ReportGrid(scene.tray_x_mm, scene.tray_y_mm, *parse_grid(settings.grid),
                      symmetry_order=scene.shape.symmetry_order, theta_offset=settings.theta_offset)
    index = PoseIndex(scene.shape, grid, settings.tol_mm, settings.tol_deg, settings.contact_tol_mm,
                      settings.contacts, flush_side=settings.flush_side)
    rounds = settings.refine_rounds if K == 1 else 0
    K0 = min(K, settings.samples_first) if (K > 1 and settings.adaptive) else K
    # agreement-staged top-up: heavy rows to K1 samples, the disputed (row, action) pairs on to K
    K1 = settings.confirm_samples if (K0 < K and settings.confirm_samples) else K
    topup_rounds = _TOPUP_ROUNDS
    weighted = settings.explore_weight > 0
    compensate = settings.snap_compensation and not settings.noise_spec.is_zero
    own_executor = executor is None
    if own_executor:
        executor = make_executor(workers, scheduler)
    if progress is None:
        progress = sys.stderr.isatty()
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(unit="tilt", desc="build", file=sys.stderr, leave=False)

    def done(n):
        if bar is not None:
            bar.update(n)
            bar.set_postfix(states=len(index), explored=int(ex.explored.sum()) * G, refresh=False)

    ex = _Exploration.load(checkpoint, key, n_act, K) if checkpoint and os.path.exists(checkpoint) else None
    resumed = ex is not None
    tilts = 0
    last_ckpt = time.perf_counter()

    def maybe_checkpoint(force=False):
        nonlocal last_ckpt
        if checkpoint and (force or time.perf_counter() - last_ckpt >= checkpoint_interval_s):
            ex.save(checkpoint, key)
            last_ckpt = time.perf_counter()

    try:
        reps = sym.action_orbit_representatives()
        if ex is None:
            ex = _Exploration(n_act, K)
            rng = np.random.default_rng([settings.seed, _START_STREAM])
            ex.start_poses = sample_start_poses(scene.shape, scene.tray_x_mm, scene.tray_y_mm,
                                                settings.start_samples, rng)
            n0 = len(ex.start_poses)
            jobs = [(scene.actions[b], ex.start_poses,
                     np.column_stack([np.full(n0, _KEY_START), np.arange(n0), np.full(n0, b)]))
                    for b in reps]
            res = _run_tilts(executor, scene, settings.noise, settings.seed, jobs, done)
            ex.start_land = np.stack([r[0] for r in res])
            ex.start_status = np.stack([r[1] for r in res])
            tilts += len(reps) * n0
            # offering order: start i, then its action, then the rotation
            _offer(index, ex, sym, _with_rotations(sym, ex.start_land.transpose(1, 0, 2)))
            maybe_checkpoint(force=True)
        else:
            # the index is exactly the representatives saved (every founding decision up to the
            # checkpoint is in them), so continuing gives the same model as an uninterrupted build
            index.add(_with_rotations(sym, ex.orbit_poses))
        batch = max(1, int(batch_tilts) // (n_act * K))
        capped = False

        def sample_noise():
            if compensate:
                return str(compensated_noise(settings.noise_spec, *_snap_spread(ex, index, sym)))
            return settings.noise

        def offer_part(part, res, k_lo, k_hi):
            nonlocal tilts
            tilts += n_act * (k_hi - k_lo) * len(part)
            for b in range(n_act):
                ex.land[part, b, k_lo:k_hi] = res[b][0].reshape(len(part), k_hi - k_lo, 3)
                ex.status[part, b, k_lo:k_hi] = res[b][1].reshape(len(part), k_hi - k_lo)
            ex.explored[part] = True
            _offer(index, ex, sym, _with_rotations(sym, ex.land[part, :, k_lo:k_hi]))

        def sample_orbits(orbits, k_lo, k_hi):
            """Tilt samples k_lo..k_hi-1 of ``orbits`` under every action, offer the landings (in
            orbit order, so the batching never changes the model), batch after batch, streamed."""
            parts = [orbits[lo:lo + batch] for lo in range(0, len(orbits), batch)]
            _stream_tilts(executor, scene, sample_noise(), settings.seed,
                          [_orbit_jobs(scene, ex, part, k_lo, k_hi, _KEY_ORBIT) for part in parts],
                          lambda i, res: offer_part(parts[i], res, k_lo, k_hi), done)

        def explore_batches(parts):
            """The exploration's next batches of orbits (samples 0..K0-1), streamed: before each
            but the first the state cap is checked, after each a checkpoint may be taken, as when
            they were run one by one. False if the cap stopped it."""
            def offer(i, res):
                if i and ex.n_orbits * G >= settings.max_states:
                    return False
                offer_part(parts[i], res, 0, K0)
                maybe_checkpoint()
                return True

            return _stream_tilts(executor, scene, sample_noise(), settings.seed,
                                 [_orbit_jobs(scene, ex, part, 0, K0, _KEY_ORBIT) for part in parts], offer, done)

        def sample_more(orbits, k_lo, k_hi):
            """Tilt samples ``k_lo[i]..k_hi[i]-1`` (beyond ``samples``) of ``orbits[i]`` under every
            action and offer the landings in orbit order (batches of about ``batch_tilts``)."""
            nonlocal tilts
            noise_text = sample_noise()
            cnt_all = (k_hi - k_lo).astype(np.int64)
            start = 0
            while start < len(orbits):
                end, acc = start + 1, n_act * cnt_all[start]
                while end < len(orbits) and acc + n_act * cnt_all[end] <= batch_tilts:
                    acc += n_act * cnt_all[end]
                    end += 1
                part, lo, hi, cnt = orbits[start:end], k_lo[start:end], k_hi[start:end], cnt_all[start:end]
                res = _run_tilts(executor, scene, noise_text, settings.seed,
                                 _orbit_jobs(scene, ex, part, lo, hi, _KEY_ORBIT), done)
                tilts += n_act * int(cnt.sum())
                offs = np.concatenate([[0], np.cumsum(cnt)])
                srcs, lands, stats_ = [], [], []
                for i, o in enumerate(part):
                    sl = slice(offs[i], offs[i + 1])
                    land_o = np.stack([res[b][0][sl] for b in range(n_act)])        # (n_act, c, 3)
                    stat_o = np.stack([res[b][1][sl] for b in range(n_act)])
                    c = int(cnt[i])
                    srcs.append(np.column_stack([np.full(n_act * c, o), np.repeat(np.arange(n_act), c),
                                                 np.tile(np.arange(lo[i], hi[i]), n_act)]))
                    lands.append(land_o.reshape(-1, 3))
                    stats_.append(stat_o.reshape(-1))
                _offer(index, ex, sym, _with_rotations(sym, np.concatenate(lands)))
                ex.more_src = np.concatenate([ex.more_src] + srcs).astype(np.int64)
                ex.more_land = np.concatenate([ex.more_land] + lands)
                ex.more_status = np.concatenate([ex.more_status] + stats_).astype(np.int8)
                start = end

        def sample_pairs(pairs, k_lo, k_hi):
            """Tilt samples k_lo..k_hi-1 of the (orbit, action) ``pairs`` (sorted by orbit, then
            action) and offer the landings in that order."""
            nonlocal tilts
            noise_text = sample_noise()
            step = max(1, int(batch_tilts) // (k_hi - k_lo))
            for lo in range(0, len(pairs), step):
                part = pairs[lo:lo + step]
                jobs, slots = [], []
                for b in np.unique(part[:, 1]):
                    orbits = part[part[:, 1] == b, 0]
                    jobs += _orbit_jobs(scene, ex, orbits, k_lo, k_hi, _KEY_ORBIT, actions=[b])
                    slots.append((orbits, b))
                res = _run_tilts(executor, scene, noise_text, settings.seed, jobs, done)
                tilts += len(part) * (k_hi - k_lo)
                for (orbits, b), (rest, status) in zip(slots, res):
                    ex.land[orbits, b, k_lo:k_hi] = rest.reshape(len(orbits), k_hi - k_lo, 3)
                    ex.status[orbits, b, k_lo:k_hi] = status.reshape(len(orbits), k_hi - k_lo)
                _offer(index, ex, sym, _with_rotations(sym, ex.land[part[:, 0], part[:, 1], k_lo:k_hi]))

        def probe_members():
            """Member probes (``BuildSettings.probes``): tilt members of the heavy representatives,
            keep them where the physics is sensitive inside the tolerance; returns orbits founded."""
            nonlocal tilts
            w, _ = _orbit_weights(scene, settings, sym, grid, index, ex, reps, key)
            heavy = np.flatnonzero((w >= settings.probe_weight) & ex.explored[:ex.n_orbits])
            _, orbit, members, _, _ = _members(ex, index, sym)
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
            res = _run_tilts(executor, scene, settings.noise, settings.seed, jobs, done)
            tilts += n_act * len(ids)
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
            return _offer(index, ex, sym, _with_rotations(sym, land)) if len(land) else 0

        if weighted:
            # weighted exploration: expand only what carries mass (module docstring); one
            # checkpoint per round, so a resumed build makes exactly the same decisions
            while ex.phase[1] < _MAX_WEIGHT_ROUNDS:
                w, first = _orbit_weights(scene, settings, sym, grid, index, ex, reps, key)
                n = ex.n_orbits
                expl = ex.explored[:n]
                todo = np.flatnonzero(~expl & ((w >= settings.explore_weight) | first))
                heavy = expl & (w >= _WEIGHT_THRESHOLD)
                top = np.flatnonzero(heavy & (ex.status[:n, 0, K1 - 1] == NOT_DRAWN)) \
                    if K0 < K else np.zeros(0, dtype=np.int64)
                disputed = _disputed_pairs(ex, grid, np.flatnonzero(heavy), K1, K) if K1 < K \
                    else np.zeros((0, 2), dtype=np.int64)
                more = np.zeros(0, dtype=np.int64)
                if settings.max_samples:
                    # samples in proportion to weight: only rows whose first K samples are drawn
                    target = _proportional_samples(w, K, settings.heavy_weight, settings.max_samples)
                    have = K + ex.more_count[:n]
                    more = np.flatnonzero(expl & (ex.status[:n, 0, K - 1] != NOT_DRAWN) & (target > have))
                if len(todo) == 0 and len(top) == 0 and len(disputed) == 0 and len(more) == 0:
                    break
                if ex.n_orbits * G >= settings.max_states:
                    capped = True
                    break
                sample_orbits(todo, 0, K0)
                if len(top):
                    sample_orbits(top, K0, K1)
                    ex.topup_tilts += n_act * (K1 - K0) * len(top)
                if len(disputed):
                    sample_pairs(disputed, K1, K)
                    ex.topup_tilts += (K - K1) * len(disputed)
                if len(more):
                    sample_more(more, have[more], target[more])
                ex.phase = ("explore", ex.phase[1] + 1)
                maybe_checkpoint(force=True)
            ex.phase = ("done", ex.phase[1])
        while ex.phase[0] != "done":
            if ex.phase[0] == "explore":
                while not capped:
                    queue = np.flatnonzero(~ex.explored[:ex.n_orbits])
                    if len(queue) == 0:
                        break
                    if ex.n_orbits * G >= settings.max_states:
                        capped = True
                        break
                    # the next len(queue) // batch batches are known now (landings found new orbits at
                    # the end of the queue), so they run as one stream; with snap compensation the
                    # noise is worked out anew before each batch, so one at a time
                    known = 1 if compensate else max(1, len(queue) // batch)
                    if not explore_batches([queue[i * batch:(i + 1) * batch] for i in range(known)]):
                        capped = True
                        break
                if not capped and K == 1 and ex.recentered < settings.recenter_rounds:
                    ex.recentered += 1
                    moved = _recenter(ex, index, sym)
                    ex.moved += moved
                    maybe_checkpoint(force=True)
                    if moved:
                        continue
                    ex.recentered = settings.recenter_rounds
                if not capped and settings.probes and not ex.probed:
                    founded = probe_members()
                    maybe_checkpoint(force=True)
                    if founded:
                        continue
                if capped or ex.phase[1] >= (topup_rounds if K0 < K else rounds):
                    break
                if K0 < K:
                    heavy = _heavy_orbits(scene, settings, sym, grid, index, ex, reps, key)
                    need = heavy[ex.status[heavy, 0, K0] == NOT_DRAWN] if len(heavy) else heavy
                    if len(need) == 0:
                        break
                    ex.phase = ("topup", ex.phase[1] + 1)
                    ex.candidates = need.astype(np.float64)[:, None]
                else:
                    ex.phase = ("refine", ex.phase[1] + 1)
                    ex.candidates = _refinement_candidates(ex, index, sym, settings.refine_min_distance)
                ex.cand_done = 0
                maybe_checkpoint(force=True)
            if ex.phase[0] == "topup":
                # adaptive sampling: rows that carry mass get the remaining K - K0 samples
                cand = ex.candidates[:, 0].astype(np.int64)
                tbatch = max(1, int(batch_tilts) // (n_act * (K - K0)))
                while ex.cand_done < len(cand):
                    lo, hi = ex.cand_done, min(len(cand), ex.cand_done + tbatch)
                    sample_orbits(cand[lo:hi], K0, K)
                    ex.topup_tilts += n_act * (K - K0) * (hi - lo)
                    ex.cand_done = hi
                    maybe_checkpoint()
                ex.phase = ("explore", ex.phase[1])
                continue
            # refinement: tilt the farthest member of each orbit; split where a landing's report
            # cell differs from the representative's
            cand = ex.candidates
            rbatch = max(1, int(batch_tilts) // n_act)
            while ex.cand_done < len(cand):
                lo, hi = ex.cand_done, min(len(cand), ex.cand_done + rbatch)
                orbit = cand[lo:hi, 0].astype(np.int64)
                member = cand[lo:hi, 1:]
                jobs = [(scene.actions[b], member,
                         np.column_stack([np.full(hi - lo, _KEY_REFINE), np.full(hi - lo, ex.phase[1]),
                                          np.arange(lo, hi), np.full(hi - lo, b)])) for b in range(n_act)]
                res = _run_tilts(executor, scene, settings.noise, settings.seed, jobs, done)
                tilts += n_act * (hi - lo)
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
                maybe_checkpoint()
            ex.phase = ("explore", ex.phase[1])
    finally:
        if bar is not None:
            bar.close()
        if own_executor:
            executor.close()
    model, stats = _assemble(scene, settings, sym, grid, index, ex, reps, key, {
        "tilts_simulated": tilts, "resumed": resumed, "simulation_seconds": time.perf_counter() - t0,
        "refinement_rounds": ex.phase[1] if (K == 1 and not weighted) else 0,
        "representatives_split": ex.splits, "refinement_tilts": ex.refine_tilts,
        "adaptive_rounds": ex.phase[1] if (K0 < K and not weighted) else 0,
        "exploration_rounds": ex.phase[1] if weighted else 0,
        "topup_tilts": ex.topup_tilts, "samples_first": K0, "confirm_samples": K1 if K1 < K else 0,
        "recentring_rounds": ex.recentered,
        "max_samples": settings.max_samples, "rows_sampled_by_weight": int(np.sum(ex.more_count > 0)),
        "weighted_sample_tilts": int(len(ex.more_src)),
        "representatives_moved": ex.moved,
        **({"probes": settings.probes, "probe_tilts": ex.probe_tilts,
            "rows_probed_sensitive": int(len(np.unique(ex.more_src[:, :2], axis=0))) if len(ex.more_src) else 0}
           if settings.probes else {}),
        **_noise_stats(settings, ex, index, sym)})
    if checkpoint and os.path.exists(checkpoint):
        os.unlink(checkpoint)
    return BuildResult(model, stats)
