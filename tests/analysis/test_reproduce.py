"""`kruskal reproduce` and `kruskal rank`: the report and the ranking on small scenes.

The small scene (a 30 mm square in a 90 mm tray, friction 0.1) closes at about a thousand states
in seconds; the report's numbers are checked against the arrays they are computed from and against
direct simulation, never against stored values.
"""
from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import tests

ROOT = tests.ROOT
#: the key's model: snapped at 0.5 mm / 0.5 deg (``kruskal rank``'s default resolution), 400 start poses
SMALL = {"start_samples": 400, "tol_mm": 0.5, "tol_deg": 0.5}
#: the compared contact model (the sphere) and the other part's model: coarse, to keep the suite short
CONTACT = {"start_samples": 100, "tol_mm": 1.0, "tol_deg": 1.0}


@pytest.fixture(scope="module")
def cache_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("cache")
    old = os.environ.get("KRUSKAL_CACHE")
    os.environ["KRUSKAL_CACHE"] = str(d)
    yield d
    if old is None:
        os.environ.pop("KRUSKAL_CACHE", None)
    else:
        os.environ["KRUSKAL_CACHE"] = old


@pytest.fixture(scope="module")
def report(cache_dir, tmp_path_factory):
    from analysis.report import write_report
    from analysis.reproduce import ReproduceSettings, reproduce

    s = ReproduceSettings(quick=True, seed=0, shape="rectangle:30x30", tray_mm=(90.0, 90.0), friction=0.1,
                          length=12, a_sequences=6, ensemble_count=300, parts=("polygon:0,0;30,0;0,20",),
                          maps=("map:low:1",), key_build=SMALL, part_build=CONTACT, a_check_trials=30,
                          b_trials=20, c_trials=20, replay_trials=100, validate_sequences=1, validate_trials=30,
                          validate_length=5, metrics_count=100, metrics_runs=30, sync_time_budget=10,
                          part_sync_time_budget=10, sync_node_budget=100_000,
                          compare_contacts=(("sphere", {"contact": "sphere"}),), compare_refine=(), judges=False,
                          contact_ensemble_count=200,
                          contact_build=CONTACT, sensitivity_noise=(), sensitivity_mu=(0.2,),
                          sensitivity_check_mu=(0.1,), sensitivity_check_sequences=2, sensitivity_check_trials=10,
                          kits=True, kit_compartments=(("square", "rectangle:30x30", 90.0, 90.0),
                                                       ("bar", "rectangle:40x20", 80.0, 70.0)),
                          kit_build=CONTACT, kit_design_tray_mm=(90.0,), kit_design_tilt_deg=(30.0,),
                          kit_replay_trials=20, kit_node_budget=100_000)
    result = reproduce(s, workers=2)
    out = tmp_path_factory.mktemp("report")
    return result, write_report(result, str(out)), out


def test_report_files_and_numbers_agree(report):
    result, paths, out = report
    text = (out / "index.md").read_text()
    assert paths["report"] == str(out / "index.md")
    for f in paths["figures"]:
        assert pathlib.Path(f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert os.path.basename(f) in text          # every figure is shown in the report
    saved = json.loads((out / "results.json").read_text())
    a = saved["A"]
    h = np.asarray(a["entropy"])
    assert h.shape == (6, 13)
    # the converged count is what the per-sequence curves say
    assert a["converged"] == int(np.sum(h.min(axis=1) <= result["settings"]["epsilon"]))
    np.testing.assert_allclose(a["mean"], h.mean(axis=0))
    assert f"{a['converged']} reach it at some tilt (model)" in text
    # reached and stayed, recounted from the curves; the best sequence settles no later than any other
    eps = result["settings"]["epsilon"]
    stays = [max((t for t in range(13) if row[t] > eps), default=-1) + 1 for row in h]
    stays = [t if t <= 12 else -1 for t in stays]
    assert a["settled"]["converged"] == sum(t >= 0 for t in stays)
    if a["settled"]["converged"]:
        assert stays[a["best_index"]] == min(t for t in stays if t >= 0)
    assert ",".join(a["best_sequence"]) in text
    # the ensemble's converged-by-tilt curve ends at its converged count
    e = saved["ensemble"]
    assert e["converged_by_tilt"][-1] == e["converged"] <= e["count"] == 300


def test_recorded_log_round_trip(report):
    """The A check's trials, written as a --poses CSV and read back, give the simulation's entropy."""
    result, _, out = report
    bd = result["A"]["best_direct"]
    np.testing.assert_allclose(bd["entropy_bits_log"], bd["entropy_bits"], atol=1e-12)
    assert "A robot's log beside the model" in (out / "index.md").read_text()


def test_sync_word_replayed_in_direct_simulation(report):
    """The model's synchronizing word orients the part in the physics engine too."""
    result, _, _ = report
    km = result["key_metrics"]
    assert km["sync_word"] and km["sync_length"] == len(km["sync_word"])
    rep = result["sync_replay"]
    assert rep["model_entropy_bits"][-1] <= km["epsilon"]
    assert rep["trials"] == 100 and len(rep["entropy_bits"]) == km["sync_length"] + 1
    assert rep["entropy_bits"][-1] <= 0.1


def test_parts_and_maps_sections(report):
    result, _, out = report
    part = result["B"]["parts"]["polygon:0,0;30,0;0,20"]
    assert len(part["entropy_bits"]) == 13 and part["model"]["states"] > 0
    m = part["metrics"]
    assert 0.0 <= m["converging_share_50"] <= 1.0 and m["mean_entropy_50"] >= 0.0
    assert result["C"]["levels"]["low"]["maps"] == 1
    assert len(result["C"]["maps"]["map:low:1"]["entropy_bits"]) == 13
    assert "polygon:0,0;30,0;0,20" in (out / "index.md").read_text()


def test_the_report_names_models_by_cache_key_not_by_path(report, cache_dir):
    """``results.json`` names each model by its file in the model cache: no absolute path of the machine
    that wrote it, and the key finds the model's file in the cache."""
    from transition_builder.cache import model_file

    result, _, out = report
    text = (out / "results.json").read_text()
    assert str(cache_dir) not in text and str(out) not in text
    saved = json.loads(text)
    key = saved["key_model"]["cache_key"]
    assert not os.path.isabs(key) and key.endswith(".npz")
    assert pathlib.Path(model_file(key)).is_file()
    assert pathlib.Path(model_file(key)).parent == cache_dir


def test_contact_models_side_by_side(report):
    """The sphere's model is a different model of the same scene, with its own paper-level answers."""
    result, _, out = report
    cm = result["contact_models"]
    assert list(cm) == ["coulomb", "coulomb (compared resolution)", "sphere"]   # the default first
    assert cm["sphere"]["model"]["cache_key"] != result["key_model"]["cache_key"]
    assert cm["coulomb"]["a_converged"] == result["A"]["converged"]      # the same 43-sequence sample
    assert cm["sphere"]["model"]["settings"] == CONTACT and result["key_model"]["settings"] == SMALL
    for k in cm:
        assert 0.0 <= cm[k]["converging_share"] <= 1.0
    text = (out / "index.md").read_text()
    assert "Does the answer depend on the contact model and the time step?" in text
    assert "the compared models were built with" in text          # their settings differ from the key's


def test_rank_cli_uses_cached_models_and_puts_a_synchronizable_part_first(report, cache_dir, tmp_path):
    """A square is oriented by a short plan; a 20 x 30 rectangle never turns by 90 degrees in a
    square tray, so no word synchronizes it and it ranks last, decided by whether a word exists."""
    from transition_builder.scene import scene_from_options

    scene = tmp_path / "scene.json"
    scene_from_options("rectangle:30x30", friction_spec=0.1, tray_mm=(90.0, 90.0)).save(str(scene))
    res = subprocess.run([sys.executable, "-m", "analysis", "rank", "--shapes", "rectangle:30x30", "rectangle:20x30",
                          "--scene", str(scene), "--start-samples", "400", "--resolution", "0.5,0.5",
                          "--recenter-rounds", "3", "--count", "200", "--runs", "30", "--workers", "2", "--json",
                          "--markdown", str(tmp_path / "rank.md")],
                         capture_output=True, text=True, timeout=600, cwd=ROOT,
                         env=dict(os.environ, KRUSKAL_CACHE=str(cache_dir)))
    assert res.returncode == 0, res.stderr[-2000:]
    out = json.loads(res.stdout)
    rows = {r["shape"]: r for r in out["ranking"]}
    assert rows["rectangle:30x30"]["cached"] is True      # the report's key model, same settings
    assert out["order"] == ["rectangle:30x30", "rectangle:20x30"]
    assert rows["rectangle:20x30"]["sync_length"] is None
    assert rows["rectangle:30x30"]["decided_by"] == "synchronizable"
    assert rows["rectangle:30x30"]["sync_word"] == report[0]["key_metrics"]["sync_word"]
    table = (tmp_path / "rank.md").read_text()
    assert "| 1 | rectangle:30x30 |" in table and "| 2 | rectangle:20x30 |" in table
    assert "--resolution 0.5,0.5" in table and "--recenter-rounds 3" in table   # the command that made it
    # the 20 x 30 rectangle never converges: every random run censored, so a bound and no mean
    assert rows["rectangle:20x30"]["random_tilts"] is None and rows["rectangle:20x30"]["random_tilts_censored"] == 30
    assert "| >= 1000.0 (30) |" in table


@pytest.mark.parametrize("argv, needle", [
    (["reproduce", "--out", "/dev/null"], "not a directory"),
    (["reproduce", "--out", "x", "--workers", "0"], "workers"),
    (["rank", "--shapes", "nonsense"], "nonsense"),
    (["rank", "--shapes", "allen-key", "allen-key"], "twice"),
    (["rank", "--shapes", "allen-key", "--resolution", "x"], "resolution"),
])
def test_bad_input_is_one_line_exit_2(argv, needle):
    res = subprocess.run([sys.executable, "-m", "analysis", *argv], capture_output=True, text=True, timeout=120,
                         cwd=ROOT)
    assert res.returncode == 2, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and needle in lines[0]


def test_sensitivity_study_and_uncertainty_section(report):
    """The sensitivity study's table, conclusions and paper coefficient agree with its own rows."""
    result, paths, out = report
    sens = result["sensitivity"]
    assert list(sens["settings"]) == ["default", "half time step", "mu 0.2"]
    assert sorted(sens["friction_curve"], key=float) == ["0.1", "0.2"]
    for label, row in sens["settings"].items():
        for k in ("converging_share", "mean_entropy_10"):
            v = row[k]
            assert v["model_ci90"][0] <= v["value"] <= v["model_ci90"][1]
        assert 0 <= row["a_converged"] <= row["a_sequences"]
    for k, c in sens["conclusions"].items():
        if isinstance(c, dict):
            vals = [row[k]["value"] for row in sens["settings"].values()]
            assert c["min"] == min(vals) and c["max"] == max(vals) and c["default"] == sens["settings"]["default"][k]["value"]
    pm = sens["paper_mu"]
    by = {float(mu): n for mu, n in pm["a_converged_by_mu"].items()}
    assert abs(by[pm["closest_mu"]] - 29) == min(abs(n - 29) for n in by.values())
    ch = sens["friction_checks"]["0.1"]
    assert ch["direct"]["sequences"] == 2 and ch["direct"]["trials"] == 10
    assert 0 <= ch["direct"]["ended_at_zero"] <= 2
    text = (out / "index.md").read_text()
    assert "## How sure are these answers?" in text and "fig_friction.png" in text
    assert (out / "fig_friction.png").exists()
    iv = result["key_metrics"]["intervals"]
    assert iv["converging_share"]["mc_ci95"][0] <= iv["converging_share"]["value"] <= iv["converging_share"]["mc_ci95"][1]


def test_engines_side_by_side(report):
    """The engine section names the engine that answered, asks both engines' models the same questions,
    and its plan lengths are the shortest plans of the models it names (recomputed from the files)."""
    from kruskal_markov.model import TransitionModel
    from kruskal_markov.sync import shortest_plan
    from transition_builder.cache import model_file
    from transition_builder.sim_settings import SimSettings

    result, _, out = report
    eng = result["engines"]
    assert eng["default"] == SimSettings().engine == result["engine"]
    assert list(eng["answers"]) == [eng["default"], "pybullet" if eng["default"] == "planar" else "planar"]
    keys = [a["model"]["cache_key"] for a in eng["answers"].values()]
    assert keys[0] != keys[1]
    for name, a in eng["answers"].items():
        assert 0.0 <= a["converging_share"] <= 1.0
        model = TransitionModel.load(model_file(a["model"]["cache_key"]))
        assert model.metadata["scene"]["settings"].get("engine", "pybullet") == name
        cell = shortest_plan(model, "cell", node_budget=100_000)
        assert (cell.length, bool(cell.exact)) == (a["cell_plan"], a["cell_plan_exact"])
    text = (out / "index.md").read_text()
    assert f"ran in the `{eng['default']}` engine" in text


def test_kits_section_names_models_by_cache_key(report):
    """The kits section runs in a report: its common plan is no shorter than any compartment's own, and
    its models are named by their cache keys (which find the files), never by a machine's path."""
    from transition_builder.cache import model_file

    result, _, out = report
    kit = result["kits"]
    from kruskal_markov.model import TransitionModel
    for c in kit["compartments"]:
        assert os.path.basename(c["model"]) == c["model"] and os.path.exists(model_file(c["model"]))
        scene = TransitionModel.load(model_file(c["model"])).metadata["scene"]
        assert scene["settings"].get("engine", "pybullet") == result["engine"]          # the report's physics
    text = json.dumps(kit) + json.dumps(result["kit_design"])
    assert str(out) not in text and os.path.expanduser("~") not in text
