"""Scene: validation, serialisation, stable content hash, CLI-style construction."""
from __future__ import annotations

import json

import numpy as np
import pytest

from transition_builder.friction import parse_friction
from transition_builder.scene import ACTIONS, Scene, scene_from_options
from transition_builder.sim_settings import LEGACY_CHOICES, SETTING_CHOICES, SimSettings


def test_defaults():
    sc = scene_from_options("allen-key")
    assert (sc.tray_x_mm, sc.tray_y_mm, sc.tilt_deg) == (200.0, 200.0, 30.0)
    assert sc.actions == ACTIONS
    assert sc.base_mu < np.tan(np.radians(30.0))
    assert sc.downhill_angle("E") == 0.0 and np.isclose(sc.downhill_angle("N"), np.pi / 2)


def test_round_trip_json_and_toml(tmp_path):
    sc = scene_from_options("triangle:3", "map:low:2", tilt_deg=25.0, actions="S,N,E", solver_iterations=60)
    p = tmp_path / "scene.json"
    sc.save(p)
    back = Scene.load(p)
    assert back == sc and back.content_hash() == sc.content_hash()
    t = tmp_path / "scene.toml"
    t.write_text('shape = "rectangle:40x20"\nfriction = "0.25"\ntilt_deg = 20\n'
                 'actions = ["E", "W"]\n[settings]\nsolver_iterations = 50\n')
    sc2 = Scene.load(t)
    assert sc2.actions == ("E", "W") and sc2.settings.solver_iterations == 50
    assert str(sc2.friction) == "0.25" and sc2.tilt_deg == 20.0


def test_hash_is_stable_and_sensitive():
    a = scene_from_options("allen-key")
    assert a.content_hash() == scene_from_options("allen-key").content_hash()
    variants = [scene_from_options("allen-key", 0.31), scene_from_options("allen-key", tilt_deg=31),
                scene_from_options("allen-key", actions="N,E"), scene_from_options("allen-key", time_step_s=1 / 250),
                scene_from_options("allen-key", solver_iterations=99), scene_from_options("allen-key:arm=7"),
                scene_from_options("allen-key", "map:low:1"), scene_from_options("allen-key", "map:low:2"),
                scene_from_options("allen-key", tray_mm=(200, 210))]
    hashes = {v.content_hash() for v in variants} | {a.content_hash()}
    assert len(hashes) == len(variants) + 1
    # every settings field is hashed
    for name, val in SimSettings().to_dict().items():
        if name in LEGACY_CHOICES:
            new = next(c for c in SETTING_CHOICES[name] if c != val)   # another of its names
        elif isinstance(val, str):
            new = "sphere" if val != "sphere" else "legs:4"      # the contact model
        else:
            new = val * 1.5 if isinstance(val, float) else val * 2     # x2 keeps substeps divisible
        if name == "contact_threshold_mm":
            new = val * 1.1                      # must stay below the floor clearance
        changed = scene_from_options("allen-key", **{name: new})
        assert changed.content_hash() != a.content_hash(), name


def test_hash_is_canonical_json():
    d = scene_from_options("allen-key").to_dict()
    json.dumps(d, allow_nan=False)
    assert d["shape"]["vertices"] and d["settings"]["solver_iterations"] >= 1


@pytest.mark.parametrize("kwargs, match", [
    (dict(friction_spec="abc"), "friction"),
    (dict(friction_spec="map:extreme:1"), "level"),
    (dict(friction_spec="map:low"), "map:LEVEL:SEED"),
    (dict(friction_spec="map:low:x"), "seed"),
    (dict(friction_spec=-0.2), "friction"),
    (dict(friction_spec="nan"), "friction"),
    (dict(tilt_deg=95), "tilt"),
    (dict(tilt_deg=0), "tilt"),
    (dict(actions="N,UP"), "unknown action"),
    (dict(actions=""), "empty"),
    (dict(actions="N,N"), "repeated"),
    (dict(tray_mm=(50, 50)), "does not fit"),
    (dict(solver_iterations=0), "solver_iterations"),
    (dict(time_step_s=-1.0), "time_step_s"),
    (dict(no_such_setting=1), "setting"),
])
def test_bad_input_is_one_line_value_error(kwargs, match):
    with pytest.raises(ValueError, match=match) as exc:
        scene_from_options("allen-key", **kwargs)
    assert "\n" not in str(exc.value)


def test_bad_scene_files(tmp_path):
    p = tmp_path / "bad.json"
    p.write_text("{not json")
    with pytest.raises(ValueError, match="cannot parse"):
        Scene.load(p)
    p.write_text('{"shape": "allen-key", "colour": "red"}')
    with pytest.raises(ValueError, match="unknown scene key"):
        Scene.load(p)
    p.write_text('{"tray_x_mm": 100}')
    with pytest.raises(ValueError, match="shape"):
        Scene.load(p)


def test_action_index():
    sc = scene_from_options("allen-key", actions=["W", "E"])
    assert sc.actions == ("E", "W")
    assert sc.action_index("w") == 1 and sc.action_index(0) == 0
    with pytest.raises(ValueError):
        sc.action_index(2)
    assert parse_friction("map:HIGH:7").level == "high"


def test_contact_model_parsed_recorded_and_old_scene_files_read():
    """``contact`` has one canonical spelling, is refused in one line when unknown, and a scene file
    written before simulator version 4 (``support_points``) reads as the contact it meant."""
    from transition_builder.sim_settings import parse_contact

    assert SimSettings().contact == "coulomb"
    assert SimSettings(contact=" LEGS:9 ").contact == "legs:9"
    assert parse_contact("legs:4").support_points == 4 and parse_contact("sphere").support_points == 1
    for bad in ("legs:1", "legs:65", "legs:x", "ball", "", 3):
        with pytest.raises(ValueError, match="unknown contact model"):
            SimSettings(contact=bad)
    old = SimSettings().to_dict()
    del old["contact"]
    assert SimSettings.from_dict({**old, "support_points": 1}).contact == "sphere"
    assert SimSettings.from_dict({**old, "support_points": 4}).contact == "legs:4"
    d = scene_from_options("allen-key", contact="legs:4").to_dict()
    assert d["settings"]["contact"] == "legs:4"


@pytest.mark.parametrize("refine", [1, 2, 4, 8])
def test_finer_step_divides_the_step_and_keeps_the_rest_test_interval(refine):
    base = SimSettings()
    fine = SimSettings(**{**base.to_dict(), **base.finer_step(refine)})
    assert fine.time_step_s * refine == pytest.approx(base.time_step_s, rel=1e-15)
    assert fine.substeps == base.substeps * refine
    assert fine.check_interval_s == pytest.approx(base.check_interval_s, rel=1e-15)


@pytest.mark.parametrize("refine", [0, -2, 2.0, True, "2"])
def test_finer_step_refuses_what_is_not_a_positive_integer(refine):
    with pytest.raises(ValueError, match="refine must be a positive integer"):
        SimSettings().finer_step(refine)
