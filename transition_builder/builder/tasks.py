"""Tilt tasks: the function that runs on workers, and the streams of tasks the build sends them.

A tilt's noise stream is named by its key (``_KEY_*`` first, then the orbit, action and sample),
so every landing is the same on any executor and any number of workers.
"""
from __future__ import annotations

import numpy as np

from transition_builder.executors import simulator_for
from transition_builder.noise import noise_rng, parse_noise, perturb_pose
from transition_builder.scene import Scene

_KEY_START, _KEY_ORBIT, _KEY_REFINE, _KEY_PROBE = 1, 2, 3, 4   # first key of a sampled tilt's noise stream
_CHUNK = 48                 # tilts per executor task


def tilt_chunk(scene: Scene, action: str, poses: np.ndarray, noise_text: str, seed: int,
               keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tilt every pose under ``action`` after perturbing it with the noise stream of its key.

    Runs in a worker (one cached simulator per scene and process); a task's result depends on its
    own tilts only.

    Parameters
    ----------
    scene : Scene
        The scene.
    action : str
        The tilt action's name.
    poses : ndarray, shape (n, 3)
        Start poses ``(x_mm, y_mm, theta_rad)``.
    noise_text : str
        The process noise spec (``none``: the poses are tilted as given).
    seed : int
        The build's seed.
    keys : ndarray of int, shape (n, m)
        ``keys[i]`` names the noise stream of tilt ``i`` (:func:`transition_builder.noise.noise_rng`).

    Returns
    -------
    rest : ndarray of float64, shape (n, 3)
        Rest poses.
    status : ndarray of int8, shape (n,)
        :mod:`transition_builder.status` codes.
    """
    noise = parse_noise(noise_text)
    p = np.array(poses, dtype=np.float64)
    if not noise.is_zero:
        for i in range(len(p)):
            p[i], _ = perturb_pose(scene, p[i], noise, noise_rng(seed, *(int(k) for k in keys[i])))
    sim = simulator_for(scene)
    sim.fresh_start()        # a task's result depends on its own tilts only
    rest, status = sim.tilt(p, action)
    return np.asarray(rest, dtype=np.float64), np.asarray(status, dtype=np.int8)


def _run_tilts(executor, scene, noise_text, seed, jobs, on_done=None):
    """Run ``jobs`` = list of (action_name, poses (n,3), keys (n, m)); returns [(rest, status)] in order."""
    out = []
    _stream_tilts(executor, scene, noise_text, seed, [jobs], lambda i, res: out.append(res), on_done)
    return out[0]


def _stream_tilts(executor, scene, noise_text, seed, batches, on_batch, on_done=None) -> bool:
    """Run several batches of jobs as one stream of executor tasks.

    ``batches`` is a list of job lists (as for :func:`_run_tilts`); ``on_batch(i, results)`` is
    called for batch 0, 1, ... in order, each as soon as it and every batch before it are done,
    while the workers go on with the later batches (so the parent's snapping overlaps the
    simulation, and no batch's last task leaves a worker idle). Each batch is cut into tasks of
    ``_CHUNK`` exactly as on its own, so the landings are the same as batch after batch. When
    ``on_batch`` returns False the rest is cancelled and False returned; True otherwise.
    """
    tasks, where, outs, pending = [], [], [], []
    for i, jobs in enumerate(batches):
        outs.append([(np.full((len(p), 3), np.nan), np.zeros(len(p), dtype=np.int8)) for _, p, _ in jobs])
        pending.append(0)
        for j, (action, poses, keys) in enumerate(jobs):
            for lo in range(0, len(poses), _CHUNK):
                tasks.append((scene, action, poses[lo:lo + _CHUNK], noise_text, seed, keys[lo:lo + _CHUNK]))
                where.append((i, j, lo))
                pending[i] += 1
    nxt = 0

    def deliver() -> bool:
        nonlocal nxt
        while nxt < len(batches) and pending[nxt] == 0:
            go = on_batch(nxt, outs[nxt])
            outs[nxt] = None
            nxt += 1
            if go is False:
                return False
        return True

    if not deliver():
        return False
    results = executor.map(tilt_chunk, tasks)
    try:
        for idx, (rest, status) in results:
            i, j, lo = where[idx]
            outs[i][j][0][lo:lo + len(rest)] = rest
            outs[i][j][1][lo:lo + len(rest)] = status
            pending[i] -= 1
            if on_done is not None:
                on_done(len(rest))
            if pending[i] == 0 and i == nxt and not deliver():
                return False
    finally:
        close = getattr(results, "close", None)
        if close is not None:
            close()                     # a stopped stream cancels the tasks not yet run
    return deliver()


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
