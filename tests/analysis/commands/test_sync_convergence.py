"""``kruskal sync`` and ``kruskal convergence`` through the command line (docs/commands.md keys)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from analysis.cli import main
from kruskal_markov.generators import cerny_table


def run_json(capsys, argv):
    rc = main(argv + ["--json"])
    out = capsys.readouterr()
    return rc, (json.loads(out.out) if rc == 0 else None), out.err


@pytest.fixture
def cerny5(tmp_path):
    table = cerny_table(5)
    path = tmp_path / "c5.json"
    path.write_text(json.dumps({"states": 5, "actions": {"a": table[0].tolist(), "b": table[1].tolist()}}))
    return path


def test_sync_cli_cerny(capsys, cerny5):
    rc, res, _ = run_json(capsys, ["sync", "--automaton", str(cerny5)])
    assert rc == 0
    assert res["length"] == 16 and res["exact"] is True and isinstance(res["method"], str)
    assert "seconds" in res
    table = {"a": [1, 2, 3, 4, 0], "b": [0, 1, 2, 3, 0]}
    cur = set(range(5))
    for a in res["word"]:
        cur = {table[a][q] for q in cur}
    assert len(cur) == 1


def test_sync_cli_non_synchronizing(capsys, tmp_path):
    path = tmp_path / "perm.json"
    path.write_text(json.dumps({"states": 3, "actions": {"a": [1, 2, 0], "b": [1, 0, 2]}}))
    rc, res, _ = run_json(capsys, ["sync", "--automaton", str(path)])
    assert rc == 0 and res["word"] is None and res["length"] is None and res["exact"] is True
    assert res["witness"]


def test_sync_cli_stochastic_threshold(capsys, tmp_path):
    path = tmp_path / "st.json"
    path.write_text(json.dumps({"states": 3, "actions": {
        "a": {"rows": [0, 0, 1, 2], "cols": [1, 2, 2, 2], "probs": [0.95, 0.05, 1, 1]},
        "b": {"rows": [0, 1, 2], "cols": [0, 0, 1], "probs": [1, 1, 1]}}}))
    rc, res, _ = run_json(capsys, ["sync", "--automaton", str(path), "--threshold", "0.1"])
    assert rc == 0 and res["mass_dropped"] == pytest.approx(0.05) and res["exact"]
    rc, res2, _ = run_json(capsys, ["sync", "--automaton", str(path), "--epsilon", "0.0"])
    assert rc == 0 and res2["length"] is not None


def test_convergence_cli(capsys, cerny5):
    rc, res, _ = run_json(capsys, ["convergence", "--automaton", str(cerny5), "--seed", "3", "--runs", "500"])
    assert rc == 0
    e = res["expected_length"]
    assert set(e) >= {"exact", "monte_carlo", "ci95", "pair_lower", "pair_upper"}
    assert e["pair_lower"] <= e["exact"] <= e["pair_upper"]
    rc, again, _ = run_json(capsys, ["convergence", "--automaton", str(cerny5), "--seed", "3", "--runs", "500"])
    assert again["expected_length"]["monte_carlo"] == e["monte_carlo"]
    rc, weighted, _ = run_json(capsys, ["convergence", "--automaton", str(cerny5), "--weights", "a=3,b=1",
                                        "--runs", "200"])
    assert rc == 0 and weighted["weights"] == [0.75, 0.25]


def test_cli_bad_input(capsys, cerny5, tmp_path):
    assert main(["sync", "--automaton", str(tmp_path / "missing.json"), "--json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert main(["convergence", "--automaton", str(cerny5), "--weights", "1,2,3"]) == 2
    assert "weights" in capsys.readouterr().err
    assert main(["sync", "--automaton", str(cerny5), "--threshold", "2"]) == 2
    capsys.readouterr()
    assert main(["sync"]) == 2
    for cmd, opt in (("sync", "--time-budget"), ("sync", "--memory-budget-mb"), ("convergence", "--pair-time-budget"),
                     ("convergence", "--mc-time-budget"), ("sync", "--node-budget")):
        for bad in (("0", "-1", "1.5") if opt == "--node-budget" else ("nan", "inf", "0", "-1")):
            capsys.readouterr()
            assert main([cmd, "--automaton", str(cerny5), opt, bad]) == 2
            err = capsys.readouterr().err
            assert err.count("\n") == 1 and opt in err


def _tray_like_model(seed, n=24, k=4):
    """A small stochastic 'tray' model: each action pushes every state into a few wall states,
    mostly deterministically, sometimes splitting between two of them."""
    import scipy.sparse as sp

    from kruskal_markov.model import TransitionModel

    rng = np.random.default_rng(seed)
    mats = []
    for _ in range(k):
        walls = rng.choice(n, size=n // 4, replace=False)
        rows, cols, vals = [], [], []
        for q in range(n):
            if rng.random() < 0.2:
                c = rng.choice(walls, size=2, replace=False)
                rows += [q, q]
                cols += list(c)
                vals += [0.7, 0.3]
            else:
                rows.append(q)
                cols.append(int(rng.choice(walls)))
                vals.append(1.0)
        mats.append(sp.csr_matrix((vals, (rows, cols)), shape=(n, n)))
    initial = np.zeros(n)
    initial[rng.choice(n, size=n // 2, replace=False)] = 1.0
    return TransitionModel(["N", "E", "S", "W"][:k], mats, initial=initial / initial.sum(),
                           partition=np.arange(n) % 6, n_cells=6)


def test_model_path_sync_and_convergence(capsys, tmp_path):
    from kruskal_markov.sync import support_automaton

    model = _tray_like_model(3)
    path = tmp_path / "tray.npz"
    model.save(path)
    rc, res, _ = run_json(capsys, ["sync", "--model", str(path)])
    assert rc == 0 and res["start_states"] == 12 and res["deterministic"] is False
    aut = support_automaton(model)
    start = np.flatnonzero(model.initial > 0)
    if res["word"] is not None:
        # every state of the initial support ends in the same single state (union of supports)
        assert len(aut.image(start, [model.actions.index(a) for a in res["word"]])) == 1
    else:
        assert res["witness"] or res["exact"] is False
    # a threshold keeps only the 0.7 branches: drops mass 0.3 and makes the automaton deterministic
    rc, thr, _ = run_json(capsys, ["sync", "--model", str(path), "--threshold", "0.5"])
    assert rc == 0 and thr["mass_dropped"] == pytest.approx(0.3) and thr["deterministic"] is True
    rc, eps, _ = run_json(capsys, ["sync", "--model", str(path), "--epsilon", "0.5"])
    assert rc == 0 and "word" in eps and "exact" in eps
    rc, conv, _ = run_json(capsys, ["convergence", "--model", str(path), "--runs", "200", "--epsilon", "0.5"])
    assert rc == 0 and "entropy_tilts" in conv and "expected_length" in conv


def _budgeted_run(tmp_path, n, command, budget_args):
    """Run ``kruskal COMMAND`` on a seeded random binary automaton of ``n`` states in a child process
    and return its JSON result. Wall time and memory are measured by ``benchmarks/bench_sync.py``
    (``cli_budgets``), not here: a test must not depend on the machine's speed."""
    import subprocess
    import sys

    rng = np.random.default_rng(1)
    path = tmp_path / f"random{n}.json"
    path.write_text(json.dumps({"states": n, "actions": {"a": rng.integers(0, n, n).tolist(),
                                                         "b": rng.integers(0, n, n).tolist()}}))
    proc = subprocess.run([sys.executable, "-m", "analysis", command, "--automaton", str(path), "--json",
                           *budget_args], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout)


@pytest.mark.parametrize("n", [3000, pytest.param(20000, marks=pytest.mark.slow)])
def test_large_random_automaton_stops_at_its_work_budgets(tmp_path, n):
    """sync and convergence on a large random automaton stop at budgets of work (subsets, letters),
    not seconds, so the answer is the same on a loaded machine, and say which phase stopped and why."""
    res = _budgeted_run(tmp_path, n, "sync", ["--node-budget", "20000"])
    again = _budgeted_run(tmp_path, n, "sync", ["--node-budget", "20000"])
    assert again["word"] == res["word"] and again["lower_bound"] == res["lower_bound"]   # deterministic
    assert res["exact"] is False and res["word"] is not None           # a greedy word, verified
    assert any("exact search stopped by its budget" in note for note in res["notes"])
    assert res["lower_bound"] >= 1 and res["length"] >= res["lower_bound"]
    # the pair-chain phase keeps a seconds budget (no assertion reads its result); the asserted
    # phases are bounded by --max-subsets and by letters per run (--max-steps)
    res = _budgeted_run(tmp_path, n, "convergence", ["--pair-time-budget", "3", "--max-subsets", "20000",
                                                     "--runs", "200"])
    assert res["subsets"] == ">20000"                                   # the exact chain was too large
    assert res["expected_length"]["monte_carlo"] is not None
    if n > 10_000:
        assert "skipped" in res["pair_check"] and "pair bounds skipped" in res["pair_bounds"]
