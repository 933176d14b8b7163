"""transition_builder.cache: the content-addressed model store, with the build replaced by a stub
(the real builds and their cache hits are exercised in test_build_model.py and test_reproduce.py)."""
from __future__ import annotations

import os
import warnings

import numpy as np
import pytest

import transition_builder.cache as cache
from kruskal_markov.model import TransitionModel
from transition_builder.builder import BuildResult, BuildSettings, build_key
from transition_builder.scene import scene_from_options


@pytest.fixture
def stub_build(monkeypatch):
    """Replace the physics build by a stub that records its calls and returns a 2-state model
    labelled with the key of its scene and settings."""
    calls = []

    def build(scene, settings, checkpoint=None, **kwargs):
        calls.append({"checkpoint": checkpoint, **kwargs})
        model = TransitionModel(["N"], [np.eye(2)], metadata={"build_key": build_key(scene, settings)})
        return BuildResult(model, {"states": 2})
    monkeypatch.setattr(cache, "build_model", build)
    return calls


@pytest.fixture
def scene():
    return scene_from_options("rectangle:20x20")


def test_cache_dir_honours_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("KRUSKAL_CACHE", str(tmp_path / "models"))
    assert cache.cache_dir() == str(tmp_path / "models") and os.path.isdir(tmp_path / "models")
    monkeypatch.delenv("KRUSKAL_CACHE")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert cache.cache_dir() == str(tmp_path / "home" / ".cache" / "kruskal" / "models")


def test_build_once_then_reuse_by_key(stub_build, scene, tmp_path):
    settings = BuildSettings(seed=1)
    key = build_key(scene, settings)
    result, path, cached = cache.cached_build(scene, settings, directory=str(tmp_path), workers=1)
    assert cached is False and path == str(tmp_path / f"{key}.npz") and os.path.exists(path)
    assert stub_build == [{"checkpoint": str(tmp_path / f"{key}.ckpt.npz"), "resume": True, "workers": 1}]
    again, path2, cached2 = cache.cached_build(scene, settings, directory=str(tmp_path))
    assert cached2 is True and path2 == path and len(stub_build) == 1          # no second build
    assert again.model.same_arrays(result.model) and again.stats == {}
    # another setting is another key: built anew
    _, path3, cached3 = cache.cached_build(scene, BuildSettings(seed=2), directory=str(tmp_path))
    assert cached3 is False and path3 != path and len(stub_build) == 2
    # use_cache=False builds even with a cached model present
    _, _, cached4 = cache.cached_build(scene, settings, directory=str(tmp_path), use_cache=False)
    assert cached4 is False and len(stub_build) == 3
    assert stub_build[-1]["resume"] is False               # --no-cache: no reuse of any kind


def test_out_gets_a_copy(stub_build, scene, tmp_path):
    out = tmp_path / "elsewhere" / "model.npz"
    _, path, cached = cache.cached_build(scene, BuildSettings(), out=str(out), directory=str(tmp_path / "c"))
    assert path == str(out) and out.exists() and not cached
    out.unlink()
    _, path, cached = cache.cached_build(scene, BuildSettings(), out=str(out), directory=str(tmp_path / "c"))
    assert cached and out.exists()
    assert not [p for p in os.listdir(out.parent) if p.startswith(".tmp-")]       # no temporary left


@pytest.mark.parametrize("damage", ["garbage", "foreign key"])
def test_unusable_cached_file_is_rebuilt_with_a_warning(stub_build, scene, tmp_path, damage):
    settings = BuildSettings()
    key = build_key(scene, settings)
    path = tmp_path / f"{key}.npz"
    if damage == "garbage":
        path.write_bytes(b"not a model at all")
    else:
        TransitionModel(["N"], [np.eye(2)], metadata={"build_key": "someone-else"}).save(str(path))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _, p, cached = cache.cached_build(scene, settings, directory=str(tmp_path))
    assert cached is False and len(stub_build) == 1
    assert any(str(path) in str(w.message) and "rebuilding" in str(w.message) for w in caught)
    assert TransitionModel.load(p).metadata["build_key"] == key


def test_a_record_names_a_model_by_its_cache_key_and_finds_it_again(stub_build, scene, tmp_path):
    """The cache key is the file relative to the cache (the same on every machine); a file outside
    the cache keeps its name only; the key leads back to the file under whatever cache is in use."""
    d = tmp_path / "models"
    _, path, _ = cache.cached_build(scene, directory=str(d))
    key = cache.cache_key(path, directory=str(d))
    assert key == f"{build_key(scene, BuildSettings())}.npz" and not os.path.isabs(key)
    assert cache.model_file(key, directory=str(d)) == path
    assert cache.model_file(key, directory=str(tmp_path / "other")) == str(tmp_path / "other" / key)
    assert cache.cache_key(str(tmp_path / "out" / "allen.npz"), directory=str(d)) == "allen.npz"
    assert cache.cache_key(str(d) + "-sibling/x.npz", directory=str(d)) == "x.npz"
