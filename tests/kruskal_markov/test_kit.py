"""kruskal_markov.kit: a kit's answers against the single part's (one compartment: identical) and
against independent brute force on tiny automata (product distributions, product subset chains,
breadth-first search over words)."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from kruskal_markov.automaton_json import model_from_automaton
from kruskal_markov.convergence import monte_carlo_entropy_tilts, monte_carlo_sync_length
from kruskal_markov.ensemble import run_ensemble
from kruskal_markov.entropy import entropy_trajectory
from kruskal_markov.generators import random_model
from kruskal_markov.kit import kit_ensemble, kit_entropy_tilts, kit_plan, kit_sync_lengths, wilson_interval
from kruskal_markov.sync import start_set, support_automaton

#: two small synchronizing automata over the letters a, b (Cerny's C4, and a 3-state one)
CERNY4 = {"states": 4, "actions": {"a": [1, 2, 3, 0], "b": [0, 1, 2, 0]}}
THREE = {"states": 3, "actions": {"a": [1, 1, 2], "b": [2, 0, 2]}}


@pytest.fixture(scope="module")
def stochastic():
    """A sparse random model with a partition: a stochastic support automaton."""
    return random_model(12, 3, 0.15, 4, False, "random", seed=np.random.default_rng(5), floor=0.2)


def _det(spec):
    return model_from_automaton(spec)


def test_one_compartment_kit_is_the_single_part(stochastic):
    for m in (_det(CERNY4), stochastic):
        ens, kit = run_ensemble(m, 50, 12, seed=3, epsilon=1e-3), kit_ensemble([m], 50, 12, seed=3, epsilon=1e-3)
        np.testing.assert_array_equal(kit["mean"], ens.mean)
        np.testing.assert_array_equal(kit["q25"], ens.q25)
        np.testing.assert_array_equal(kit["convergence_steps"], ens.convergence_steps)
        np.testing.assert_array_equal(kit["best_sequence"], ens.best_sequence)
        assert kit["converged"] == ens.converged
        assert kit_entropy_tilts([m], 1e-3, runs=60, seed=4, max_steps=40) == \
            monte_carlo_entropy_tilts(m, 1e-3, runs=60, seed=4, max_steps=40)
        aut = support_automaton(m)
        s = start_set(m, m.is_deterministic())
        assert kit_sync_lengths([aut], [s], runs=60, seed=7, max_steps=300) == \
            monte_carlo_sync_length(aut, s, runs=60, seed=7, max_steps=300)
        r1, rk = kit_plan([m], "cell")["common"], None
        from kruskal_markov.sync.plan import shortest_plan
        rk = shortest_plan(m, "cell")
        assert (r1.word, r1.length, r1.exact, r1.lower_bound) == (rk.word, rk.length, rk.exact, rk.lower_bound)


def test_two_identical_compartments_have_the_single_plan(stochastic):
    for m in (_det(CERNY4), stochastic):
        r = kit_plan([m, m], "cell")
        own = r["own"][0]
        assert r["common"].word == own.word and r["common"].exact == own.exact
        if own.word is not None:
            assert r["joint_success"] == pytest.approx(own.success_probability ** 2)


def _images(spec, word):
    """The image of all states under ``word`` (deterministic automaton spec)."""
    s = set(range(spec["states"]))
    for a in word:
        s = {spec["actions"][a][q] for q in s}
    return s


def test_common_plan_is_the_shortest_word_found_by_brute_force():
    r = kit_plan([_det(CERNY4), _det(THREE)], "state")
    letters = list(CERNY4["actions"])
    shortest = next(n for n in range(1, 14) for w in itertools.product(letters, repeat=n)
                    if len(_images(CERNY4, w)) == 1 and len(_images(THREE, w)) == 1)
    assert r["common"].exact and r["common"].length == shortest
    assert len(_images(CERNY4, r["common"].word)) == 1 and len(_images(THREE, r["common"].word)) == 1
    assert r["common"].length >= max(p.length for p in r["own"])


def test_kit_entropy_is_the_entropy_of_the_product_distribution(stochastic):
    other = random_model(7, 3, 0.3, 3, False, "random", seed=np.random.default_rng(9), floor=0.2)
    kit = kit_ensemble([stochastic, other], 5, 6, seed=2)
    for seq, h in zip(kit["sequences"], kit["entropy"]):
        names = [stochastic.actions[a] for a in seq]
        for t in (0, 3, 6):
            pa = _cell_distribution(stochastic, names[:t])
            pb = _cell_distribution(other, names[:t])
            joint = np.outer(pa, pb).ravel()
            joint = joint[joint > 0]
            assert h[t] == pytest.approx(float(-(joint * np.log2(joint)).sum()), abs=1e-9)


def _cell_distribution(model, word):
    p = np.asarray(model.initial, dtype=float)
    for a in word:
        p = model.matrices[model.actions.index(a)].T @ p
    return np.bincount(model.partition, weights=p, minlength=model.n_cells)


def test_kit_sync_time_matches_the_exact_product_chain():
    """E[T] of the pair (C4, THREE) under uniform random letters, solved exactly on the chain of
    subset pairs, lies in the Monte Carlo interval of the shared-sequence sampling; it exceeds both
    parts' own expectations (the kit is not the max of the means)."""
    specs = (CERNY4, THREE)
    start = tuple(frozenset(range(s["states"])) for s in specs)
    index, order = {start: 0}, [start]
    i = 0
    while i < len(order):
        for a in ("a", "b"):
            nxt = tuple(frozenset(s["actions"][a][q] for q in sub) for s, sub in zip(specs, order[i]))
            if nxt not in index:
                index[nxt] = len(order)
                order.append(nxt)
        i += 1
    n = len(order)
    A, b = np.eye(n), np.ones(n)
    for j, node in enumerate(order):
        if all(len(sub) == 1 for sub in node):
            b[j] = 0.0
            continue
        for a in ("a", "b"):
            nxt = tuple(frozenset(s["actions"][a][q] for q in sub) for s, sub in zip(specs, node))
            A[j, index[nxt]] -= 0.5
    exact = float(np.linalg.solve(A, b)[0])
    auts = [support_automaton(_det(s)) for s in specs]
    mc = kit_sync_lengths(auts, [np.arange(s["states"]) for s in specs], runs=4000, seed=1, max_steps=10_000)
    assert mc["ci95"][0] <= exact <= mc["ci95"][1]
    own = [monte_carlo_sync_length(a, np.arange(s["states"]), runs=4000, seed=1)["mean"] for a, s in zip(auts, specs)]
    assert exact > max(own)


def test_kit_entropy_tilts_wait_for_every_compartment_at_once():
    """Deterministic automata (entropy on the states): the kit converges exactly when both images are
    singletons, i.e. at the max of the parts' first times, run by run on the same letters."""
    a, b = _det(CERNY4), _det(THREE)
    kit = kit_entropy_tilts([a, b], 1e-9, runs=300, seed=11, max_steps=200)
    rng = np.random.default_rng(11)
    letters = rng.choice(2, size=(300, 200), p=np.full(2, 0.5))
    times = []
    for row in letters:
        word = [a.actions[x] for x in row]
        ha = entropy_trajectory(a, word).entropy_bits
        hb = entropy_trajectory(b, word).entropy_bits
        times.append(int(np.flatnonzero((ha[1:] <= 1e-9) & (hb[1:] <= 1e-9))[0]) + 1)
    assert kit["censored"] == 0 and kit["mean"] == pytest.approx(np.mean(times))


def test_wilson_interval_brackets_the_share():
    lo, hi = wilson_interval(0, 20)
    assert lo == 0.0 and 0.1 < hi < 0.2
    assert wilson_interval(3, 0) == [None, None]
