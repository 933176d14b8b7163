"""The planar engine's contract: the simulator interface, keys and caches, old files, chunking, bad input."""
from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from transition_builder import status as st
from transition_builder.planar import PlanarSimulator
from transition_builder.sampling import sample_start_poses
from transition_builder.scene import Scene, scene_from_options
from transition_builder.sim_settings import SimSettings
from transition_builder.simulators import make_simulator


@pytest.fixture(scope="module")
def key():
    return scene_from_options("allen-key", engine="planar")


def test_make_simulator_follows_the_setting(key):
    assert isinstance(make_simulator(key), PlanarSimulator)
    assert type(make_simulator(key.with_settings(engine="pybullet"))).__name__ == "TraySimulator"


def test_engines_have_different_keys_and_pybullet_keys_are_unchanged(key):
    """A model is never served from the cache for the other engine: the content hash differs. A
    PyBullet scene's dict has no engine entry, so every key from before the planar engine stands."""
    pb = key.with_settings(engine="pybullet")
    assert key.content_hash() != pb.content_hash()
    assert "engine" not in pb.to_dict()["settings"]
    assert key.to_dict()["settings"]["engine"] == "planar"


def test_old_saved_settings_and_scene_files_read_as_pybullet(tmp_path, key):
    """A saved settings dict without ``engine`` (every model and scene file before it) is PyBullet."""
    old = key.with_settings(engine="pybullet").to_dict()
    assert "engine" not in old["settings"]
    path = tmp_path / "old.json"
    path.write_text(json.dumps(old))
    assert Scene.load(str(path)).settings.engine == "pybullet"
    assert SimSettings.from_dict(old["settings"]).engine == "pybullet"
    # a scene file may name the engine in its settings
    path.write_text(json.dumps({"shape": "allen-key", "settings": {"engine": "planar"}}))
    assert Scene.load(str(path)).settings.engine == "planar"


def test_pybullet_only_settings_do_not_split_planar_keys():
    """Settings the planar engine does not have change nothing, so they do not split its keys; they are
    kept, so switching a planar scene back to PyBullet gives PyBullet's own defaults."""
    a = SimSettings(engine="planar")
    b = SimSettings(engine="planar", part_links="per-part", contact_pairs="all", long_steps="free")
    assert a.to_dict() == b.to_dict()
    assert dataclasses.replace(a, engine="pybullet") == SimSettings(engine="pybullet")
    saved = SimSettings.from_dict(a.to_dict())
    assert saved.to_dict() == a.to_dict()
    assert dataclasses.replace(saved, engine="pybullet") == SimSettings(engine="pybullet")


@pytest.mark.parametrize("bad", ["bullet", "", "PLANAR2", 3])
def test_unknown_engine_is_one_line_error(bad):
    with pytest.raises(ValueError, match="unknown engine"):
        SimSettings(engine=bad)


def test_planar_has_the_coulomb_contact_only():
    with pytest.raises(ValueError, match="coulomb contact only"):
        SimSettings(engine="planar", contact="sphere")


def test_landings_do_not_depend_on_chunking(key):
    """Same starts, same landings, bit for bit, whether tilted at once or in chunks of any size."""
    sim = PlanarSimulator(key)
    starts = sample_start_poses(key.shape, 200.0, 200.0, 40, np.random.default_rng(3))
    whole, s_whole = sim.tilt(starts, "NE")
    parts = [sim.tilt(starts[i:i + 7], "NE") for i in range(0, 40, 7)]
    assert np.array_equal(whole, np.concatenate([p[0] for p in parts]), equal_nan=True)
    assert np.array_equal(s_whole, np.concatenate([p[1] for p in parts]))
    again, _ = PlanarSimulator(key).tilt(starts, "NE")
    assert np.array_equal(whole, again, equal_nan=True)


def test_faults_are_counted_never_poses(key):
    """A start outside the tray or not finite is INVALID (NaN pose); landings lie inside the tray."""
    sim = PlanarSimulator(key)
    rest, status = sim.tilt([[-50.0, 100.0, 0.0], [np.nan, 1.0, 0.0], [100.0, 100.0, 0.3]], "SW")
    assert status.tolist() == [st.INVALID, st.INVALID, st.OK]
    assert np.all(np.isnan(rest[:2])) and np.all(np.isfinite(rest[2]))
    assert 0.0 <= rest[2, 2] < 2 * math.pi
    v = key.shape.placed(rest[2])
    assert v.min() > -key.settings.escape_tolerance_mm and v.max() < 200.0 + key.settings.escape_tolerance_mm


def test_a_part_that_cannot_settle_is_unsettled():
    """The time limit holds: on a frictionless floor a part never comes to rest within 0.1 s."""
    sc = scene_from_options("rectangle:40x20", 0.0, engine="planar", max_time_s=0.1)
    rest, status = PlanarSimulator(sc).tilt([[100.0, 100.0, 0.0]], "N")
    assert status[0] == st.UNSETTLED and np.all(np.isnan(rest[0]))


def test_tilt_time_ramps_the_slope(key):
    """A slow tilt starts later: after 0.2 s of a 1 s ramp the part has moved far less than on an instant tilt."""
    slow = PlanarSimulator(dataclasses.replace(key, tilt_time_s=1.0))
    fast = PlanarSimulator(key)
    _, a, _ = fast.trajectory([100.0, 100.0, 0.0], "E", 0.2)
    _, b, _ = slow.trajectory([100.0, 100.0, 0.0], "E", 0.2)
    assert a[-1, 0] - 100.0 > 20.0 and b[-1, 0] - 100.0 < 2.0


@pytest.mark.parametrize("argv, needle", [(["--engine", "bullet"], "--engine"),
                                          (["--engine", "planar", "--contact", "sphere"], "coulomb contact only")])
def test_cli_refuses_a_bad_engine_in_one_line(argv, needle):
    cmd = [sys.executable, "-m", "analysis", "simulate", "--shape", "allen-key", "--sequence", "E",
           "--trials", "2", *argv]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], out.stderr
