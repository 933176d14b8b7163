"""Static and kinetic friction (``MU_S/MU_K``) and the tilt time: parsing, scene keys, the one-number
guarantee (bit-identical landings and unchanged cache keys against the code before the pair existed),
and bad input on the command line."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import tests
from transition_builder.friction import friction_map, parse_friction
from transition_builder.scene import Scene, scene_from_options
from transition_builder.sim_settings import LEGACY_CHOICES

GOLDEN = str(tests.DATA / "single_coefficient_golden.json")
#: the physics settings of the code that wrote the golden file (the defaults up to the sixth session)
_LEGACY = LEGACY_CHOICES


def _golden():
    with open(GOLDEN) as f:
        return json.load(f)


# ---------------------------------------------------------------- parsing
@pytest.mark.parametrize("text, mu_k, mu_s", [("0.5/0.3", 0.3, 0.5), ("0.61/0.47", 0.47, 0.61),
                                              (" 0.4 / 0.2 ", 0.2, 0.4)])
def test_pair_parses_to_kinetic_and_static(text, mu_k, mu_s):
    spec = parse_friction(text)
    assert (spec.kind, spec.mu, spec.static_mu, spec.is_pair) == ("uniform", mu_k, mu_s, True)
    assert parse_friction(str(spec)) == spec


def test_equal_pair_is_the_single_number():
    assert parse_friction("0.3/0.3") == parse_friction("0.3") == parse_friction(0.3)
    assert parse_friction("0.3").static_ratio == 1.0 and not parse_friction("0.3").is_pair


@pytest.mark.parametrize("bad", ["0.3/0.5", "-0.1/-0.2", "0.5/-0.3", "a/b", "0.5/", "/0.3", "0.5/0.3/0.1",
                                 "0.5/0", "nan/0.3", "map:low:1:0.2/0.3"])
def test_bad_pairs(bad):
    with pytest.raises(ValueError) as exc:
        parse_friction(bad)
    assert "\n" not in str(exc.value)


def test_map_scales_both_coefficients():
    spec = parse_friction("map:medium:2:0.5/0.4")
    assert (spec.mu, spec.static_mu) == (0.4, 0.5)
    mu, _ = friction_map(spec, 200, 200)
    assert mu.mean() == pytest.approx(0.4, abs=1e-12)
    assert spec.static_ratio == pytest.approx(1.25)
    # a map naming a single mean is the same scene as the scene file's base_mu
    a = scene_from_options("allen-key", "map:low:1:0.4")
    b = Scene.from_dict({"shape": "allen-key", "friction": "map:low:1", "base_mu": 0.4})
    assert a.content_hash() == b.content_hash()


# ---------------------------------------------------------------- scenes and keys
def test_cache_keys_of_single_coefficients_unchanged():
    """The golden keys were written before the lighter physics became the default (seventh session):
    with the three settings at their legacy values, every scene keeps its key; at today's defaults
    every coulomb scene gets a new one."""
    for entry in _golden()["keys"]:
        if "options" in entry:
            sc = scene_from_options(**entry["options"])
        else:
            sc = Scene.from_dict(entry["scene_dict"])
        old = sc.with_settings(**_LEGACY)
        assert old.content_hash() == entry["hash"], entry
        if sc.settings.contact == "coulomb":
            assert sc.content_hash() != entry["hash"], entry


def test_pair_and_tilt_time_change_the_key():
    base = scene_from_options("allen-key", 0.3)
    keys = {base.content_hash(), scene_from_options("allen-key", "0.5/0.3").content_hash(),
            scene_from_options("allen-key", "0.4/0.3").content_hash(),
            scene_from_options("allen-key", "map:low:1:0.5/0.3").content_hash(),
            scene_from_options("allen-key", "map:low:1").content_hash(),
            scene_from_options("allen-key", 0.3, tilt_time_s=0.5).content_hash(),
            scene_from_options("allen-key", 0.3, tilt_time_s=1.0).content_hash()}
    assert len(keys) == 7
    assert scene_from_options("allen-key", 0.3, tilt_time_s=0.0).content_hash() == base.content_hash()


def test_scene_round_trip_and_old_files(tmp_path):
    sc = scene_from_options("allen-key", "map:high:3:0.61/0.47", tilt_time_s=0.75)
    path = tmp_path / "scene.json"
    sc.save(path)
    back = Scene.load(path)
    assert back == sc and back.content_hash() == sc.content_hash()
    assert back.tilt_time_s == 0.75 and back.friction.static_mu == 0.61
    # a scene file written before the pair and the tilt time existed
    old = tmp_path / "old.toml"
    old.write_text('shape = "allen-key"\nfriction = "0.35"\ntilt_deg = 25.0\n')
    o = Scene.load(old)
    assert o.tilt_time_s == 0.0 and not o.friction.is_pair and "tilt_time_s" not in o.to_dict()


@pytest.mark.parametrize("contact", ["sphere", "legs:4"])
def test_pair_needs_the_coulomb_contact(contact):
    with pytest.raises(ValueError, match="coulomb"):
        scene_from_options("allen-key", "0.5/0.3", contact=contact)
    scene_from_options("allen-key", "0.3/0.3", contact=contact)       # one number: fine


@pytest.mark.parametrize("bad", [-0.1, float("nan"), float("inf"), 61.0, "1", True])
def test_bad_tilt_time(bad):
    with pytest.raises(ValueError, match="tilt time"):
        scene_from_options("allen-key", 0.3, tilt_time_s=bad)


# ---------------------------------------------------------------- the one-number guarantee
def test_single_coefficient_landings_bit_identical_to_before():
    """Every recorded tilt (tests/data/make_single_coefficient_golden.py, run on main's code before
    the pair existed, under the physics settings of then) lands on exactly the same floats, through
    the ``MU/MU`` spelling as well."""
    from transition_builder.sim import TraySimulator

    rows = _golden()["landings"]
    for spelling in ("one", "pair"):
        for r in rows:
            fr = r["friction"]
            if spelling == "pair" and not fr.startswith("map"):
                fr = f"{fr}/{fr}"
            sc = scene_from_options(r["shape"], fr, contact=r["contact"], **_LEGACY)
            with TraySimulator(sc) as sim:
                rest, status = sim.tilt([r["start"]], r["action"])
            assert int(status[0]) == r["status"]
            assert [float(v) for v in rest[0]] == r["rest"], (spelling, r)


def test_tilt_time_zero_is_the_instant_tilt():
    from transition_builder.sim import TraySimulator

    r = _golden()["landings"][0]
    sc = scene_from_options(r["shape"], r["friction"], tilt_time_s=0.0, **_LEGACY)
    with TraySimulator(sc) as sim:
        rest, _ = sim.tilt([r["start"]], r["action"])
    assert [float(v) for v in rest[0]] == r["rest"]


def test_slow_tilt_changes_the_landing_but_stays_valid():
    """A ramped tilt is a different motion (the part starts to slide part-way up the ramp) and
    still lands against the downhill wall."""
    from transition_builder.sim import TraySimulator

    r = _golden()["landings"][0]
    sc = scene_from_options(r["shape"], "0.5/0.3", tilt_time_s=1.0)
    with TraySimulator(sc) as sim:
        rest, status = sim.tilt([r["start"]], r["action"])
    assert status[0] == 0
    assert not np.allclose(rest[0], r["rest"], atol=1e-6)
    assert rest[0][0] > 150.0             # at the east wall


# ---------------------------------------------------------------- command line
@pytest.mark.parametrize("argv", [["--friction", "0.3/0.5"], ["--friction", "-0.2"], ["--friction", "x/0.3"],
                                  ["--tilt-time", "-1"], ["--tilt-time", "abc"],
                                  ["--friction", "0.5/0.3", "--contact", "sphere"]])
def test_cli_bad_friction_or_tilt_time_exit_2(argv):
    proc = subprocess.run([sys.executable, "-m", "analysis", "simulate", "--sequence", "E", "--trials", "1",
                           *argv], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr


def test_cli_pair_and_tilt_time_run(capsys):
    from analysis.cli import main

    code = main(["simulate", "--sequence", "E", "--trials", "2", "--friction", "0.5/0.3", "--tilt-time", "0.5",
                 "--workers", "1", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["friction"] == "0.5/0.3" and out["tilt_time_s"] == 0.5


# ---------------------------------------------------------------- judges (analytic mechanics)
@pytest.mark.parametrize("pair", ["0.5/0.3", "0.61/0.47"])
def test_static_kinetic_judges_pass(pair):
    """Hold below the static angle, slide by the kinetic law, break away above the static angle,
    start on a ramping tray at atan(mu_s): every judge within its target."""
    from transition_builder.judges import PAIR_JUDGE_TARGETS, pair_judges

    table = pair_judges(pair, shapes=("allen-key",))["allen-key"]
    for judge, target in PAIR_JUDGE_TARGETS.items():
        assert table[judge] <= target, (pair, judge, table[judge])


def test_hold_judge_fails_without_static_friction():
    """The same slope with one coefficient (the kinetic one): the key slides away; the judge can fail."""
    from transition_builder.judges import engine_incline, pair_judge_slopes

    a_hold = pair_judge_slopes(0.5, 0.3)[0]
    run = engine_incline("allen-key", "0.3", a_hold, 1.0)
    assert run.distance[-1] > 50.0


def _ramp_onset_reference_deg(mu, tilt_deg, tilt_time_s, threshold_mm=0.05, g=9810.0):
    """Coulomb's law on a tray ramping linearly to ``tilt_deg`` in ``tilt_time_s``: the slope at which
    a block at rest has slid ``threshold_mm`` (it starts at atan(mu) and accelerates by
    g (sin a - mu cos a)), by integrating twice on a 1 microsecond grid."""
    t = np.arange(0.0, tilt_time_s, 1e-6)
    a = np.radians(tilt_deg) * t / tilt_time_s
    acc = np.where(np.tan(a) > mu, g * (np.sin(a) - mu * np.cos(a)), 0.0)
    dist = np.cumsum(np.cumsum(acc) * 1e-6) * 1e-6
    return float(np.degrees(a[np.argmax(dist > threshold_mm)]))


def test_one_coefficient_ramp_starts_at_its_friction_angle():
    """Detected at 0.05 mm, the onset lags atan(0.4) by 0.47 degrees by Coulomb's law itself; the
    engine must match that within one rest-test interval of the ramp (0.133 degrees)."""
    from transition_builder.judges import engine_incline, onset_slope_deg

    run = engine_incline("allen-key", "0.4", 32.0, 3.5, tilt_time_s=4.0, refine=4)
    reference = _ramp_onset_reference_deg(0.4, 32.0, 4.0)
    assert 0.4 < reference - np.degrees(np.arctan(0.4)) < 0.55
    interval_deg = 32.0 / 4.0 * float(run.t[1] - run.t[0])
    assert abs(onset_slope_deg(run) - reference) <= interval_deg


def test_free_slide_judge_holds_for_a_pair():
    """On a level floor a pair slides by its kinetic coefficient: the free-slide judge against the
    integration of Coulomb's law at mu_k (0.2 mm, 0.5 degrees) still passes."""
    from transition_builder.judges import TABLE_SLIDES, engine_free_slide, reference_free_slide

    _, pose, twist = TABLE_SLIDES[2]
    eng = engine_free_slide("allen-key", pose, twist, mu="0.5/0.3", refine=16)
    ref = reference_free_slide("allen-key", pose, twist, mu=0.3)
    assert np.hypot(*(eng.final[:2] - ref.final[:2])) <= 0.2
    assert abs(np.degrees(eng.final[2] - ref.final[2])) <= 0.5


def test_report_shows_the_pair_judges_and_marks_a_miss():
    from analysis.experiments.contact import judges_lines as _judges_lines
    from transition_builder.judges import JUDGE_TARGETS, PAIR_JUDGE_TARGETS

    row = {k: 0.0 for k in PAIR_JUDGE_TARGETS}
    lines = _judges_lines({"table": {"coulomb": {k: 0.0 for k in JUDGE_TARGETS}}, "targets": JUDGE_TARGETS,
                           "pairs": {"table": {"0.5/0.3": row, "0.61/0.47": dict(row, onset_deg=0.9)},
                                     "targets": PAIR_JUDGE_TARGETS}})
    text = "\n".join(lines)
    assert "`0.5/0.3` | `0.61/0.47`" in text and "**0.90**" in text and "| 0.50 | 0.00 |" in text


def test_build_keys_differ_for_pairs_and_tilt_times_and_match_for_one_number():
    """The model cache's key (scene hash and build settings): a pair or a tilt time never meets
    another scene's model; ``0.3/0.3`` and a zero tilt time meet today's."""
    from transition_builder.builder import BuildSettings
    from transition_builder.builder.build_settings import build_key

    b = BuildSettings()
    keys = [build_key(scene_from_options("allen-key", f, tilt_time_s=t), b)
            for f, t in (("0.3", 0.0), ("0.5/0.3", 0.0), ("0.5/0.3", 0.5), ("0.3", 0.5), ("0.4/0.3", 0.0))]
    assert len(set(keys)) == len(keys)
    assert build_key(scene_from_options("allen-key", "0.3/0.3", tilt_time_s=0.0), b) == keys[0]
