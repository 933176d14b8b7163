"""The simulator of a scene, kept per process and thread, and :func:`simulate` on it.

Every tilt the product runs -- a builder task, a direct-simulation trial, a user's
:func:`simulate` -- gets its simulator from :func:`simulator_for`: one per scene (keyed by its
content hash) and per thread, built on first use and kept, because building a PyBullet world costs
far more than a tilt. Tasks on any executor (:mod:`transition_builder.executors`) use it the same
way, so results do not depend on where a task ran.
"""
from __future__ import annotations

import hashlib
import pickle
import threading
from collections import OrderedDict

import numpy as np

from transition_builder.scene import Scene
from transition_builder.sim import TraySimulator

__all__ = ["SIM_CACHE_SIZE", "simulate", "simulator_for", "make_simulator"]

#: simulators kept per process and thread (least recently used first out).
SIM_CACHE_SIZE = 4


_LOCAL = threading.local()


def _sim_cache() -> OrderedDict:
    """This thread's simulator cache (key -> simulator)."""
    cache = getattr(_LOCAL, "sims", None)
    if cache is None:
        cache = _LOCAL.sims = OrderedDict()
    return cache


def make_simulator(scene):
    """A new simulator of ``scene`` in the engine its settings name (``scene.settings.engine``):
    :class:`transition_builder.planar.PlanarSimulator` or :class:`transition_builder.sim.TraySimulator`.
    Both have the same interface (``tilt``, ``trajectory``, ``fresh_start``, ``close``)."""
    if getattr(getattr(scene, "settings", None), "engine", "pybullet") == "planar":
        from transition_builder.planar import PlanarSimulator
        return PlanarSimulator(scene)
    return TraySimulator(scene)


def _default_factory(scene):
    return make_simulator(scene)


def _simulator_key(scene, factory) -> str:
    """A key identifying (scene, simulator factory) across processes.

    Every task brings its own unpickled copy of the scene, and a content hash costs about a
    millisecond (thousands of tasks in a build), so keys are remembered per thread by the pickle
    of the pair: an equal pickle is an equal scene (a scene that pickles otherwise is only hashed
    again)."""
    last = getattr(_LOCAL, "last_key", None)
    if last is not None and last[0] is scene and last[1] is factory:
        return last[2]
    blob = pickle.dumps((scene, factory))
    memo = getattr(_LOCAL, "key_memo", None)
    if memo is None:
        memo = _LOCAL.key_memo = OrderedDict()
    key = memo.get(blob)
    if key is None:
        h = hashlib.sha256()
        content_hash = getattr(scene, "content_hash", None)
        h.update(content_hash().encode() if callable(content_hash) else pickle.dumps(scene))
        h.update(pickle.dumps(factory))
        key = memo[blob] = h.hexdigest()
        while len(memo) > 4 * SIM_CACHE_SIZE:
            memo.popitem(last=False)
    _LOCAL.last_key = (scene, factory, key)
    return key


def simulator_for(scene, factory=None):
    """The simulator of ``scene`` in this process and thread, built on first use and then kept.

    Parameters
    ----------
    scene : transition_builder.scene.Scene
        Keyed by its content hash (an object without ``content_hash`` by its pickle).
    factory : callable, optional
        ``factory(scene)`` builds the simulator; default :class:`transition_builder.sim.TraySimulator`.
        Part of the key (by its pickle), so it must be picklable (a module-level function).

    Returns
    -------
    object
        The simulator. At most :data:`SIM_CACHE_SIZE` are kept per thread; the least recently used
        one is closed when another is built.
    """
    key = _simulator_key(scene, factory)
    cache = _sim_cache()
    sim = cache.get(key)
    if sim is None:
        sim = (factory or _default_factory)(scene)
        cache[key] = sim
        while len(cache) > SIM_CACHE_SIZE:
            _, old = cache.popitem(last=False)
            close = getattr(old, "close", None)
            if callable(close):
                close()
    else:
        cache.move_to_end(key)
    return sim


def simulate(scene: Scene, poses, action) -> tuple[np.ndarray, np.ndarray]:
    """Tilt the tray toward ``action`` from every start pose: ``(rest_poses (n, 3), status (n,) int8)``.

    Convenience form of :meth:`TraySimulator.tilt` on the simulator of ``scene`` kept by this
    process and thread (the one simulator cache, :func:`simulator_for`,
    keyed by the scene's content hash). Faulted trials have NaN poses.

    Parameters
    ----------
    scene : Scene
        Shape, tray, friction, tilt and simulator settings.
    poses : array_like (n, 3)
        Start poses ``(x_mm, y_mm, theta_rad)``.
    action : str or int
        Action name or index into ``scene.actions``.

    Returns
    -------
    rest : ndarray (n, 3)
        Rest poses (NaN where a trial faulted).
    status : ndarray (n,) of int8
        Fault codes (:mod:`transition_builder.status`; 0 is OK).
    """
    if not isinstance(scene, Scene):
        raise ValueError(f"simulate needs a Scene, got {type(scene).__name__}")
    return simulator_for(scene).tilt(poses, action)
