"""The driver: :func:`build_model` runs the phases of a build in order (see the package docstring).

The phases are functions of one explicit :class:`~transition_builder.builder.context._BuildContext`:
the start tilts, then weighted exploration (noisy builds) or breadth-first exploration with
recentring, member probes, adaptive top-ups and refinement rounds, then assembly.
"""
from __future__ import annotations

import os
import time
import warnings

import numpy as np

from transition_builder.builder import exploration as _explore
from transition_builder.builder import refinement as _refine
from transition_builder.builder.assembly import _assemble, _noise_stats
from transition_builder.builder.build_settings import BuildResult, BuildSettings, build_key
from transition_builder.builder.context import _BuildContext
from transition_builder.builder.exploration import _MAX_WEIGHT_ROUNDS, _START_STREAM, _TOPUP_ROUNDS  # noqa: F401
from transition_builder.builder.refinement import _PROBE_STREAM  # noqa: F401
from transition_builder.builder.representatives import _with_rotations
from transition_builder.builder.state import CheckpointError, _Exploration
from transition_builder.executors import SchedulerLost
from transition_builder.grid import ReportGrid, parse_grid
from transition_builder.noise import check_noise_for_tray
from transition_builder.scene import Scene
from transition_builder.snapping import PoseIndex
from transition_builder.status import OK
from transition_builder.symmetry import tray_symmetry
from transition_builder.tilting import TiltEngine


class BuildWarning(UserWarning):
    """Something a build recovered from (a checkpoint set aside, a cached model rebuilt).

    Parameters
    ----------
    message : str
        One line in the project's words, naming the file concerned (as for any :class:`Warning`).
    """


def build_model(scene: Scene, settings: BuildSettings | None = None, *, executor=None, workers=None,
                scheduler=None, checkpoint: str | None = None, checkpoint_interval_s: float = 30.0,
                progress: bool | None = False, batch_tilts: int = 3000, resume: bool = True) -> BuildResult:
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
        from it. A checkpoint that cannot be resumed (unreadable, of another build, or holding a
        landing none of its representatives covers) is set aside as ``<checkpoint>.rejected`` with
        a one-line :class:`BuildWarning`, and the build starts from scratch. Removed when the build
        finishes; kept when it stops (interrupted, or the Dask scheduler lost).
    resume : bool, default True
        Resume from ``checkpoint`` if it exists; False: start from scratch (the checkpoint is
        overwritten), as ``kruskal build --no-cache`` does.
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
    check_noise_for_tray(settings.noise, scene.tray_x_mm, scene.tray_y_mm)
    t0 = time.perf_counter()
    c = _context(scene, settings, executor, batch_tilts, checkpoint, checkpoint_interval_s)
    if resume and checkpoint and os.path.exists(checkpoint):
        c.ex = _resume(c, checkpoint)
        if c.ex is None:
            c = _context(scene, settings, executor, batch_tilts, checkpoint, checkpoint_interval_s)
    resumed = c.ex is not None
    # one tilt engine owns the executor made here (a given one stays the caller's) and the bar
    engine = TiltEngine(executor, workers=workers, scheduler=scheduler, progress=progress, unit="tilt",
                        desc="build")
    c.executor, c.bar = engine, engine.bar
    try:
        if c.ex is None:
            _explore.start_phase(c)
        if settings.explore_weight > 0:
            _explore.weighted_exploration(c)
        _run_phases(c)
    except SchedulerLost as exc:
        kept = f"; checkpoint {checkpoint} kept, run the same build again to resume" \
            if checkpoint and os.path.exists(checkpoint) else ""
        raise SchedulerLost(f"{exc}{kept}") from None
    finally:
        engine.close()
    model, stats = _assemble(scene, settings, c.sym, c.grid, c.index, c.ex, c.reps, c.key,
                             _run_stats(c, resumed, time.perf_counter() - t0))
    if checkpoint and os.path.exists(checkpoint):
        os.unlink(checkpoint)
    return BuildResult(model, stats)


def _resume(c: _BuildContext, checkpoint: str) -> _Exploration | None:
    """The state saved in ``checkpoint``, its representatives added to the snapping index, if it
    belongs to this build and replays (every landing it holds lies within tolerance of one of its
    representatives, as after every phase of a build); else None, the checkpoint set aside as
    ``<checkpoint>.rejected`` with a one-line warning naming it."""
    try:
        ex = _Exploration.read(checkpoint, c.key, c.n_act, c.K)
    except CheckpointError as why:
        return _set_aside(checkpoint, str(why))
    # the index is exactly the representatives saved (every founding decision up to the
    # checkpoint is in them), so continuing gives the same model as an uninterrupted build
    c.index.add(_with_rotations(c.sym, ex.orbit_poses))
    c.index.compact()
    done = np.flatnonzero(ex.explored[:ex.n_orbits])
    landings = [ex.start_land[ex.start_status == OK], ex.land[done][ex.status[done] == OK],
                ex.more_land[ex.more_status == OK]]
    for land in landings:
        if len(land) and np.any(c.index.snap(_with_rotations(c.sym, land)) < 0):
            return _set_aside(checkpoint, "a landing in it has no representative within tolerance")
    c.tilts_before = ex.tilts_done
    return ex


def _set_aside(checkpoint: str, why: str) -> None:
    aside = checkpoint + ".rejected"
    os.replace(checkpoint, aside)
    warnings.warn(f"checkpoint {checkpoint} cannot be resumed: {why}; set aside as {aside}, building from scratch",
                  BuildWarning, stacklevel=4)
    return None


def _context(scene, settings, executor, batch_tilts, checkpoint, checkpoint_interval_s) -> _BuildContext:
    """The build's context: derived sample counts, symmetry, grid and an empty snapping index."""
    key = build_key(scene, settings)
    K = settings.samples
    n_act = len(scene.actions)
    sym = tray_symmetry(scene, settings.symmetry)
    grid = ReportGrid(scene.tray_x_mm, scene.tray_y_mm, *parse_grid(settings.grid),
                      symmetry_order=scene.shape.symmetry_order, theta_offset=settings.theta_offset)
    index = PoseIndex(scene.shape, grid, settings.tol_mm, settings.tol_deg, settings.contact_tol_mm,
                      settings.contacts, flush_side=settings.flush_side)
    K0 = min(K, settings.samples_first) if (K > 1 and settings.adaptive) else K
    # agreement-staged top-up: heavy rows to K1 samples, the disputed (row, action) pairs on to K
    K1 = settings.confirm_samples if (K0 < K and settings.confirm_samples) else K
    return _BuildContext(scene=scene, settings=settings, key=key, K=K, K0=K0, K1=K1, n_act=n_act, sym=sym,
                         grid=grid, index=index, reps=sym.action_orbit_representatives(), executor=executor,
                         batch_tilts=batch_tilts,
                         compensate=settings.snap_compensation and not settings.noise_spec.is_zero,
                         checkpoint=checkpoint, checkpoint_interval_s=checkpoint_interval_s,
                         batch=max(1, int(batch_tilts) // (n_act * K)))


def _run_phases(c: _BuildContext) -> None:
    """Deterministic and adaptive builds: explore, recentre, probe, then top-up or refinement
    rounds, each followed by exploration of what it reached, until nothing is left to do."""
    ex = c.ex
    rounds = c.settings.refine_rounds if c.K == 1 else 0
    while ex.phase[0] != "done":
        if ex.phase[0] == "explore":
            _explore.explore_queue(c)
            if _explore.recenter_round(c):
                continue
            if not c.capped and c.settings.probes and not ex.probed:
                founded = _refine.probe_members(c)
                c.maybe_checkpoint(force=True)
                if founded:
                    continue
            if c.capped or ex.phase[1] >= (_TOPUP_ROUNDS if c.K0 < c.K else rounds):
                break
            if c.K0 < c.K:
                if not _explore.plan_topup(c):
                    break
            else:
                _refine.plan_refinement(c)
            ex.cand_done = 0
            c.maybe_checkpoint(force=True)
        if ex.phase[0] == "topup":
            _explore.topup_phase(c)
            continue
        _refine.refine_phase(c)


def _run_stats(c: _BuildContext, resumed: bool, seconds: float) -> dict:
    """What the run did (the statistics beyond the model's own; ``kruskal build`` JSON keys)."""
    ex, settings, K, K0, K1 = c.ex, c.settings, c.K, c.K0, c.K1
    weighted = settings.explore_weight > 0
    return {
        "tilts_simulated": c.tilts_before + c.tilts, "tilts_this_run": c.tilts, "resumed": resumed, "simulation_seconds": seconds,
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
        **_noise_stats(settings, ex, c.index, c.sym)}
