"""Tests of kruskal_markov.closed_classes: closed classes and what they imply for the entropy."""
from __future__ import annotations

import networkx as nx
import numpy as np
import pytest

from kruskal_markov.automaton_json import model_from_automaton
from kruskal_markov.closed_classes import analyze_structure, closed_classes, support_graph
from kruskal_markov.ensemble import run_ensemble
from kruskal_markov.generators import random_model


def random_sparse_model(rng, n, k, density):
    return random_model(n, k, density, initial="uniform", seed=rng, floor=0.5)


@pytest.mark.parametrize("seed", range(15))
def test_closed_classes_match_networkx(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 40))
    model = random_sparse_model(rng, n, int(rng.integers(1, 4)), float(rng.uniform(0, 0.1)))
    g = support_graph(model)
    dense = np.zeros((n, n), dtype=bool)
    for m in model.matrices:
        dense |= m.toarray() > 0
    np.testing.assert_array_equal(g.toarray() > 0, dense)
    ours = sorted(tuple(c.tolist()) for c in closed_classes(g))
    ref = sorted(tuple(sorted(c)) for c in nx.attracting_components(nx.DiGraph(dense)))
    assert ours == ref


def test_two_absorbing_states_exclude_zero_entropy():
    # states 0 and 3 absorbing; 1, 2 transient
    model = model_from_automaton(
        {"states": 4, "actions": {"a": [0, 0, 3, 3], "b": [0, 2, 1, 3]}})
    rep = analyze_structure(model)
    assert [c.tolist() for c in rep.closed_classes] == [[0], [3]]
    assert rep.reachable_classes == [0, 1] and rep.holding_classes == [0, 1]
    assert rep.class_mass == [0.25, 0.25]
    assert rep.zero_entropy_excluded and rep.zero_cell_entropy_excluded
    assert "class 0 = {0}" in rep.message and "class 1 = {3}" in rep.message
    assert "cannot reach zero" in rep.message
    # the consequence, checked by brute force over every sequence of length 6
    res = run_ensemble(model, 2000, 6, seed=0)
    assert res.converged == 0 and min(res.best_entropy) >= 1.0 - 1e-12


def test_reachable_but_not_holding_classes_allow_zero():
    # from state 0 (the only initial state) action a goes to 1, b to 2; both absorbing
    model = model_from_automaton(
        {"states": 3, "actions": {"a": [1, 1, 2], "b": [2, 1, 2]}, "initial": [1, 0, 0]})
    rep = analyze_structure(model)
    assert rep.reachable_classes == [0, 1] and rep.holding_classes == []
    assert not rep.zero_entropy_excluded
    assert "not excluded" in rep.message


def test_partition_sharing_a_cell():
    model = model_from_automaton(
        {"states": 4, "actions": {"a": [0, 0, 3, 3]}, "partition": [0, 1, 1, 0], "cells": 2})
    rep = analyze_structure(model)
    assert rep.zero_entropy_excluded and not rep.zero_cell_entropy_excluded
    assert "could" in rep.message
    res = run_ensemble(model, 1, 1, seed=0, keep_entropy=True)
    assert res.entropy[0, 1] == 0.0  # the report-grid entropy does reach zero
    separate = model_from_automaton(
        {"states": 4, "actions": {"a": [0, 0, 3, 3]}, "partition": [0, 1, 1, 1], "cells": 2})
    assert analyze_structure(separate).zero_cell_entropy_excluded


def test_single_class_synchronizing():
    n = 5
    model = model_from_automaton(
        {"states": n, "actions": {"a": [(i + 1) % n for i in range(n)], "b": [1] + list(range(1, n))}})
    rep = analyze_structure(model)
    assert len(rep.closed_classes) == 1 and rep.closed_classes[0].tolist() == list(range(n))
    assert not rep.zero_entropy_excluded
    d = rep.to_dict()
    assert d["closed_classes"][0]["size"] == n and d["zero_entropy_excluded"] is False


def test_analyze_with_initial_override():
    model = model_from_automaton({"states": 4, "actions": {"a": [0, 0, 3, 3]}})
    rep = analyze_structure(model, initial=[0, 1, 0, 0])
    assert rep.holding_classes == [] and rep.reachable_classes == [0]
    with pytest.raises(ValueError, match="3 entries"):
        analyze_structure(model, initial=[1, 0, 0])


# ----------------------------------------------------------------------------- the report's text and summary
def test_describe_and_to_dict():
    from kruskal_markov.closed_classes import _describe

    assert _describe(np.array([3])) == "{3} (1 state)"
    assert _describe(np.array([1, 2])) == "{1, 2} (2 states)"
    assert _describe(np.arange(5)) == "{0, 1, 2, 3, 4} (5 states)"
    assert _describe(np.arange(6)) == "{0, 1, 2, 3, 4, ...} (6 states)"
    # two absorbing states, each holding half the mass; a 3-state cycle reachable from nothing
    model = model_from_automaton({"states": 5, "actions": {"a": [0, 1, 3, 4, 2]}})
    rep = analyze_structure(model, initial=[0.5, 0.5, 0, 0, 0])
    d = rep.to_dict(max_states=3)
    assert set(d) == {"closed_classes", "reachable_classes", "holding_classes", "class_mass",
                      "zero_entropy_excluded", "zero_cell_entropy_excluded", "message"}
    assert d["closed_classes"][2] == {"size": 3, "states": [2, 3, 4], "truncated": False}
    assert rep.to_dict(max_states=2)["closed_classes"][2] == {"size": 3, "states": [2, 3], "truncated": True}
    assert d["holding_classes"] == [0, 1] and d["class_mass"] == [0.5, 0.5] and d["zero_entropy_excluded"]
    assert rep.message == ("2 closed classes hold initial mass (class 0 holds mass 0.5; class 1 holds mass 0.5); "
                           "mass never leaves a closed class, so the entropy on the states cannot reach zero. "
                           "Reachable closed classes: class 0 = {0} (1 state); class 1 = {1} (1 state).")


def test_messages_with_a_partition_and_without_held_mass():
    base = {"states": 3, "actions": {"a": [0, 1, 0], "b": [0, 1, 1]}}
    shared = model_from_automaton({**base, "partition": [0, 0, 1]})
    rep = analyze_structure(shared, initial=[0.5, 0.5, 0.0])
    assert rep.zero_entropy_excluded and not rep.zero_cell_entropy_excluded
    assert ", but the report-grid entropy could (the classes share a report cell). Reachable closed classes: " \
        in rep.message
    apart = model_from_automaton({**base, "partition": [0, 1, 1]})
    rep = analyze_structure(apart, initial=[0.5, 0.5, 0.0])
    assert rep.zero_cell_entropy_excluded
    assert " and neither can the report-grid entropy (the classes share no report cell). " in rep.message
    rep = analyze_structure(model_from_automaton(base), initial=[0, 0, 1.0])
    assert rep.message.startswith("2 closed classes are reachable (class 0 = {0} (1 state); class 1 = {1} "
                                  "(1 state)) but at most one holds initial mass")


# ----------------------------------------------------------------------------- values the reports rest on
def test_support_graph_is_an_int8_zero_one_pattern():
    """One byte per edge, every entry 1 however many actions share the edge (memory: the support
    graph of a 100,000-state model is built whole)."""
    model = model_from_automaton({"states": 3, "actions": {"a": [1, 1, 2], "b": [1, 2, 2], "c": [1, 1, 2]}})
    g = support_graph(model)
    assert g.dtype == np.int8 and np.all(g.data == 1)
    assert g.toarray().tolist() == [[0, 1, 0], [0, 1, 1], [0, 0, 1]]


def test_closed_classes_are_listed_by_smallest_state_on_a_large_graph():
    """Three closed classes of 1,000 interleaved states each (cycles over the states = r mod 3)
    and 1,000 transient states: listed by their smallest state, each sorted (a large graph, where
    an unstable sort of the labels would scramble the members)."""
    n = 4000
    nxt = np.empty(n, dtype=np.int64)
    for r in range(3):
        members = np.arange(r, 3000, 3)[::-1]                         # a cycle through the class
        nxt[members] = np.roll(members, 1)
    nxt[3000:] = np.random.default_rng(2).integers(0, 3000, 1000)    # transient: into some class
    model = model_from_automaton({"states": n, "actions": {"a": nxt.tolist()}})
    classes = closed_classes(support_graph(model))
    assert [c.tolist() for c in classes] == [list(range(r, 3000, 3)) for r in range(3)]


def test_reachability_follows_the_edges_forward_only():
    """State 3 leads into the start's class and into another closed class; the start (state 0)
    cannot reach state 3, so that other class is not reachable from it."""
    model = model_from_automaton({"states": 4, "actions": {"a": [1, 1, 2, 0], "b": [0, 1, 2, 2]}})
    rep = analyze_structure(model, initial=[1, 0, 0, 0])
    assert [c.tolist() for c in rep.closed_classes] == [[1], [2]]
    assert rep.reachable_classes == [0] and rep.holding_classes == []


def test_to_dict_lists_twenty_states_by_default():
    n = 21
    model = model_from_automaton({"states": n, "actions": {"a": [(i + 1) % n for i in range(n)]}})
    d = analyze_structure(model).to_dict()
    assert d["closed_classes"] == [{"size": 21, "states": list(range(20)), "truncated": True}]


def test_whole_messages_of_the_three_cases():
    model = model_from_automaton({"states": 3, "actions": {"a": [0, 1, 0], "b": [0, 1, 1]},
                                  "partition": [0, 1, 1]})
    rep = analyze_structure(model, initial=[0.5, 0.5, 0.0])
    assert rep.message == ("2 closed classes hold initial mass (class 0 holds mass 0.5; class 1 holds mass 0.5); "
                           "mass never leaves a closed class, so the entropy on the states cannot reach zero "
                           "and neither can the report-grid entropy (the classes share no report cell). "
                           "Reachable closed classes: class 0 = {0} (1 state); class 1 = {1} (1 state).")
    one = model_from_automaton({"states": 2, "actions": {"a": [1, 0], "b": [0, 0]}})
    assert analyze_structure(one).message == (
        "one closed class is reachable (class 0 = {0, 1} (2 states)): zero entropy is not excluded by the "
        "class structure (whether a sequence reaches it is a synchronization question).")
