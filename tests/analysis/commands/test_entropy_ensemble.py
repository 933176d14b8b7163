"""``kruskal entropy`` and ``kruskal ensemble`` through the command line (docs/commands.md keys, exit codes)."""
from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse as sp

from analysis.cli import main
from kruskal_markov.automaton_json import model_from_automaton
from kruskal_markov.entropy import entropy_trajectory
from kruskal_markov.model import TransitionModel


def run_json(capsys, argv):
    rc = main(argv + ["--json"])
    out = capsys.readouterr()
    return rc, (json.loads(out.out) if rc == 0 else None), out.err


def run_error(capsys, argv):
    try:
        rc = main(argv)
    except SystemExit as exc:  # argparse usage errors
        rc = exc.code
    out = capsys.readouterr()
    assert rc == 2, out
    lines = out.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in out.err
    assert out.out == ""
    return lines[0]


@pytest.fixture
def cerny4(tmp_path):
    path = tmp_path / "c4.json"
    path.write_text(json.dumps({"states": 4, "actions": {"a": [1, 2, 3, 0], "b": [1, 1, 2, 3]}}))
    return path


@pytest.fixture
def stochastic_model(tmp_path):
    rng = np.random.default_rng(0)
    n = 20
    mats = []
    for _ in range(8):
        a = rng.random((n, n)) * (rng.random((n, n)) < 0.2)
        a[np.arange(n), rng.integers(0, 5, n)] += 1.0
        mats.append(sp.csr_matrix(a / a.sum(axis=1, keepdims=True)))
    model = TransitionModel(["N", "NE", "E", "SE", "S", "SW", "W", "NW"], mats,
                            partition=np.arange(n) // 5, metadata={"kind": "test"})
    path = tmp_path / "m.npz"
    model.save(path)
    return model, path


def test_entropy_automaton_states(capsys, cerny4):
    rc, res, _ = run_json(capsys, ["entropy", "--automaton", str(cerny4), "--sequence", "b,a,a,a,b,a,a,a,b"])
    assert rc == 0
    assert len(res["entropy_bits"]) == 10 and res["entropy_bits"] == res["entropy_bits_model"]
    assert res["entropy_bits"][0] == pytest.approx(2.0) and res["entropy_bits"][-1] == 0.0
    assert all(h > 0 for h in res["entropy_bits"][:-1])  # Černý C_4: nothing shorter than 9 resets
    assert res["actions"][0] == "b" and "seconds" in res


def test_entropy_model_partition(capsys, stochastic_model):
    model, path = stochastic_model
    rc, res, _ = run_json(capsys, ["entropy", "--model", str(path), "--sequence", "NE,S,w,W,N"])
    assert rc == 0
    traj = entropy_trajectory(model, ["NE", "S", "W", "W", "N"])
    np.testing.assert_allclose(res["entropy_bits"], traj.entropy_bits, atol=1e-12)
    np.testing.assert_allclose(res["entropy_bits_model"], traj.entropy_bits_states, atol=1e-12)
    assert res["entropy_bits"][0] == pytest.approx(2.0)  # 4 equal cells
    assert res["entropy_bits_model"][0] == pytest.approx(math.log2(20))
    assert res["mass_drift"] <= 1e-12 and res["entropy_on"] == "partition"


def test_entropy_random_sequence_uses_seed(capsys, stochastic_model):
    _, path = stochastic_model
    a = run_json(capsys, ["entropy", "--model", str(path), "--sequence", "random:12", "--seed", "4"])[1]
    b = run_json(capsys, ["entropy", "--model", str(path), "--sequence", "random:12", "--seed", "4"])[1]
    assert a["actions"] == b["actions"] and len(a["actions"]) == 12
    assert a["entropy_bits"] == b["entropy_bits"]


def test_ensemble_cli(capsys, cerny4):
    rc, res, _ = run_json(capsys, ["ensemble", "--automaton", str(cerny4), "--count", "500", "--length", "20",
                                   "--seed", "3"])
    assert rc == 0
    for key in ("mean", "q25", "q75"):
        assert len(res[key]) == 21
    assert len(res["convergence_steps"]) == 500
    conv = [s for s in res["convergence_steps"] if s is not None]
    assert res["converged"] == len(conv) > 0 and min(conv) >= 9
    # the best sequence really resets C_4 at the reported step (checked on the state set)
    table = {"a": [1, 2, 3, 0], "b": [1, 1, 2, 3]}
    cur = set(range(4))
    for t, a in enumerate(res["best_sequence"], start=1):
        cur = {table[a][q] for q in cur}
        if t == min(conv):
            assert len(cur) == 1
            break
    from kruskal_markov.ensemble import run_ensemble

    lib = run_ensemble(model_from_automaton(cerny4), 500, 20, seed=3)
    assert res["mean"] == lib.mean.tolist() and res["q25"] == lib.q25.tolist() and res["q75"] == lib.q75.tolist()
    assert res["best_sequence"] == [["a", "b"][i] for i in lib.best_sequence]
    assert res["zero_entropy_excluded"] is False and "one closed class" in res["structure"]
    again = run_json(capsys, ["ensemble", "--automaton", str(cerny4), "--count", "500", "--length", "20",
                              "--seed", "3"])[1]
    assert again["mean"] == res["mean"] and again["best_sequence"] == res["best_sequence"]


def test_ensemble_weights_and_text(capsys, cerny4):
    rc, res, _ = run_json(capsys, ["ensemble", "--automaton", str(cerny4), "--count", "50", "--length", "5",
                                   "--weights", "0,1"])
    assert rc == 0 and set(res["best_sequence"]) == {"b"}
    assert main(["ensemble", "--automaton", str(cerny4), "--count", "10", "--length", "3"]) == 0
    out = capsys.readouterr().out
    assert "best sequence" in out and "q25" in out


@pytest.mark.parametrize("argv_tail, pattern", [
    (["entropy", "--automaton", "{aut}", "--sequence", "b,X"], "unknown action 'X'"),
    (["entropy", "--automaton", "{aut}"], "--sequence is required"),
    (["entropy", "--sequence", "a"], "one of --model PATH or --automaton FILE is required"),
    (["entropy", "--automaton", "{missing}", "--sequence", "a"], "not found"),
    (["entropy", "--model", "{junk}", "--sequence", "a"], "not a readable kruskal model"),
    (["entropy", "--model", "{aut}", "--sequence", "a"], "not a readable kruskal model"),
    (["entropy", "--automaton", "{bad_rows}", "--sequence", "a"], "action 'a': row 1 sums to 0.5"),
    (["entropy", "--automaton", "{aut}", "--sequence", "random:x"], "random:N"),
    (["entropy", "--automaton", "{aut}", "--sequence", "a", "--shape", "allen-key"], "--shape is only used"),
    (["entropy", "--poses", "{aut}"], "--poses needs --shape"),
    (["ensemble", "--automaton", "{aut}", "--count", "0", "--length", "3"], "--count must be at least 1"),
    (["ensemble", "--automaton", "{aut}", "--count", "2", "--length", "-3"], "--length"),
    (["ensemble", "--automaton", "{aut}", "--count", "2", "--length", "3", "--weights", "1"],
     "--weights has 1 values, the model has 2 actions"),
    (["ensemble", "--automaton", "{aut}", "--count", "2", "--length", "3", "--weights", "1,x"], "bad --weights"),
    (["ensemble", "--automaton", "{aut}", "--count", "2", "--length", "3", "--weights", "1,-1"], "non-negative"),
    (["ensemble", "--automaton", "{aut}", "--count", "2", "--length", "3", "--epsilon", "-1"], "epsilon"),
    (["ensemble", "--automaton", "{aut}", "--length", "3"], "--count"),
])
def test_cli_errors_one_line_exit_2(capsys, tmp_path, cerny4, argv_tail, pattern):
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"garbage")
    bad_rows = tmp_path / "bad.json"
    bad_rows.write_text(json.dumps({"states": 2, "actions": {"a": {"rows": [0, 1], "cols": [0, 1],
                                                                   "probs": [1, 0.5]}}}))
    subst = {"{aut}": str(cerny4), "{missing}": str(tmp_path / "none.json"), "{junk}": str(junk),
             "{bad_rows}": str(bad_rows)}
    argv = [subst.get(a, a) for a in argv_tail]
    line = run_error(capsys, argv)
    assert pattern in line, line


def test_entropy_from_poses_csv(capsys, tmp_path):
    """Recorded poses: 4 trials in 4 far-apart places (2 bits), then all in one place (0 bits)."""
    rows = ["trial,step,x_mm,y_mm,theta_rad,status"]
    spots = [(10, 10, 0.0), (190, 10, 1.5), (10, 190, 3.0), (190, 190, 4.5)]
    for t, (x, y, th) in enumerate(spots):
        rows.append(f"{t},0,{x},{y},{th},ok")
        rows.append(f"{t},1,100,100,0.0,ok")
    rows.append("4,0,50,50,0.0,ok")
    rows.append("4,1,,,,tipped")
    path = tmp_path / "poses.csv"
    path.write_text("\n".join(rows) + "\n")
    rc, res, err = run_json(capsys, ["entropy", "--poses", str(path), "--shape", "rectangle:20x10"])
    assert rc == 0, err
    assert res["entropy_bits"][1] == 0.0
    # step 0: five poses in five distinct voxels of the 4x4x4 grid -> log2(5)
    assert res["entropy_bits"][0] == pytest.approx(math.log2(5), abs=1e-12)
    assert "entropy_bits_model" not in res


def test_real_binary_exit_code(tmp_path, cerny4):
    proc = subprocess.run([sys.executable, "-m", "analysis", "entropy", "--automaton", str(cerny4),
                           "--sequence", "q", "--json"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2 and proc.stdout == ""
    assert len(proc.stderr.strip().splitlines()) == 1 and "unknown action 'q'" in proc.stderr
    proc = subprocess.run([sys.executable, "-m", "analysis", "entropy", "--automaton", str(cerny4),
                           "--sequence", "b,a", "--json"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0
    assert set(json.loads(proc.stdout)) >= {"entropy_bits", "entropy_bits_model", "seconds"}


def test_ensemble_cli_reports_closed_classes(capsys, tmp_path):
    path = tmp_path / "two.json"
    path.write_text(json.dumps({"states": 4, "actions": {"a": [0, 0, 3, 3], "b": [0, 2, 1, 3]}}))
    rc, res, _ = run_json(capsys, ["ensemble", "--automaton", str(path), "--count", "100", "--length", "8"])
    assert rc == 0 and res["converged"] == 0
    assert res["zero_entropy_excluded"] is True and "cannot reach zero" in res["structure"]
