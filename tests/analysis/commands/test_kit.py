"""``--kit`` on plan, ensemble, convergence, simulate, and ``kruskal design``: a one-compartment kit
is the single part, two identical compartments have the single part's plan, a kit plan replayed
in direct simulation lands where the models say, design variants are cached and reproducible,
bad kits exit 2. Small scenes (a 30 mm square, coarse 2 mm models of 200 start samples: a few
seconds each, built once into a module cache)."""
from __future__ import annotations

import io
import json
import os
from contextlib import redirect_stdout

import pytest

from analysis.cli import main

pytest.importorskip("transition_builder.sim")

SQUARE = {"shape": "rectangle:30x30", "friction": 0.1}
#: the coarse models of every kit command here
COARSE = ["--resolution", "2,2", "--start-samples", "200", "--workers", "1"]


@pytest.fixture(scope="module")
def kits(tmp_path_factory):
    """Kit files in a directory, and a model cache of the module's own."""
    d = tmp_path_factory.mktemp("kits")
    old = os.environ.get("KRUSKAL_CACHE")
    os.environ["KRUSKAL_CACHE"] = str(d / "cache")
    files = {
        # the corner poses lie inside report cells (a 60 mm tray would put them on a cell edge)
        "one": [{"name": "a", "size_mm": [70, 70], **SQUARE}],
        "twins": [{"name": "a", "size_mm": [70, 70], **SQUARE}, {"name": "b", "size_mm": [70, 70], **SQUARE}],
        "two": [{"name": "a", "size_mm": [70, 70], **SQUARE}, {"name": "b", "size_mm": [80, 66], **SQUARE}],
    }
    paths = {}
    for name, comps in files.items():
        paths[name] = str(d / f"{name}.json")
        with open(paths[name], "w") as fh:
            json.dump({"tilt_deg": 30, "compartments": comps}, fh)
    paths["dir"] = d
    yield paths
    if old is None:
        os.environ.pop("KRUSKAL_CACHE", None)
    else:
        os.environ["KRUSKAL_CACHE"] = old


def _json(*argv) -> dict:
    buf = io.StringIO()
    with redirect_stdout(buf):
        code = main([*argv, "--json"])
    assert code == 0
    return json.loads(buf.getvalue())


def test_one_compartment_kit_gives_the_single_parts_answers(kits):
    kit = _json("plan", "--kit", kits["one"], "--target", "cell", *COARSE)
    path = kit["compartments"][0]["model"]
    single = _json("plan", "--model", path, "--target", "cell")
    for key in ("word", "length", "exact", "lower_bound", "final_cell", "success_probability"):
        assert kit[key] == single[key], key
    assert kit["per_compartment"][0]["length"] == single["length"]
    ens_k = _json("ensemble", "--kit", kits["one"], "--count", "100", "--length", "15", "--seed", "3",
                  "--epsilon", "0.001", *COARSE)
    ens_s = _json("ensemble", "--model", path, "--count", "100", "--length", "15", "--seed", "3",
                  "--epsilon", "0.001", "--draws", "0")
    for key in ("mean", "q25", "q75", "converged", "convergence_steps", "best_sequence"):
        assert ens_k[key] == ens_s[key], key
    conv_k = _json("convergence", "--kit", kits["one"], "--runs", "200", "--epsilon", "0.001", "--seed", "2", *COARSE)
    conv_s = _json("convergence", "--model", path, "--runs", "200", "--epsilon", "0.001", "--seed", "2", "--draws", "0")
    assert conv_k["expected_length"] == conv_s["expected_length"]
    for key in ("mean", "ci95", "censored"):
        assert conv_k["entropy_tilts"][key] == conv_s["entropy_tilts"][key]


def test_two_identical_compartments_have_the_single_plan(kits):
    single = _json("plan", "--kit", kits["one"], "--target", "state", *COARSE)
    twins = _json("plan", "--kit", kits["twins"], "--target", "state", *COARSE)
    assert twins["word"] == single["word"] and twins["exact"] == single["exact"]
    assert [p["length"] for p in twins["per_compartment"]] == [single["length"]] * 2


def test_kit_plan_replayed_in_direct_simulation_lands_in_the_predicted_cells(kits):
    """Every part ends in its predicted cell at the predicted rate: the model's success probability
    lies in the 95% interval of the replay's share; the kit's convergence is no sooner than any
    part's own (each compartment's expected time is a lower bound of the kit's)."""
    from analysis.kit import kit_models, load_kit
    from analysis.kit_replay import replay_plan
    from transition_builder.builder import BuildSettings

    plan = _json("plan", "--kit", kits["two"], "--target", "cell", *COARSE)
    assert plan["word"] and len(plan["final_cell"]) == 2
    assert plan["length"] >= max(p["length"] for p in plan["per_compartment"])
    kit = load_kit(kits["two"])
    comps = kit_models(kit, BuildSettings(tol_mm=2, tol_deg=2, recenter_rounds=1, start_samples=200), workers=1)
    assert all(c["cached"] for c in comps)
    rep = replay_plan([c["scene"] for c in comps], kit.names, plan["word"], plan["final_cell"],
                      plan["success_probability"], 200, seed=1, workers=1)
    for row in rep["compartments"]:
        assert row["within"], row
    conv = _json("convergence", "--kit", kits["two"], "--runs", "300", "--epsilon", "0.001", *COARSE)
    own = [c["expected_length"]["monte_carlo"] for c in conv["compartments"]]
    assert conv["expected_length"]["monte_carlo"] >= max(own) - 1e-9 or \
        conv["expected_length"]["ci95"][1] >= max(own)


def test_simulate_kit_drives_every_compartment_and_animates(kits, capsys):
    gif = str(kits["dir"] / "kit.gif")
    out = _json("simulate", "--kit", kits["two"], "--sequence", "NE,SE", "--trials", "30", "--workers", "1",
                "--animation", gif)
    assert [c["name"] for c in out["compartments"]] == ["a", "b"]
    assert all(len(c["entropy_bits"]) == 3 for c in out["compartments"])
    assert out["entropy_bits"][-1] == pytest.approx(sum(c["entropy_bits"][-1] for c in out["compartments"]))
    from PIL import Image

    with Image.open(gif) as im:
        assert im.n_frames > 1
    single = _json("simulate", "--shape", "rectangle:30x30", "--friction", "0.1", "--sequence", "NE,SE",
                   "--trials", "30", "--workers", "1", "--scene", _scene_file(kits, 70, 70))
    assert single["entropy_bits"] == out["compartments"][0]["entropy_bits"]


def _scene_file(kits, x, y) -> str:
    from transition_builder.scene import scene_from_options

    path = str(kits["dir"] / f"scene_{x}x{y}.json")
    scene_from_options("rectangle:30x30", friction_spec=0.1, tray_mm=(x, y)).save(path)
    return path


def test_design_variants_are_cached_and_the_same_seed_gives_the_same_table(kits, tmp_path):
    argv = ["design", "--shape", "rectangle:30x30", "--friction", "0.1", "--tray-mm", "70..80:2", "--count", "100",
            "--runs", "60", "--check-trials", "40", "--seed", "4", *COARSE]
    first = _json(*argv, "--figure", str(tmp_path / "pareto.png"))
    again = _json(*argv)
    assert len(first["variants"]) == 2 and all(v["cached"] for v in again["variants"])
    drop = ("seconds", "cached")
    assert [{k: v for k, v in r.items() if k not in drop} for r in first["variants"]] == \
        [{k: v for k, v in r.items() if k not in drop} for r in again["variants"]]
    assert first["best"] == again["best"] and first["pareto"] == again["pareto"]
    assert os.path.getsize(first["figure"]) > 0
    assert first["replay"]["trials"] == 40
    for v in first["variants"]:
        lo, hi = v["converging_share_ci"]
        assert lo <= v["converging_share"] <= hi and v["tray_mm"] == [v["side_mm"]] * 2


def test_design_of_one_part_has_the_rankings_numbers(kits):
    """design shares the ranking's definitions: the converging share and the expected random tilts
    of a part's variant are part_metrics' on the same model with the same seed."""
    from analysis.orientability import part_metrics
    from kruskal_markov.model import TransitionModel
    from transition_builder.cache import model_file

    out = _json("design", "--shape", "rectangle:30x30", "--friction", "0.1", "--tray-mm", "70", "--count", "100",
                "--runs", "60", "--check-trials", "0", "--seed", "4", *COARSE)
    (row,) = out["variants"]
    m = part_metrics(TransitionModel.load(model_file(row["models"][0])), seed=4, count=100, runs=60, draws=0,
                     sync_node_budget=100_000)
    assert row["converging_share"] == m.converging_share_50
    assert row["expected_tilts"] == m.random_tilts


@pytest.mark.parametrize("content, needle", [
    ("{not json", "not valid JSON"),
    ('{"compartments": []}', "non-empty list"),
    ('{"compartments": [{"name": "a", "size_mm": [70, 70], "shape": "rectangle:30x30"},'
     ' {"name": "a", "size_mm": [70, 70], "shape": "rectangle:30x30"}]}', "appears twice"),
    ('{"compartments": [{"name": "a", "size_mm": [20, 70], "shape": "rectangle:30x30"}]}', "too small"),
    ('{"compartments": [{"name": "a", "size_mm": [-70, 70], "shape": "rectangle:30x30"}]}', "positive"),
    ('{"compartments": [{"name": "a", "size_mm": [70], "shape": "rectangle:30x30"}]}', "size_mm"),
    ('{"compartments": [{"name": "a", "size_mm": [70, 70], "shape": "blob"}]}', "blob"),
    ('{"compartments": [{"name": "a", "size_mm": [70, 70], "shape": "rectangle:30x30", "friction": "x"}]}',
     "friction"),
    ('{"tilt_deg": 95, "compartments": [{"name": "a", "size_mm": [70, 70], "shape": "rectangle:30x30"}]}',
     "below 90"),
    ('{"trays": 1, "compartments": [{"name": "a", "size_mm": [70, 70], "shape": "rectangle:30x30"}]}',
     "unknown key"),
])
@pytest.mark.parametrize("command", ["plan", "ensemble", "convergence", "simulate", "design"])
def test_bad_kits_are_one_line_exit_2(tmp_path, capsys, content, needle, command):
    path = tmp_path / "kit.json"
    path.write_text(content)
    extra = {"plan": [], "ensemble": ["--count", "5", "--length", "5"], "convergence": [],
             "simulate": ["--sequence", "N", "--trials", "2"], "design": []}[command]
    code = main([command, "--kit", str(path), *extra])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and needle in err, err


def test_kit_with_other_model_sources_is_exit_2(kits, capsys):
    for argv in (["plan", "--kit", kits["one"], "--model", "x.npz"],
                 ["ensemble", "--kit", kits["one"], "--shape", "allen-key", "--count", "2", "--length", "2"],
                 ["simulate", "--kit", kits["one"], "--shape", "allen-key", "--sequence", "N"],
                 ["simulate", "--shape", "allen-key", "--sequence", "N", "--animation", "x.gif"],
                 ["design", "--kit", kits["one"], "--friction", "0.2"],
                 ["design", "--shape", "rectangle:30x30", "--tray-mm", "10..20"],
                 [str(kits["dir"] / "missing.json")]):
        argv = argv if len(argv) > 1 else ["plan", "--kit", argv[0]]
        code = main(argv)
        _, err = capsys.readouterr()
        assert code == 2 and len(err.strip().splitlines()) == 1, (argv, err)


def test_design_of_a_kit_keeps_its_own_sizes_and_replays_every_compartment(kits):
    plan = _json("plan", "--kit", kits["two"], "--target", "cell", *COARSE)
    out = _json("design", "--kit", kits["two"], "--count", "100", "--runs", "60", "--check-trials", "20", *COARSE)
    (row,) = out["variants"]
    assert row["tray_mm"] is None and row["area_mm2"] == 70 * 70 + 80 * 66 and row["cached"]
    assert out["best"] == 0 and out["pareto"] == [0] and out["reference"] is None
    assert row["word"] == plan["word"] and row["final_cells"] == plan["final_cell"]
    assert [c["name"] for c in out["replay"]["compartments"]] == ["a", "b"]


def test_sweep_values_and_bad_ranges():
    from analysis.design import Kit, Sweep, parse_sweep_range, variants
    from analysis.kit import parse_kit

    assert parse_sweep_range("1..4", 2, "--aspect", None) == (1.0, 4.0)
    for bad in ("0..3", "5..2", "x", "3..5:1"):
        with pytest.raises(ValueError):
            parse_sweep_range(bad, 3, "--tray-mm", None)
    kit = parse_kit({"compartments": [{"name": "a", "size_mm": [70, 70], **SQUARE}]})
    assert isinstance(kit, Kit)
    found, skipped = variants(kit, Sweep((40.0, 80.0), (1.0, 4.0), (30.0,)))
    sizes = [d["tray_mm"] for d, _ in found]
    assert sizes == [[40.0, 40.0], [80.0, 80.0], [160.0, 40.0]]      # T^2 the area, x/y the aspect
    assert [d["tray_mm"] for d, _ in skipped] == [[80.0, 20.0]] and "too small" in skipped[0][1]
