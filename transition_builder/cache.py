"""A content-addressed store of built models.

A model is filed under :func:`transition_builder.builder.build_key` — the hash of the scene
(shape, tray, friction, tilt, actions, every solver setting, simulator and PyBullet versions), the
build settings (resolution, samples, noise, seed...) and the builder and package versions — so a
cached model is never reused for a different scene or setting. A file that does not load (corrupt,
foreign, truncated) is rebuilt with a one-line warning, never used. The in-progress checkpoint of a
build lives beside it (``<key>.ckpt.npz``), so a killed build resumes when started again; with
``use_cache=False`` nothing is reused, neither a cached model nor a checkpoint.

The directory is ``$KRUSKAL_CACHE`` if set, else ``~/.cache/kruskal/models``. What a record (a report's
``results.json``, a benchmark's data) keeps of a model is its cache key (:func:`cache_key`: the file's
path relative to the cache, ``<build key>.npz``), never a machine's absolute path; :func:`model_file`
turns a key back into the file on this machine.
"""
from __future__ import annotations

import os
import shutil
import tempfile
import warnings
from typing import NamedTuple

from kruskal_markov.model import ModelError, TransitionModel
from transition_builder.builder import BuildResult, BuildSettings, BuildWarning, build_key, build_model
from transition_builder.scene import Scene

__all__ = ["CachedBuild", "cache_dir", "cache_key", "cached_build", "model_file"]


class CachedBuild(NamedTuple):
    """What :func:`cached_build` gives: unpacks as ``result, path, cached`` as before.

    Attributes
    ----------
    result : BuildResult
        The model and its statistics (those recorded when it was built, for a cached model).
    path : str
        Where the model is: ``out`` if given, else the cache file.
    cached : bool
        Whether a cached model was reused.
    """

    result: BuildResult
    path: str
    cached: bool


def cache_dir() -> str:
    """The model cache directory, created on demand.

    Returns
    -------
    str
        ``$KRUSKAL_CACHE`` if set, else ``~/.cache/kruskal/models``.
    """
    d = os.environ.get("KRUSKAL_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "kruskal", "models")
    os.makedirs(d, exist_ok=True)
    return d


def cache_key(path: str, directory: str | None = None) -> str:
    """The name a record keeps for a model file: its path relative to the model cache.

    Parameters
    ----------
    path : str
        A model file, e.g. the ``path`` of a :class:`CachedBuild`.
    directory : str, optional
        The cache directory (default :func:`cache_dir`).

    Returns
    -------
    str
        ``<build key>.npz`` for a file in the cache; for a file elsewhere (a build's ``out`` copy),
        its file name. Never an absolute path, so a record written on one machine names the same
        model on another (:func:`model_file` finds it).

    Examples
    --------
    >>> cache_key("/any/cache/ab12.npz", directory="/any/cache")
    'ab12.npz'
    >>> cache_key("/elsewhere/allen.npz", directory="/any/cache")
    'allen.npz'
    """
    d = os.path.abspath(directory or cache_dir())
    p = os.path.abspath(path)
    if os.path.commonpath([d, p]) == d and p != d:
        return os.path.relpath(p, d).replace(os.sep, "/")
    return os.path.basename(p)


def model_file(key: str, directory: str | None = None) -> str:
    """The file of a model named by ``key``: ``key`` itself when it is a file here, else the file
    under the model cache (:func:`cache_key` turned around).

    Parameters
    ----------
    key : str
        A cache key (``<build key>.npz``) or a path.
    directory : str, optional
        The cache directory (default :func:`cache_dir`).

    Returns
    -------
    str
        The path to load (it may not exist when the model was never built on this machine).
    """
    if os.path.isfile(key):
        return key
    return os.path.join(directory or cache_dir(), key)


def _copy_atomic(src: str, dst: str) -> None:
    directory = os.path.dirname(os.path.abspath(dst))
    os.makedirs(directory, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".npz", dir=directory)
    os.close(fd)
    try:
        shutil.copyfile(src, tmp)
        os.replace(tmp, dst)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def cached_build(scene: Scene, settings: BuildSettings | None = None, out: str | None = None, *,
                 use_cache: bool = True, directory: str | None = None, **build_kwargs) -> CachedBuild:
    """Build ``scene`` or reuse the cached model of the same key.

    Parameters
    ----------
    scene : Scene
        What to build.
    settings : BuildSettings, optional
        Build settings (default ``BuildSettings()``).
    out : str, optional
        Also copy the model here (atomically).
    use_cache : bool, default True
        Reuse a cached model of the same key and resume its checkpoint; False: build from scratch
        (no reuse of any kind) and file the result in the cache.
    directory : str, optional
        The cache directory (default :func:`cache_dir`).
    **build_kwargs
        Passed to :func:`~transition_builder.builder.build_model` (executor, workers, scheduler,
        progress).

    Returns
    -------
    CachedBuild
        ``result`` (the model and its statistics, those recorded when it was built for a cached
        model), ``path`` (``out`` if given, else the cache file) and ``cached`` (whether a cached
        model was reused); unpacks as a 3-tuple.
    """
    settings = settings or BuildSettings()
    key = build_key(scene, settings)
    d = directory or cache_dir()
    os.makedirs(d, exist_ok=True)
    path = os.path.join(d, f"{key}.npz")
    if use_cache and os.path.exists(path):
        try:
            model = TransitionModel.load(path)
            if model.metadata.get("build_key") != key:
                raise ModelError("its key does not match")
        except ModelError:
            warnings.warn(f"cached model {path} is damaged or not a kruskal model; rebuilding it", BuildWarning,
                          stacklevel=2)
            os.unlink(path)
        else:
            if out:
                _copy_atomic(path, out)
            stats = dict(model.metadata.get("stats", {}))
            return CachedBuild(BuildResult(model, stats), out or path, True)
    result = build_model(scene, settings, checkpoint=os.path.join(d, f"{key}.ckpt.npz"), resume=use_cache,
                         **build_kwargs)
    result.model.save(path)
    if out:
        _copy_atomic(path, out)
    return CachedBuild(result, out or path, False)
