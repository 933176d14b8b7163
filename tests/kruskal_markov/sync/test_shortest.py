"""kruskal_markov.sync.shortest_word: one entry point, one result type, one rule choosing the search."""
from __future__ import annotations

import numpy as np
import pytest

from kruskal_markov.automaton_json import model_from_automaton
from kruskal_markov.generators import random_model
from kruskal_markov.sync import (
    PlanResult,
    choose_method,
    is_synchronizing_word,
    shortest_plan,
    shortest_synchronizing_word,
    shortest_word,
    support_automaton,
)

CERNY4 = {"states": 4, "actions": {"a": [1, 2, 3, 0], "b": [0, 1, 2, 0]}}


@pytest.fixture(scope="module")
def tray_like():
    """A stochastic model with a report partition (what a build gives)."""
    return random_model(14, 3, 0.25, 4, False, "uniform", seed=np.random.default_rng(7))


def test_both_searches_give_a_plan_result_with_names():
    cerny = model_from_automaton(CERNY4)
    by_subsets = shortest_word(cerny, method="subsets")
    by_plan = shortest_word(cerny, method="plan")
    for r in (by_subsets, by_plan):
        assert isinstance(r, PlanResult) and r.target == "state"
        assert r.length == 9 and r.exact and all(a in ("a", "b") for a in r.word)
    aut = support_automaton(cerny, 0.0)
    assert is_synchronizing_word(aut, [cerny.actions.index(a) for a in by_subsets.word])
    # the subset search's answer, named: the same word, its nodes and its greedy bound carried over
    raw = shortest_synchronizing_word(aut)
    assert list(by_subsets.word) == [cerny.actions[a] for a in raw.word]
    assert by_subsets.greedy_length == raw.greedy_length and by_subsets.sync_dict()["states_explored"] > 0
    assert shortest_word(aut).word == by_subsets.word          # an automaton is a source too


def test_the_rule_choosing_the_search(tray_like):
    cerny = model_from_automaton(CERNY4)
    assert choose_method(cerny) == "subsets"                   # deterministic
    assert choose_method(support_automaton(cerny, 0.0)) == "subsets"
    assert choose_method(cerny, "cell") == "plan"              # cells need the plan search
    assert tray_like.partition is not None and not support_automaton(tray_like, 0.0).deterministic
    assert choose_method(tray_like) == "plan"
    assert choose_method(tray_like, start="all") == "subsets"
    auto = shortest_word(tray_like, node_budget=200_000)
    assert auto.method.startswith("plan-")
    direct = shortest_plan(tray_like, "state", node_budget=200_000)
    assert (auto.length, auto.exact) == (direct.length, direct.exact)


def test_bad_requests_are_errors():
    cerny = model_from_automaton(CERNY4)
    with pytest.raises(ValueError, match="method"):
        shortest_word(cerny, method="fastest")
    with pytest.raises(ValueError, match="state"):
        shortest_word(cerny, "cell", method="subsets")
    with pytest.raises(ValueError, match="TransitionModel"):
        shortest_word(support_automaton(cerny, 0.0), method="plan")
