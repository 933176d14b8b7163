"""Plans (kruskal_markov.sync.plan): every target's answer against brute force over all words."""
from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest
import scipy.sparse as sp

from analysis.cli import main
from kruskal_markov.automaton_json import model_from_automaton
from kruskal_markov.model import TransitionModel
from kruskal_markov.sync import (
    PlanResult,
    parse_target,
    random_word_success,
    shortest_plan,
    shortest_synchronizing_word,
    support_automaton,
)


# ----------------------------------------------------------------------------- independent judge
def _dense(model):
    return [np.asarray(sp.csr_matrix(m).todense()) for m in model.matrices]


def meets(model, word, target, cells=None):
    """Plain numpy: does ``word`` meet ``target`` on ``model`` (support of the start set / distribution)?"""
    t = parse_target(target)
    P = _dense(model)
    p = np.asarray(model.initial, dtype=float).copy()
    support = p > 0
    for a in word:
        p = p @ P[a]
        support = (support.astype(float) @ (P[a] > 0)) > 0
    if t.kind == "state":
        return int(support.sum()) == 1
    part = np.arange(model.n_states) if cells is None and model.partition is None else \
        np.asarray(model.partition if cells is None else cells)
    if t.kind == "cell":
        return len(set(part[support].tolist())) == 1
    mass = np.bincount(part, weights=p)
    return mass.max() >= 1 - t.epsilon - 1e-12


def brute_length(models, target, max_len, cells=None):
    """Shortest length of a word meeting ``target`` on every model, by enumeration (None if > max_len)."""
    k = models[0].n_actions
    for length in range(max_len + 1):
        for w in itertools.product(range(k), repeat=length):
            if all(meets(m, w, target, None if cells is None else cells[i]) for i, m in enumerate(models)):
                return length
    return None


def random_model(rng, n, k, stochastic, cells):
    mats = []
    for _ in range(k):
        a = np.zeros((n, n))
        a[np.arange(n), rng.integers(0, n, n)] = 1.0
        if stochastic:
            extra = (rng.random((n, n)) < 0.12) * rng.random((n, n))
            a = a + extra
        mats.append(sp.csr_matrix(a / a.sum(axis=1, keepdims=True)))
    init = rng.random(n) ** 3 + 0.01
    part = rng.integers(0, cells, n)
    return TransitionModel([f"a{i}" for i in range(k)], mats, initial=init / init.sum(), partition=part,
                           n_cells=cells)


CASES = [(seed, stoch) for seed in range(14) for stoch in (False, True)]


@pytest.mark.parametrize("seed,stochastic", CASES)
@pytest.mark.parametrize("target", ["state", "cell", "probability:0.2"])
def test_plan_equals_brute_force(seed, stochastic, target):
    rng = np.random.default_rng(seed)
    n, k = int(rng.integers(3, 7)), int(rng.integers(2, 4))
    model = random_model(rng, n, k, stochastic, int(rng.integers(2, 4)))
    max_len = 7 if k == 2 else 5
    truth = brute_length([model], target, max_len)
    res = shortest_plan(model, target, max_length=max_len, node_budget=10**6)
    assert isinstance(res, PlanResult)
    if truth is None:
        assert res.word is None
        assert res.lower_bound is None or res.lower_bound > max_len or res.exact
    else:
        assert res.exact, res
        assert res.length == truth and res.lower_bound == truth
        assert meets(model, [model.actions.index(a) for a in res.word], target)
    d = res.to_dict()
    assert set(d) >= {"word", "length", "exact", "lower_bound", "target", "method", "final_cell",
                      "success_probability"}
    assert d["target"] == target


def test_no_plan_proven_exhaustively():
    # a two-cycle that never merges: no word orients it, proven by exhausting the images
    m = model_from_automaton({"states": 2, "actions": {"a": [1, 0], "b": [0, 1]}})
    res = shortest_plan(m, "state")
    assert res.word is None and res.exact and res.witness is not None
    assert brute_length([m], "state", 6) is None


def _strict_case():
    """The first seeded model where probability:E < cell < state (found by brute force)."""
    for seed in range(300):
        rng = np.random.default_rng(1000 + seed)
        model = random_model(rng, 6, 2, False, 2)
        s = brute_length([model], "state", 9)
        c = brute_length([model], "cell", 9)
        p = brute_length([model], "probability:0.3", 9)
        if s is not None and c is not None and p is not None and p < c < s:
            return model, s, c, p
    return None


def test_cell_shorter_than_state_and_probability_shorter_than_cell():
    found = _strict_case()
    assert found is not None, "no seeded model separates the three targets"
    model, s, c, p = found
    for target, truth in (("state", s), ("cell", c), ("probability:0.3", p)):
        res = shortest_plan(model, target, max_length=9)
        assert res.exact and res.length == truth


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("budget", [1, 5, 20, 60])
def test_budget_stop_lower_bound_never_above_truth(seed, budget):
    rng = np.random.default_rng(50 + seed)
    model = random_model(rng, 6, 2, seed % 2 == 1, 3)
    for target in ("state", "cell", "probability:0.1"):
        truth = brute_length([model], target, 8)
        res = shortest_plan(model, target, node_budget=budget, max_length=8, beam_width=2)
        if res.exact:
            assert res.word is None and truth is None or res.length == truth
        if truth is not None and res.lower_bound is not None:
            assert res.lower_bound <= truth
        if res.word is not None:
            assert meets(model, [model.actions.index(a) for a in res.word], target)
            assert res.length >= (truth or 0)


def test_robust_plan_verifies_on_every_model():
    rng = np.random.default_rng(7)
    models = [random_model(rng, 5, 2, False, 2) for _ in range(2)]
    truth = brute_length(models, "cell", 8)
    res = shortest_plan(models, "cell", max_length=8)
    assert truth is not None and res.exact and res.length == truth
    w = [models[0].actions.index(a) for a in res.word]
    assert all(meets(m, w, "cell") for m in models)
    assert len(res.final_cell) == 2 and len(res.success_probability) == 2
    assert res.length >= max(brute_length([m], "cell", 8) for m in models)


def test_robust_pair_without_common_plan_says_why():
    # model A orients only with last letter a, model B only with last letter b (set-valued rows)
    A = TransitionModel(["a", "b"], [sp.csr_matrix([[1.0, 0], [1.0, 0]]), sp.csr_matrix([[.5, .5], [.5, .5]])])
    B = TransitionModel(["a", "b"], [sp.csr_matrix([[.5, .5], [.5, .5]]), sp.csr_matrix([[1.0, 0], [1.0, 0]])])
    assert brute_length([A], "state", 4) == 1 and brute_length([B], "state", 4) == 1
    assert brute_length([A, B], "state", 6) is None
    res = shortest_plan([A, B], "state")
    assert res.word is None and res.exact
    assert "every model" in res.witness["reason"]
    assert res.witness["per_model_lengths"] == [1, 1]


def test_state_target_agrees_with_sync():
    rng = np.random.default_rng(3)
    for _ in range(5):
        table = rng.integers(0, 8, size=(2, 8))
        m = model_from_automaton({"states": 8, "actions": {"a": table[0].tolist(), "b": table[1].tolist()}})
        s = shortest_synchronizing_word(support_automaton(m), node_budget=10**6)
        p = shortest_plan(m, "state", max_length=40)
        if s.word is None:
            assert p.word is None
        else:
            assert p.exact and s.exact and p.length == s.length


def test_random_word_success_matches_enumeration():
    rng = np.random.default_rng(11)
    model = random_model(rng, 5, 2, True, 2)
    res = random_word_success(model, "cell", max_length=4, words=4000, seed=1)
    for L in range(5):
        exact = np.mean([meets(model, w, "cell") for w in itertools.product(range(2), repeat=L)])
        lo, hi = res["ci95"][L]
        assert lo - 0.01 <= exact <= hi + 0.01
    again = random_word_success(model, "cell", max_length=4, words=4000, seed=1)
    assert again == res


# ----------------------------------------------------------------------------- command line
@pytest.fixture
def cerny_file(tmp_path):
    path = tmp_path / "c4.json"
    path.write_text(json.dumps({"states": 4, "actions": {"a": [1, 2, 3, 0], "b": [0, 1, 2, 0]},
                                "partition": [0, 0, 1, 1], "cells": 2}))
    return path


def test_cli_plan_keys_and_values(capsys, cerny_file):
    model = model_from_automaton(str(cerny_file))
    for target in ("state", "cell", "probability:0.25"):
        assert main(["plan", "--automaton", str(cerny_file), "--target", target, "--json"]) == 0
        out = json.loads(capsys.readouterr().out)
        assert {"word", "length", "exact", "lower_bound", "target", "method", "final_cell",
                "success_probability", "seconds"} <= set(out)
        assert out["target"] == target and out["exact"] is True
        assert out["length"] == brute_length([model], target, 10)
        assert meets(model, [model.actions.index(a) for a in out["word"]], target)


@pytest.mark.parametrize("argv", [
    ["plan", "--target", "cell"],
    ["plan", "--automaton", "AUTO", "--target", "voxel"],
    ["plan", "--automaton", "AUTO", "--target", "probability:1.5"],
    ["plan", "--automaton", "AUTO", "--target", "probability:x"],
    ["plan", "--automaton", "AUTO", "--grid", "2x2x2"],
    ["plan", "--automaton", "AUTO", "--node-budget", "0"],
    ["plan", "--automaton", "missing.json"],
    ["plan", "--model", "missing.npz", "--model", "other.npz"],
])
def test_cli_plan_bad_input_exit_2(capsys, cerny_file, argv):
    argv = [str(cerny_file) if a == "AUTO" else a for a in argv]
    assert main(argv + ["--json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err and "error" in err


@pytest.mark.parametrize("seed", [1, 2])
def test_sync_memory_bound_switches_to_depth_first_and_stays_exact(seed):
    """A memory budget too small for the breadth-first stores: the search goes depth-first and still
    proves the same shortest length as an unconstrained run (the beam's first word switched off, or
    it would be proven shortest before either phase has to find a word)."""
    from kruskal_markov.sync import ExactSearchOptions, SyncAutomaton

    no_beam = ExactSearchOptions(use_beam=False)
    rng = np.random.default_rng(seed)
    n = 60
    table = rng.integers(0, n, size=(2, n))
    aut = SyncAutomaton.from_table(table)
    free = shortest_synchronizing_word(aut, time_budget=None, node_budget=10**7, options=no_beam)
    tight = shortest_synchronizing_word(aut, time_budget=None, memory_budget_mb=0.05, node_budget=10**8,
                                        options=no_beam)
    assert free.method == "bidirectional-bfs" and tight.method == "bidirectional-bfs+dfs"
    assert free.exact and tight.exact and free.length == tight.length
    assert len({_apply(table, q, tight.word) for q in range(n)}) == 1


def _apply(table, q, word):
    for a in word:
        q = int(table[a][q])
    return q


def test_sync_node_budget_stop_lower_bound_is_proven():
    from kruskal_markov.sync import SyncAutomaton

    rng = np.random.default_rng(5)
    n = 24
    aut = SyncAutomaton.from_table(rng.integers(0, n, size=(2, n)))
    truth = shortest_synchronizing_word(aut, time_budget=None).length
    for budget in (30, 100, 300, 1000, 3000):
        r = shortest_synchronizing_word(aut, time_budget=None, node_budget=budget)
        assert r.lower_bound is None or r.lower_bound <= truth
        assert r.exact == (r.length == truth and r.lower_bound == truth)


@pytest.mark.parametrize("seed", range(6))
def test_cli_sync_on_a_tray_like_model_is_the_state_plan(capsys, tmp_path, seed):
    """``kruskal sync --model`` (plan search) and the bidirectional subset search agree, both exact."""
    rng = np.random.default_rng(seed)
    n, mats = 24, []
    for _ in range(4):
        walls = rng.choice(n, size=n // 4, replace=False)
        a = np.zeros((n, n))
        for q in range(n):
            if rng.random() < 0.2:
                c = rng.choice(walls, size=2, replace=False)
                a[q, c[0]], a[q, c[1]] = 0.7, 0.3
            else:
                a[q, rng.choice(walls)] = 1.0
        mats.append(sp.csr_matrix(a))
    initial = np.zeros(n)
    initial[rng.choice(n, size=n // 2, replace=False)] = 1.0
    model = TransitionModel(["N", "E", "S", "W"], mats, initial=initial / initial.sum(),
                            partition=np.arange(n) % 6, n_cells=6)
    path = tmp_path / "tray.npz"
    model.save(path)
    assert main(["sync", "--model", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    ref = shortest_synchronizing_word(support_automaton(model), np.flatnonzero(model.initial > 0),
                                      time_budget=None)
    assert out["target"] == "state" and out["method"].startswith("plan-")
    assert out["exact"] == ref.exact and out["length"] == ref.length


@pytest.mark.parametrize("seed", range(6))
def test_pair_distances_against_plain_pair_search(seed):
    """The pair-merging distances behind the state bound and Eppstein's greedy, against a plain
    breadth-first search from every pair (a bound one too high would make the plan search miss)."""
    from kruskal_markov.sync import SyncAutomaton

    rng = np.random.default_rng(seed)
    n, k = 7, 2
    table = rng.integers(0, n, size=(k, n)) if seed else np.array([[1, 2, 3, 0], [0, 1, 2, 0]])
    n = table.shape[1]
    dist, _ = SyncAutomaton.from_table(table).pair_distances()
    for p in range(n):
        for q in range(p + 1, n):
            level, seen, d, found = {(p, q)}, {(p, q)}, 0, -1
            while level and found < 0:
                d += 1
                nxt = set()
                for (x, y) in level:
                    for a in range(k):
                        u, v = int(table[a][x]), int(table[a][y])
                        if u == v:
                            found = d
                        elif (min(u, v), max(u, v)) not in seen:
                            seen.add((min(u, v), max(u, v)))
                            nxt.add((min(u, v), max(u, v)))
                level = nxt
            i = p * n - p * (p + 1) // 2 + (q - p - 1)
            assert dist[i] == found, (p, q)
    if not seed:
        assert dist.tolist() == [4, 6, 1, 3, 5, 2]      # Cerny C_4


def test_cli_plan_grid_cells_from_state_poses(capsys, tmp_path):
    """--grid bins the rest states by their poses on the model's tray; start states (no pose) get
    cells of their own. The answer equals brute force on those cells."""
    from analysis.commands.plan import grid_cells

    rng = np.random.default_rng(4)
    n, k = 8, 2
    model = random_model(rng, n, k, True, 3)
    poses = np.column_stack([rng.uniform(0, 100, n), rng.uniform(0, 80, n), rng.uniform(0, 6.28, n)])
    poses[:2] = np.nan                                   # two start states
    model = TransitionModel(model.actions, model.matrices, initial=model.initial, partition=model.partition,
                            n_cells=model.n_cells, extras={"state_poses": poses},
                            metadata={"grid": {"tray_x_mm": 100.0, "tray_y_mm": 80.0, "nx": 4, "ny": 4,
                                               "ntheta": 4, "symmetry_order": 1, "theta_offset": 0.0}})
    path = tmp_path / "m.npz"
    model.save(path)
    cells = grid_cells(model, "2x1x1")
    assert cells[0] != cells[1] and set(cells[:2]).isdisjoint(cells[2:])
    assert np.array_equal(cells[2:], (poses[2:, 0] >= 50).astype(int))
    truth = brute_length([model], "cell", 7, cells=[cells])
    assert main(["plan", "--model", str(path), "--target", "cell", "--grid", "2x1x1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["length"] == truth and out["exact"] and out["grid"] == "2x1x1"


# ----------------------------------------------------------------------------- answers whole, bounds, budgets
def _cerny4(**kw):
    return model_from_automaton({"states": 4, "actions": {"a": [1, 2, 3, 0], "b": [0, 1, 2, 0]}, **kw})


def test_max_length_below_the_shortest_plan_proves_nothing_beyond_it():
    """Cerny C_4 needs 9 letters; with max_length 5..8 the answer is 'none up to max_length', not a
    proof that no plan exists (the pair-merging bound excludes lengths up to R only). Found by this
    test: the search claimed 'no cell is reachable ... at any length' (exact) for max_length 5."""
    model = _cerny4()
    for L in (5, 6, 8):
        r = shortest_plan(model, "state", max_length=L)
        assert (r.word, r.exact, r.lower_bound, r.method) == (None, False, L + 1, "ida*")
        assert r.notes == (f"no plan of length <= {L}",) and r.witness is None
    rng = np.random.default_rng(21)
    for _ in range(40):
        m = random_model(rng, 5, 2, False, 2)
        for target in ("state", "cell"):
            r = shortest_plan(m, target, max_length=3)
            if r.word is None and r.exact:
                assert brute_length([m], target, 10) is None


def test_a_plan_result_whole():
    r = shortest_plan(_cerny4(), "state")
    assert r.to_dict() == {"word": list("baaabaaab"), "length": 9, "exact": True, "lower_bound": 9, "target": "state",
                           "method": "beam+ida*", "final_cell": 0, "success_probability": 1.0, "upper_bound": 9,
                           "nodes": r.nodes, "witness": None, "notes": [], "threads": 1}
    assert r.nodes > 0
    # the defaults are the documented ones (beam width 64, 64 letters, threshold 0)
    same = shortest_plan(_cerny4(), "state", beam_width=64, max_length=64, threshold=0.0)
    assert same.to_dict() == r.to_dict()
    # IDA* alone (a beam of width 1 finds no plan): method "ida*", work counted
    ida = shortest_plan(_cerny4(), "state", beam_width=1)
    assert (ida.length, ida.exact, ida.method) == (9, True, "ida*") and ida.nodes > r.nodes


def test_state_plan_probability_is_the_mass_in_the_final_state():
    """A stochastic model: the state plan ends in one state of the support automaton; its success
    probability is the model's mass there (here 1, every row's support single after the plan)."""
    mats = [sp.csr_matrix([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.5, 0.5]]), sp.csr_matrix(np.eye(3)[[1, 1, 1]])]
    model = TransitionModel(["a", "b"], mats, partition=[0, 1, 1], n_cells=2)
    r = shortest_plan(model, "state")
    assert r.word == ("b",) and r.final_cell == 1 and r.success_probability == 1.0


def test_cells_given_are_used_by_plans_and_random_words():
    """One cell for every state: the cell target is met by the empty word, by every word of every length."""
    model = _cerny4(partition=[0, 0, 1, 1], cells=2)
    one = [np.zeros(4, dtype=np.int64)]
    assert shortest_plan(model, "cell").length == brute_length([model], "cell", 9)
    r = shortest_plan(model, "cell", cells=one)
    assert (r.word, r.method, r.final_cell, r.success_probability) == ((), "trivial", 0, 1.0)
    rws = random_word_success(model, "cell", max_length=3, words=10, cells=one[0])
    assert rws["probability"] == [1.0, 1.0, 1.0, 1.0]


def test_bounds_that_do_not_fit_the_memory_say_so():
    model = _cerny4(partition=[0, 0, 1, 1], cells=2)
    p = shortest_plan(model, "probability:0.1", memory_budget_mb=1e-6)
    assert p.notes == ("probability bound skipped (memory)", "probability bound computed up to length 0 only (memory)")
    assert p.exact and p.length == brute_length([model], "probability:0.1", 9)
    c = shortest_plan(model, "cell", memory_budget_mb=1e-6)
    assert c.notes == ("cell-reachability bound skipped (memory)",)
    assert c.exact and c.length == brute_length([model], "cell", 9)
    # half the budget for the bound tables: 1e-4 MB (52 bytes) cannot hold the cell masks' 3 levels of
    # 32 bytes, nor two levels of the probability tables (32 bytes each)
    assert shortest_plan(model, "cell", memory_budget_mb=1e-4).notes == ("cell-reachability bound skipped (memory)",)
    assert shortest_plan(model, "probability:0.1", memory_budget_mb=1e-4).notes[0] == "probability bound skipped (memory)"
    roomy = shortest_plan(model, "cell", memory_budget_mb=1.0)
    assert roomy.notes == () and roomy.length == c.length


def test_no_plan_witnesses_whole():
    swap = model_from_automaton({"states": 2, "actions": {"a": [1, 0], "b": [0, 1]}})
    r = shortest_plan(swap, "state")
    assert (r.word, r.exact, r.lower_bound, r.method) == (None, True, None, "cell-reachability")
    assert r.witness == {"kind": "bound", "reason": "no cell is reachable by every start state under some word "
                                                    "(per model), at any length"}
    A = TransitionModel(["a", "b"], [sp.csr_matrix([[1.0, 0], [1.0, 0]]), sp.csr_matrix([[.5, .5], [.5, .5]])])
    B = TransitionModel(["a", "b"], [sp.csr_matrix([[.5, .5], [.5, .5]]), sp.csr_matrix([[1.0, 0], [1.0, 0]])])
    both = shortest_plan([A, B], "state")
    assert both.method == "ida*" and both.witness["kind"] == "exhaustive"
    assert both.witness["reason"].endswith(" meets the target state under every model; every model alone has a "
                                           "plan (lengths [1, 1]), but no one word serves all")


def test_node_budget_stops_the_beam_after_a_whole_level_and_the_passes_at_once():
    """A budget of N images lets the beam finish the level that passes N (a 2-letter plan is found
    with a budget of 2, the first level's size); a budget that stops the depth-first passes reports
    what it proved, with method 'none' when the beam found nothing."""
    model = model_from_automaton({"states": 3, "actions": {"a": [1, 1, 2], "b": [2, 2, 2]}})
    assert brute_length([model], "state", 4) == 1
    two = model_from_automaton({"states": 3, "actions": {"a": [1, 2, 2], "b": [0, 0, 1]}})
    assert brute_length([two], "state", 4) == 2
    r = shortest_plan(two, "state", node_budget=2)
    assert r.length == 2
    assert shortest_plan(two, "state", node_budget=2, max_length=2).length == 2     # the beam goes to max_length
    stop = shortest_plan(_cerny4(), "state", beam_width=1, node_budget=30)
    assert (stop.word, stop.exact, stop.method, stop.lower_bound) == (None, False, "none", 6)
    assert stop.notes == ("budget reached in the depth-6 pass: no plan is shorter than 6",)
    mid = shortest_plan(_cerny4(), "state", node_budget=100)
    assert mid.word is not None and not mid.exact and mid.method == "beam" and mid.lower_bound <= 9


def test_probability_plans_that_need_the_depth_first_passes():
    """beam width 1: the passes start from the root distribution (its values), against brute force."""
    rng = np.random.default_rng(8)
    checked = 0
    for _ in range(12):
        m = random_model(rng, 6, 2, True, 4)
        r = shortest_plan(m, "probability:0.05", beam_width=1, max_length=7)
        if not (r.method.endswith("ida*") and r.word is not None):
            continue
        assert r.exact and r.length == brute_length([m], "probability:0.05", 7)
        checked += 1
    assert checked >= 3


def test_state_plan_passes_its_budgets_and_notes():
    from kruskal_markov.sync import state_plan

    ticks = itertools.count(10 ** 6)
    r = state_plan(_cerny4(), time_budget=2.5, clock=lambda: float(next(ticks)))
    assert not r.exact and r.method.startswith("plan-")
    assert r.notes and r.notes[-1].startswith("budget reached in the depth-")
    full = state_plan(_cerny4(), time_budget=None)
    assert full.exact and full.length == 9 and full.word == [1, 0, 0, 0, 1, 0, 0, 0, 1]


def test_plan_input_messages():
    import re

    model = _cerny4()
    for kwargs, message in (({"models": []}, "at least one model is needed"),
                            ({"node_budget": 0}, "node_budget must be a positive integer, got 0"),
                            ({"beam_width": 1.5}, "beam_width must be a positive integer, got 1.5")):
        models = kwargs.pop("models", model)
        with pytest.raises(ValueError, match="^" + re.escape(message) + "$"):
            shortest_plan(models, "state", **kwargs)
    with pytest.raises(ValueError, match=r"^max_length must be >= 0 and words >= 1 \(integers\)$"):
        random_word_success(model, words=0)


def test_random_word_success_answer_whole():
    """Keys, the default target (cell), and the 95% interval p +- 1.96 sqrt(p (1 - p) / words), clipped."""
    model = _cerny4(partition=[0, 0, 1, 1], cells=2)
    r = random_word_success(model, max_length=8, words=400, seed=2)
    assert set(r) == {"lengths", "probability", "ci95", "words", "target"}
    assert r["target"] == "cell" and r["words"] == 400 and r["lengths"] == list(range(9))
    for p, (lo, hi) in zip(r["probability"], r["ci95"]):
        se = math.sqrt(p * (1 - p) / 400)
        assert lo == pytest.approx(max(0.0, p - 1.96 * se), abs=1e-15)
        assert hi == pytest.approx(min(1.0, p + 1.96 * se), abs=1e-15)
    assert any(0 < p < 1 for p in r["probability"])


def test_plans_share_the_models_support_automaton():
    """One support automaton per model and threshold: a plan caches it under the key sync uses."""
    from kruskal_markov.sync import as_automaton

    model = _cerny4()
    shortest_plan(model, "state")
    cached = model.memo(("support_automaton", 0.0), lambda: pytest.fail("the plan did not cache it"))
    assert as_automaton(model)[0] is cached


def test_targets_whole_messages_and_types():
    import re

    from kruskal_markov.sync import Target
    from kruskal_markov.sync.targets import model_cells

    def refused(fn, message):
        with pytest.raises(ValueError, match="^" + re.escape(message) + "$"):
            fn()

    refused(lambda: Target("probability", 1.0), "probability target: E must lie in [0, 1), got 1.0")
    refused(lambda: Target("cell", 0.1), "target cell takes no epsilon")
    refused(lambda: parse_target(3), "bad plan target 3: expected state, cell or probability:E")
    refused(lambda: parse_target("probability:x"),
            "bad plan target 'probability:x': E in probability:E must be a number in [0, 1)")
    refused(lambda: parse_target("probability:0.1:0.2"),
            "bad plan target 'probability:0.1:0.2': E in probability:E must be a number in [0, 1)")
    t = Target("probability", 0)
    assert type(t.epsilon) is float and t.epsilon == 0.0 and t.threshold == 1.0
    model = _cerny4(partition=[0, 0, 1, 1], cells=2)
    refused(lambda: model_cells(model, parse_target("cell"), [0, 1]), "cells must be 4 integers (one per state), got "
                                                                       "shape (2,)")
    refused(lambda: model_cells(model, parse_target("cell"), [0, -1, 0, 0]), "cells must be non-negative")
    c, n = model_cells(model, parse_target("cell"), np.array([0, 2, 2, 1], dtype=np.int32))
    assert c.dtype == np.int64 and c.tolist() == [0, 2, 2, 1] and n == 3


def test_the_beam_order_counts_cells_beyond_one_per_model_then_states():
    """Set targets: the beam's score of an image is (its distinct (model, cell) pairs minus the
    models, its size), lower first. Cerny C_4 with cells {0, 1} and {2, 3}, alone and twice."""
    from kruskal_markov.sync.plan import _Problem

    model = _cerny4(partition=[0, 0, 1, 1], cells=2)
    one = _Problem([model], parse_target("cell"), None, 0.0)
    two = _Problem([model, model], parse_target("cell"), None, 0.0)
    ones = np.ones(4)
    for states, want in (([0, 1], (0, 2)), ([0, 2], (1, 2)), ([1, 2, 3], (1, 3)), ([3], (0, 1))):
        idx = np.array(states, dtype=np.int32)
        assert one.score(idx, ones[:idx.size]) == want
    # states 0..3 of the first copy, 4..7 of the second: {0, 1} and {5} one cell each
    assert two.score(np.array([0, 1, 5], dtype=np.int32), np.ones(3)) == (0, 3)
    assert two.score(np.array([0, 6, 7], dtype=np.int32), np.ones(3)) == (0, 3)
    assert two.score(np.array([0, 2, 4, 6], dtype=np.int32), np.ones(4)) == (2, 4)


def test_the_beam_searches_up_to_max_length_letters():
    """Cerny C_4 has at most 15 distinct images, so a beam of width 64 is a breadth-first search: with
    max_length 9 its last level finds the 9-letter plan (method 'beam+ida*'), with 8 it finds none."""
    from kruskal_markov.sync.plan import _beam, _Problem

    prob = _Problem([_cerny4()], parse_target("state"), None, 0.0)
    word, _ = _beam(prob, 64, 9, 10 ** 6)
    assert len(word) == 9 and meets(_cerny4(), word, "state")
    assert _beam(prob, 64, 8, 10 ** 6)[0] is None
    assert shortest_plan(_cerny4(), "state", max_length=9).method == "beam+ida*"


def test_a_pass_that_starts_at_the_deadline_exactly_runs():
    """The time budget is past only after its deadline. On a clock ticking one second per reading
    (no reading between the start and the first pass, beam width 1 finding nothing on Cerny C_4), a
    budget of 1 s runs the first pass (the check before it reads the deadline exactly) and stops
    before the second; a budget of 0.5 s stops before the first: the proven bound is one more."""

    def run(budget):
        ticks = itertools.count(10 ** 6)
        return shortest_plan(_cerny4(), "state", beam_width=1, time_budget=budget, clock=lambda: float(next(ticks)))

    first, none = run(1.0), run(0.5)
    assert (first.word, first.exact, none.word, none.exact) == (None, False, None, False)
    assert 1 <= none.lower_bound < 9 and first.lower_bound == none.lower_bound + 1
    assert first.notes[-1] == f"budget reached in the depth-{first.lower_bound} pass: no plan is shorter than " \
                              f"{first.lower_bound}"


def test_the_probability_bound_is_computed_up_to_the_beam_plans_length():
    """The bound tables are needed only below the beam's plan (5 letters here, shortest by brute
    force): half the memory budget holding 5, 6 or 20 levels of 4 states x 2 cells x 4 bytes
    gives no note; holding 4 or 3, the note says how far they go."""
    model = _cerny4(partition=[0, 0, 1, 1], cells=2)
    assert brute_length([model], "probability:0.1", 9) == 5
    for levels in (5, 6, 20, 4, 3):
        r = shortest_plan(model, "probability:0.1", memory_budget_mb=4 * 2 * 4 * (levels + 1) * 2 / 2 ** 20)
        assert (r.length, r.exact, r.upper_bound) == (5, True, 5)
        assert r.notes == (() if levels >= 5 else (f"probability bound computed up to length {levels} only (memory)",))


def test_the_default_beam_is_64_wide_on_a_model_where_the_width_shows():
    """A 37-state random automaton whose beam levels exceed 64 images: the default search is the
    one with ``beam_width=64`` (the same work counted), not the one with 65."""
    rng = np.random.default_rng(0)
    model = random_model(rng, int(rng.integers(20, 40)), 3, False, 4)
    assert model.n_states == 37
    default, w64, w65 = (shortest_plan(model, "state", **kw) for kw in ({}, {"beam_width": 64}, {"beam_width": 65}))
    assert w64.nodes != w65.nodes and w64.length == w65.length
    assert (default.word, default.length, default.method, default.nodes) == (w64.word, w64.length, w64.method,
                                                                             w64.nodes)


def test_the_transposition_table_is_full_when_its_state_slots_are():
    """The passes record each distinct image they expand (depths 1..D-1 of the depth-D pass: every
    image within D-1 letters when nothing prunes) whole: with a tiny budget the table's floors,
    1,024 entries and 1,024 state slots, are all it has. A 28-state automaton (no cell bound:
    it does not fit) has under 1,024 distinct images within 9 letters, so only the state slots
    fill: the note names exactly the passes whose images (a plain breadth-first search) hold more
    than 1,024 states together (one had no room), before the plan's own pass."""
    model = random_model(np.random.default_rng(1), 28, 2, False, 3)
    table = [np.asarray(m.indices) for m in model.matrices]
    r = shortest_plan(model, "cell", beam_width=1, memory_budget_mb=1e-6, max_length=12)
    assert r.exact and r.length == 10 and r.method == "ida*" and meets(model, [model.actions.index(a) for a in r.word],
                                                                         "cell")
    seen, level, sizes = set(), {frozenset(range(28))}, []
    for _ in range(r.length - 2):                     # images within 1..L-2 letters (the passes D <= L-1)
        level = {frozenset(int(t[q]) for q in s) for s in level for t in table} - seen
        seen |= level
        sizes.append((len(seen), sum(len(s) for s in seen)))
    assert all(count < 1024 for count, _ in sizes)
    full = {d + 2 for d, (_, states) in enumerate(sizes) if states > 1024}
    noted = {int(n.split("depth-")[1].split()[0]) for n in r.notes if n.startswith("transposition table full")}
    assert full and noted - {r.length} == full


def test_the_transposition_table_takes_a_quarter_of_the_budget_in_state_slots():
    """Half the memory budget for the transposition table, half of that for its state slots (4
    bytes each, set targets): 0.08 MB give 5,242 slots, and the 1,024-entry floor. A 2,000-state
    automaton (its cell bound of 16,000-byte levels does not fit the other half): the depth-D pass
    records the images within D - 1 letters, so the note names the passes whose images (a plain
    breadth-first search) hold more than 5,242 states together (one had no room)."""
    n = 2000
    model = random_model(np.random.default_rng(0), n, 2, False, 3)
    table = [np.asarray(m.indices) for m in model.matrices]
    r = shortest_plan(model, "cell", beam_width=1, memory_budget_mb=0.08, max_length=4)
    assert (r.word, r.exact, r.lower_bound) == (None, False, 5)
    slots = int(0.08 * 2 ** 20 / 2 / 2 / 4)
    assert slots == 5242
    seen, level, states = set(), {frozenset(range(n))}, [0]
    for _ in range(3):
        level = {frozenset(int(t[q]) for q in s) for s in level for t in table} - seen
        seen |= level
        states.append(sum(len(s) for s in seen))
    assert len(seen) < 1024
    full = [D for D in range(1, 5) if states[D - 1] > slots]
    assert 1 < len(full) < 4, states                  # the boundary falls between the passes
    assert r.notes == ("cell-reachability bound skipped (memory)",
                       *(f"transposition table full in the depth-{D} pass (depth-first without it)" for D in full),
                       "no plan of length <= 4")
