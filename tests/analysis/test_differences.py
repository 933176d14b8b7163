"""The differences section (analysis/experiments/differences.py): each paper row's verdict follows
from the numbers it cites, and the section renders from a saved report alone."""
from __future__ import annotations

import dataclasses
import importlib.util
import json

import pytest

import tests
from analysis.experiments.differences import best_physics, differences, from_saved, markdown
from analysis.reproduce import ReproduceSettings
from kruskal_markov.answers import wilson_interval


def _saved(a_share=0.53, by8=16, b_direct=9, low_levels=13):
    n = 51
    ens = {"converged": int(a_share * 1_000_000), "of": 1_000_000, "mean": [5.0] + [0.9] * (n - 1),
           "converged_by_tilt": [0] * 8 + [by8] + [100] * (n - 9), "fastest": 7}
    a = {"converged": 24, "of": 43, "settled": {"converged": 20}, "mean": [5.0] * n, "fastest": 18}
    parts = {f"triangle:{i}": {} for i in range(1, 16)}
    b = {"parts": parts, "converged": 9, "converged_direct": b_direct, "mean": [4.0] + [0.3] * (n - 1),
         "mean_near_zero_by": None}
    c = {"levels": {"low": {"maps": 13, "converged": low_levels}, "medium": {"maps": 3, "converged": 3},
                    "high": {"maps": 4, "converged": 4}}}
    return {"A": a, "ensemble": ens, "B": b, "C": c,
            "key_metrics": {"sync_length": 8, "sync_exact": True},
            "plans": {"cell": {"plan": {"length": 7}}}}


def _study():
    def group(ends, maps, lo, hi):
        return {"maps": maps, "ends_zero": ends, "reaches_zero": ends, "mean_coefficients": [lo, hi]}
    search = {"today": {"friction": "0.3", "tilt_time_s": 0.0, "share_reaching_zero": 0.67, "mean_entropy_20": 0.96,
                        "entropy_0": 5.0, "D": 0.2},
              "pair": {"friction": "0.5/0.3", "tilt_time_s": 0.0, "share_reaching_zero": 0.0, "mean_entropy_20": 1.2,
                       "entropy_0": 5.0, "D": 0.9}}
    b_search = {"pair": {"reaches_zero": 10, "measured": 15, "B_distance": 0.0}}
    return {"c_groups": {"mean": {"low": group(13, 13, 0.22, 0.35), "medium": group(0, 3, 0.38, 0.44),
                                  "high": group(1, 4, 0.46, 0.49)},
                         "amplitude": {"low": group(4, 4, 0.3, 0.3)}},
            "search": search, "b_search": b_search, "physics": {"engine": "planar"}}


def _point(points, topic):
    return next(p for p in points if p.topic.startswith(topic))


def test_a_share_is_judged_by_the_papers_own_binomial_interval():
    lo, hi = wilson_interval(29, 43)
    inside = _point(differences(_saved(a_share=(lo + hi) / 2)), "A: random sequences")
    outside = _point(differences(_saved(a_share=lo - 0.02)), "A: random sequences")
    assert inside.verdict == "within sampling noise" and outside.verdict == "not explained"
    assert "29 of 43 (67%, 95% interval 53-80%)" == inside.paper


def test_the_fast_best_sequence_is_a_rare_draw_or_not_by_the_ensembles_share():
    rare = _point(differences(_saved(by8=16)), "A: the best")            # p = 1.6e-5: 0.07% in 43 draws
    common = _point(differences(_saved(by8=5_000)), "A: the best")       # p = 0.5%: 19% in 43 draws
    assert rare.verdict.startswith("not explained") and "0.1%" in rare.why
    assert common.verdict == "within sampling noise" and f"{100 * (1 - (1 - 0.005) ** 43):.1f}%" in common.why


def test_c_points_follow_the_maps_grouped_by_mean():
    pts = differences(_saved(), _study())
    low, medium, high = (_point(pts, f"C: {lv}") for lv in ("low", "medium", "high"))
    assert medium.verdict == "explained" and "0 of 3" in medium.why
    assert high.verdict == "explained" and "1 of 4" in high.why           # within one map of the paper's 0
    assert low.verdict == "partly explained" and "3 failures" in low.why  # 13 of 13 against the paper's 10
    without = _point(differences(_saved(), None), "C: high")
    assert without.verdict == "not explained" and "not run" in without.why


def test_best_physics_ranks_by_the_combined_criterion_where_b_was_searched():
    rows = best_physics(_study())
    assert [r["label"] for r in rows] == ["pair", "today"]               # D_AB 0.9 beats a missing B
    assert rows[0]["D_AB"] == pytest.approx(0.9) and rows[1]["D_AB"] is None
    assert best_physics(None) == ()


def test_markdown_says_when_the_study_is_missing():
    r = from_saved(_saved(), "/nonexistent")
    text = markdown(r)
    assert text.startswith("## How the differences arise") and "friction study was not run" in text
    assert r.to_dict()["differences"]["friction_study"] is None
    assert markdown(dataclasses.replace(r, points=())) == ""


def test_rerun_section_renders_differences_from_a_saved_report(tmp_path):
    spec = importlib.util.spec_from_file_location("rerun_section", str(tests.ROOT / "tools" / "rerun_section.py"))
    rerun = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(rerun)
    saved = dict(_saved(), settings=json.loads(json.dumps(dataclasses.asdict(ReproduceSettings.full()))),
                 engine="planar")
    (tmp_path / "results.json").write_text(json.dumps(saved))
    (tmp_path / "index.md").write_text("# R\n\n## How the differences arise\n\nstale text\n\n## Z\n\nz\n")
    (tmp_path / "friction_study").mkdir()
    (tmp_path / "friction_study" / "friction_study.json").write_text(json.dumps(_study()))
    assert rerun.main(["--out", str(tmp_path), "--section", "differences", "--from-saved"]) == 0
    index = (tmp_path / "index.md").read_text()
    assert "stale text" not in index and "| C: medium-noise maps converging | 0 of 3 |" in index and index.endswith("z\n")
    got = json.loads((tmp_path / "results.json").read_text())["differences"]
    assert got["friction_study"].endswith("friction_study.json") and got["physics"][0]["label"] == "pair"
    assert rerun.main(["--out", str(tmp_path), "--section", "A", "--from-saved"]) == 2


def test_short_runs_and_a_mean_that_reaches_zero_are_read_as_they_are():
    """A quick report's 10-tilt sequences have no tilt 20: the point reads the last tilt; a mean that
    reaches zero by the paper's tilt is no gap."""
    s = _saved()
    s["ensemble"] = dict(s["ensemble"], mean=[5.0] + [0.5] * 10, converged_by_tilt=[0] * 11)
    s["B"] = dict(s["B"], mean=[4.0] + [0.3] * 10)
    pts = differences(s)
    mean_point = _point(pts, "A: mean entropy")
    assert mean_point.ours.startswith("0.50 bits at tilt 10; not near zero within 10")
    s["ensemble"] = dict(s["ensemble"], mean=[5.0] + [0.05] * 50, mean_near_zero_by=12)
    assert _point(differences(s), "A: mean entropy").verdict == "no gap"


def test_a_study_of_another_physics_is_not_cited(tmp_path):
    """The differences section cites a friction study only when it ran in the report's own engine: a
    study of the other engine, or one that recorded no physics, leaves its explanations out."""
    (tmp_path / "friction_study").mkdir()
    for physics in ({"engine": "pybullet"}, None):
        study = dict(_study(), physics=physics) if physics else {k: v for k, v in _study().items() if k != "physics"}
        (tmp_path / "friction_study" / "friction_study.json").write_text(json.dumps(study))
        r = from_saved(dict(_saved(), engine="planar"), str(tmp_path))
        assert r.study_source is None and "growing the amplitude" not in markdown(r)
    (tmp_path / "friction_study" / "friction_study.json").write_text(json.dumps(_study()))
    r = from_saved(dict(_saved(), engine="planar"), str(tmp_path))
    assert r.study_source.endswith("friction_study.json") and "growing the amplitude leaves 4 of 4" in markdown(r)
