"""The friction study (analysis/friction_study.py): the paper's grouping by mean, the criterion,
and the section it writes (no simulation here: fabricated per-map results)."""
from __future__ import annotations

import pytest

from analysis.friction_study import (
    PAPER,
    FrictionStudyResult,
    FrictionStudySettings,
    criterion,
    mean_maps,
)
from analysis.reproduce import ReproduceSettings
from transition_builder.friction import parse_friction


def test_mean_maps_are_seeded_valid_specs_with_their_means():
    s = FrictionStudySettings()
    maps = mean_maps(s)
    assert maps == mean_maps(s) and len(maps) == 20
    for spec, m in maps:
        f = parse_friction(spec)
        assert f.kind == "map" and f.mu == pytest.approx(m) and s.mean_range[0] <= m <= s.mean_range[1]
    assert maps != mean_maps(FrictionStudySettings(mean_seed=1))


def test_criterion_is_zero_at_the_paper_and_grows_away_from_it():
    share = PAPER["A_converged"] / PAPER["A_sequences"]
    assert criterion(share, 0.0, 4.9) == 0.0
    assert criterion(share + 0.1, 0.0, 4.9) == pytest.approx(0.1)
    assert criterion(share, 0.49, 4.9) == pytest.approx(0.1)


def _map(mean, group, ends):
    h = [4.9] + [0.0 if ends else 1.0] * 50
    return {"mean": mean, "group": group, "ends_zero": ends, "reaches_zero": ends, "entropy_bits": h}


def test_markdown_groups_maps_by_mean_as_the_paper_did(tmp_path):
    c_mean = {f"map:low:{k}:{m}": _map(m, g, e) for k, (m, g, e) in enumerate(
        [(0.25, "low", True), (0.3, "low", False), (0.45, "medium", False), (0.49, "high", False)])}
    search = {"today": {"friction": "0.3", "tilt_time_s": 0.0, "share_reaching_zero": 0.5, "mean_entropy_20": 1.0,
                        "mean_entropy_50": 0.5, "D": 0.4}}
    res = FrictionStudyResult(settings=dict(trials=200, seed=0, search_sequences=8, search_trials=100),
                              c_mean=c_mean, search=search)
    text = res.markdown()
    assert "| 1 of 2 (reached 1); mean mu 0.25-0.30 | 0 of 1 (reached 0); mean mu 0.45-0.45 |" in text
    assert "| today | `0.3` | 0 | 0.50 | 1.00 | 0.50 | 0.40 |" in text
    d = res.to_dict()
    assert d["c_groups"]["mean"]["low"]["ends_zero"] == 1 and d["paper"]["C"]["medium"] == (0, 3)
    assert res.figures(str(tmp_path)) == [str(tmp_path / "fig_friction_c.png")]


def test_sensitivity_physics_variants():
    """The sensitivity study's static/kinetic and tilt-time variants: the key's scene with the pair
    or tilt time set, the key's own friction when the spec is None, pairs skipped off coulomb."""
    from analysis.experiments.sensitivity import Settings, _physics_variants
    from analysis.reproduce import SENSITIVITY_PHYSICS, ReproduceSettings
    from transition_builder.scene import scene_from_options

    st = Settings.from_settings(ReproduceSettings(sensitivity_physics=SENSITIVITY_PHYSICS))
    key = scene_from_options("allen-key", 0.25)
    got = {label: sc for label, sc, _ in _physics_variants(key, st)}
    assert str(got["friction 0.5/0.3 (Simscape's defaults)"].friction) == "0.5/0.3"
    assert got["tilt time 0.5 s"].tilt_time_s == 0.5 and str(got["tilt time 0.5 s"].friction) == "0.25"
    assert got["0.5/0.3, tilt time 0.5 s"].content_hash() != key.content_hash()
    sphere = {label for label, _, _ in _physics_variants(scene_from_options("allen-key", contact="sphere"), st)}
    assert sphere == {"tilt time 0.5 s"}
    assert Settings.from_settings(ReproduceSettings()).physics == ()


def test_friction_section_is_off_by_default():
    from analysis.experiments import EXPERIMENTS
    from analysis.experiments.context import Context
    from analysis.experiments.friction import markdown, run

    assert EXPERIMENTS["friction"] == "analysis.experiments.friction"
    r = run(Context(ReproduceSettings()))
    assert r.to_dict() == {} and markdown(r) == ""


def test_a_resumed_c_reading_equals_an_uninterrupted_one():
    """The study's readings are long; an interrupted one resumes from its saved maps and gives the
    same per-map results as a run that never stopped (each map is seeded on its own)."""
    from analysis.friction_study import c_reading

    s = FrictionStudySettings(mean_maps=2, trials=3, sequence="E,S", workers=1)
    whole = c_reading(s, "mean", progress=lambda line: None)
    first = next(iter(whole))
    told = []
    resumed = c_reading(s, "mean", progress=told.append, done={first: whole[first]})
    assert resumed == whole
    assert len(told) == 1 and first not in told[0]
    stale = dict(whole[first], trials=2)
    told.clear()
    c_reading(s, "mean", progress=told.append, done={first: stale})
    assert len(told) == 2


def test_b_criterion_is_zero_at_the_paper_and_counts_parts():
    from analysis.friction_study import b_criterion

    assert b_criterion(10, 15) == 0.0
    assert b_criterion(9, 15) == pytest.approx(1 / 15)
    assert b_criterion(15, 15) == pytest.approx(5 / 15)


def test_a_resumed_b_search_equals_an_uninterrupted_one():
    """The B search replays one sequence on every part under every candidate; an interrupted run
    resumes at the first part not saved, and a part saved with other trials is run again."""
    from analysis.friction_study import b_search

    s = FrictionStudySettings(b_parts=("triangle:1", "triangle:2"), b_trials=3, b_sequence="E,S", workers=1,
                              candidates=(("today", "0.3", 0.0),))
    saved = []
    whole = b_search(s, progress=lambda line: None, on_item=lambda out: saved.append(
        {k: dict(v, parts=dict(v["parts"])) for k, v in out.items()}))
    r = whole["today"]
    assert r["measured"] == r["planned"] == 2 and set(r["parts"]) == {"triangle:1", "triangle:2"}
    assert r["reaches_zero"] == sum(p["reaches_zero"] for p in r["parts"].values())
    assert all(len(p["entropy_bits"]) == 3 and p["trials"] == 3 for p in r["parts"].values())
    told = []
    resumed = b_search(s, progress=told.append, done=saved[0])
    assert resumed == whole and len(told) == 1 and "triangle:2" in told[0]
    stale = {"today": dict(saved[0]["today"], parts={"triangle:1": dict(r["parts"]["triangle:1"], trials=2)})}
    told.clear()
    b_search(s, progress=told.append, done=stale)
    assert len(told) == 2


def test_markdown_b_table_joins_the_a_criterion():
    b = {"today": {"friction": "0.3", "tilt_time_s": 0.0, "parts": {}, "measured": 15, "planned": 15,
                   "reaches_zero": 9, "ends_zero": 8, "mean_entropy_50": 0.4, "faults": 0,
                   "B_distance": 1 / 15},
         "pair": {"friction": "0.5/0.3", "tilt_time_s": 0.0, "parts": {}, "measured": 7, "planned": 15,
                  "reaches_zero": 0, "ends_zero": 0, "mean_entropy_50": 2.0, "faults": 1, "B_distance": 10 / 15}}
    search = {"today": {"friction": "0.3", "tilt_time_s": 0.0, "share_reaching_zero": 0.5, "mean_entropy_20": 1.0,
                        "mean_entropy_50": 0.5, "D": 0.2}}
    res = FrictionStudyResult(settings=dict(trials=200, seed=0, search_sequences=6, search_trials=100, b_trials=100),
                              search=search, b_search=b)
    text = res.markdown()
    assert "| today | `0.3` | 0 | 9 of 15 | 8 | 0.40 | 0 | 0.07 | 0.20 | 0.27 |" in text
    assert "| pair | `0.5/0.3` | 0 | 0 of 7 (measured 7 of 15) | 0 | 2.00 | 1 | 0.67 | - | - |" in text
    assert text.index("| today | `0.3` | 0 | 9") < text.index("| pair |")


def test_b_search_runs_the_candidates_closest_to_a_first():
    from analysis.friction_study import b_search

    s = FrictionStudySettings(b_parts=("triangle:1",), b_trials=2, b_sequence="E", workers=1,
                              candidates=(("far", "0.5", 0.0), ("near", "0.3", 0.0), ("unsearched", "0.2", 0.0)))
    told = []
    b_search(s, progress=told.append, a_search={"far": {"D": 0.9}, "near": {"D": 0.1}})
    assert [t.split(" (")[0] for t in told] == ["B search: near", "B search: far", "B search: unsearched"]


def test_b_search_runs_tilt_time_candidates_last():
    from analysis.friction_study import b_search

    s = FrictionStudySettings(b_parts=("triangle:1",), b_trials=2, b_sequence="E", workers=1,
                              candidates=(("ramp", "0.3", 0.5), ("far", "0.5", 0.0)))
    told = []
    b_search(s, progress=told.append, a_search={"ramp": {"D": 0.1}, "far": {"D": 0.9}})
    assert [t.split(" (")[0] for t in told] == ["B search: far", "B search: ramp"]
