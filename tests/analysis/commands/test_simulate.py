"""Tests for ``kruskal simulate``: JSON contract, determinism, pose files, bad input -> exit 2."""
from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from analysis.cli import main

pytest.importorskip("transition_builder.sim")


def _run(capsys, *argv):
    code = main(["simulate", *argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    """One small real simulation, run once for several checks (JSON via the CLI, in-process)."""
    path = tmp_path_factory.mktemp("sim") / "poses.csv"
    import io
    from contextlib import redirect_stdout

    buf = io.StringIO()
    with redirect_stdout(buf):
        code = main(["simulate", "--shape", "allen-key", "--sequence", "NE,S,W", "--trials", "24",
                     "--seed", "4", "--workers", "1", "--poses", str(path), "--json"])
    assert code == 0
    return json.loads(buf.getvalue()), path


def test_json_contract(small_run):
    res, _ = small_run
    for key in ("entropy_bits", "trials", "tilts", "faults", "seconds"):
        assert key in res
    assert res["trials"] == 24 and res["tilts"] == 3
    assert len(res["entropy_bits"]) == 4
    assert set(res["faults"]) == {"tipped", "escaped", "unsettled", "invalid"}
    assert res["sequence"] == ["NE", "S", "W"]
    assert all(0 <= h <= math.log2(64) + 1e-9 for h in res["entropy_bits"])
    assert all(h <= math.log2(max(n, 1)) + 1e-9 for h, n in zip(res["entropy_bits"], res["surviving"]))
    assert len(res["scene_hash"]) == 64
    assert res["noise"] == "none"
    assert res["contact"] == "coulomb"                  # the default contact, named


@pytest.mark.parametrize("command", ["build", "validate", "rank", "reproduce"])
def test_unknown_contact_is_one_line_exit_2_on_every_command(capsys, command, tmp_path):
    """``--contact`` has one meaning everywhere: an unknown value stops every command in one line
    before any work."""
    argv = {"build": ["build", "--shape", "rectangle:30x30"],
            "validate": ["validate", "--model", str(tmp_path / "missing.npz")],
            "rank": ["rank", "--shapes", "rectangle:30x30"],
            "reproduce": ["reproduce", "--quick", "--out", str(tmp_path / "r")]}[command]
    code = main([*argv, "--contact", "sphere-ish"])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and "unknown contact model" in err


def test_poses_file_matches_json(small_run):
    from analysis.montecarlo import entropy_by_step, read_poses_csv
    from transition_builder.grid import ReportGrid

    res, path = small_run
    rec = read_poses_csv(path)
    assert rec.trials == 24 and rec.n_steps == 4
    grid = ReportGrid(200, 200, 4, 4, 4)
    np.testing.assert_allclose(entropy_by_step(rec, grid), res["entropy_bits"], atol=1e-12)
    n_fault_rows = int(np.sum(rec.status != 0))
    assert n_fault_rows == sum(res["faults"].values())


def test_same_seed_same_output_across_processes(small_run):
    """A fresh process with 2 workers reproduces the in-process single-worker run exactly."""
    res, _ = small_run
    cmd = [sys.executable, "-m", "analysis", "simulate", "--shape", "allen-key", "--sequence", "NE,S,W",
           "--trials", "24", "--seed", "4", "--workers", "2", "--json"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert len(lines) == 1  # exactly one JSON object on stdout
    other = json.loads(lines[0])
    assert other["entropy_bits"] == res["entropy_bits"]
    assert other["faults"] == res["faults"]
    assert other["scene_hash"] == res["scene_hash"]


def test_random_sequence_from_seed(capsys):
    code, out, _ = _run(capsys, "--sequence", "random:6", "--trials", "3", "--seed", "11", "--workers", "1",
                        "--json", "--grid", "2x2x2")
    assert code == 0
    a = json.loads(out)
    code, out, _ = _run(capsys, "--sequence", "random:6", "--trials", "3", "--seed", "11", "--workers", "1",
                        "--json", "--grid", "2x2x2")
    b = json.loads(out)
    assert a["sequence"] == b["sequence"] and len(a["sequence"]) == 6
    assert a["entropy_bits"] == b["entropy_bits"]
    assert a["grid"] == "2x2x2"


def test_one_seed_one_sequence_in_every_command(capsys, tmp_path):
    """--sequence random:N --seed S names the same actions in simulate, entropy and validate's
    first sequence, so a model's prediction and a direct simulation of it really compare alike."""
    from analysis.sequences import random_sequences_for

    names = ["N", "NE", "E", "SE", "S", "SW", "W", "NW"]
    code, out, _ = _run(capsys, "--sequence", "random:9", "--trials", "2", "--seed", "23", "--workers", "1",
                        "--json")
    assert code == 0
    simulated = json.loads(out)["sequence"]
    aut = tmp_path / "eight.json"
    aut.write_text(json.dumps({"states": 2, "actions": {a: [1, 0] for a in names}}))
    assert main(["entropy", "--automaton", str(aut), "--sequence", "random:9", "--seed", "23", "--json"]) == 0
    predicted = json.loads(capsys.readouterr().out)["sequence"]
    assert simulated == predicted == [names[a] for a in random_sequences_for(8, 3, 9, 23)[0]]


def test_process_noise_option(capsys):
    argv = ["--sequence", "NE,S", "--trials", "16", "--seed", "4", "--workers", "1", "--json"]
    code, out, err = _run(capsys, *argv, "--noise", "pose:0.5,0.5")
    assert code == 0, err
    noisy = json.loads(out)
    assert noisy["noise"] == "pose:0.5,0.5" and noisy["trials"] == 16
    code, out, _ = _run(capsys, *argv, "--noise", "pose:0,0")
    zero = json.loads(out)
    code, out, _ = _run(capsys, *argv)
    plain = json.loads(out)
    assert zero["noise"] == plain["noise"] == "none"
    assert zero["entropy_bits"] == plain["entropy_bits"]


def test_zero_length_sequence_text_output(capsys):
    code, out, _ = _run(capsys, "--sequence", "", "--trials", "500", "--seed", "1")
    assert code == 0
    assert "entropy_bits" in out and "faults" in out


@pytest.mark.parametrize("argv, needle", [
    (["--shape", "hexagon", "--sequence", "N"], "unknown shape"),
    (["--shape", "polygon:0,0;10,10;10,0;0,10", "--sequence", "N"], "not simple"),
    (["--shape", "polygon:0,0;1,x;2,2", "--sequence", "N"], "not a number"),
    (["--shape", "rectangle:300x10", "--sequence", "N"], "does not fit"),
    (["--sequence", "N,UP"], "unknown action 'UP'"),
    (["--sequence", "random:x"], "random:N"),
    (["--sequence", "N", "--trials", "0"], "--trials"),
    (["--sequence", "N", "--grid", "4x4"], "bad grid"),
    (["--sequence", "N", "--friction", "slippery"], "friction"),
    (["--sequence", "N", "--workers", "0"], "--workers"),
    (["--sequence", "N", "--noise", "pose:x"], "pose:SIGMA_MM,SIGMA_DEG"),
    (["--sequence", "N", "--noise", "gauss:1,1"], "pose:SIGMA_MM,SIGMA_DEG"),
    (["--sequence", "N", "--trials", "2", "--scheduler", "nonsense://x"], "scheduler"),
    (["--sequence", "N", "--poses", ""], "empty string"),
    (["--shape", "", "--sequence", "N"], "--shape is empty"),
    (["--sequence", "N", "--poses", "/nonexistent-dir/p.csv"], "does not exist"),
    (["--sequence", "N", "--poses", "/"], "is a directory"),
    (["--sequence", "N", "--contact", "springs"], "unknown contact model"),
    (["--sequence", "N", "--contact", "legs:1"], "unknown contact model"),
])
def test_bad_input_exits_2_with_one_line(capsys, argv, needle):
    code, out, err = _run(capsys, *argv)
    assert code == 2
    assert out == ""
    assert len(err.strip().splitlines()) == 1
    assert needle.lower() in err.lower()
    assert "Traceback" not in err


def test_bad_input_in_a_real_process():
    proc = subprocess.run([sys.executable, "-m", "analysis", "simulate", "--shape", "polygon:0,0;1,1",
                           "--sequence", "N", "--json"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stdout == ""
    err = [line for line in proc.stderr.splitlines() if not line.startswith("pybullet build time")]
    assert len(err) == 1 and "at least 3 vertices" in err[0]


def test_scene_file_and_overrides(capsys, tmp_path):
    from transition_builder.scene import scene_from_options

    path = tmp_path / "scene.json"
    scene_from_options("rectangle:40x20", friction_spec=0.2).save(path)
    code, out, err = _run(capsys, "--scene", str(path), "--sequence", "E", "--trials", "20", "--workers", "1",
                          "--json", "--theta-offset", "0")
    assert code == 0, err
    res = json.loads(out)
    assert res["shape"] == "rectangle:40x20" and res["friction"] == "0.2"
    assert res["symmetry_order"] == 2 and res["theta_offset"] == 0.0
    code, out, err = _run(capsys, "--scene", str(path), "--shape", "triangle:2", "--sequence", "E",
                          "--trials", "20", "--workers", "1", "--json")
    assert code == 0, err
    assert json.loads(out)["shape"] == "triangle:2"
    code, out, err = _run(capsys, "--scene", str(tmp_path / "missing.json"), "--sequence", "E")
    assert code == 2 and len(err.strip().splitlines()) == 1
