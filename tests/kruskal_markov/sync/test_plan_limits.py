"""The plan search's argument limits, its duration, and the random-word success intervals."""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from kruskal_markov.generators import cerny_model
from kruskal_markov.sync import random_word_success, shortest_plan, state_plan


@pytest.mark.parametrize("time_budget", [0, 0.0, -1.0])
def test_a_time_budget_must_be_positive(time_budget):
    with pytest.raises(ValueError) as err:
        shortest_plan(cerny_model(4), "state", time_budget=time_budget)
    assert str(err.value) == "memory and time budgets must be positive"


def _ticking():
    """A clock reading 0, 1, 2, ... seconds, one second per reading."""
    return itertools.count().__next__


def test_state_plan_reports_the_searchs_duration():
    """The same search on two fresh clocks that tick once per reading: the SyncResult's seconds are
    the plan's."""
    model = cerny_model(4)
    plan = shortest_plan(model, "state", time_budget=1e9, clock=_ticking())
    res = state_plan(model, time_budget=1e9, clock=_ticking())
    assert plan.seconds > 0 and res.seconds == plan.seconds


def test_random_word_success_at_length_zero_is_the_start():
    """``max_length=0`` is allowed: only the empty word, which meets the state target of C_4's uniform
    start never."""
    r = random_word_success(cerny_model(4), "state", max_length=0, words=10)
    assert r["lengths"] == [0] and r["probability"] == [0.0] and r["ci95"] == [[0.0, 0.0]]


def test_random_word_success_intervals_are_clipped_to_probabilities():
    """Normal intervals p +- 1.96 sqrt(p (1 - p) / words), clipped to [0, 1]; with 20 words some
    length has p high enough that the unclipped upper end passes 1."""
    words = 20
    r = random_word_success(cerny_model(4), "state", max_length=150, words=words, seed=3)
    p = np.asarray(r["probability"])
    se = np.sqrt(p * (1 - p) / words)
    assert np.any(p + 1.96 * se > 1) and np.any(p - 1.96 * se < 0)
    for (lo, hi), pl, s in zip(r["ci95"], p, se):
        assert lo == pytest.approx(max(0.0, pl - 1.96 * s), abs=1e-15)
        assert hi == pytest.approx(min(1.0, pl + 1.96 * s), abs=1e-15)
        assert 0.0 <= lo <= hi <= 1.0 and not math.isnan(hi)


def test_a_state_plans_final_cell_is_the_cell_of_its_final_state():
    """Cerny C_4 with cells {1, 3} -> 0 and {0, 2} -> 1 (no state is its own cell's number): the state
    plan ends every start in one state with probability 1, and its final cell is that state's cell
    (found by running the word by hand), not the state's index."""
    from kruskal_markov.automaton_json import model_from_automaton
    from kruskal_markov.generators import cerny_table

    t = cerny_table(4)
    model = model_from_automaton({"states": 4, "actions": {"a": t[0].tolist(), "b": t[1].tolist()},
                                  "partition": [1, 0, 1, 0]})
    r = shortest_plan(model, "state")
    states = set(range(4))
    for name in r.word:
        states = {int(t["ab".index(name)][q]) for q in states}
    (final,) = states
    assert r.final_cell == [1, 0, 1, 0][final] and r.success_probability == pytest.approx(1.0, abs=1e-12)


def test_a_state_plans_success_is_its_final_states_probability():
    """C_4 whose every row leaks 1% uniformly, searched on its support above 0.05 (C_4 itself): the
    plan's success probability is the final distribution's largest state probability (propagated by
    hand), and its final cell that state's cell (cells numbered so that no state is its own cell's
    number), not the state's index."""
    from kruskal_markov.generators import cerny_table
    from kruskal_markov.model import TransitionModel

    t = cerny_table(4)
    mats = [0.99 * np.eye(4)[t[a]] + 0.01 / 4 for a in range(2)]
    partition = [1, 0, 1, 0]
    model = TransitionModel(["a", "b"], mats, partition=partition)
    r = shortest_plan(model, "state", threshold=0.05)
    p = np.full(4, 0.25)
    for name in r.word:
        p = mats["ab".index(name)].T @ p
    q = int(np.argmax(p))
    assert r.final_cell == partition[q]
    assert r.success_probability == pytest.approx(p[q], abs=1e-12) and p[q] < 0.99


def test_the_default_target_is_cell():
    """``shortest_plan(model)`` plans for the ``cell`` target (C_4 with cells {1, 3} and {0, 2})."""
    from kruskal_markov.automaton_json import model_from_automaton
    from kruskal_markov.generators import cerny_table

    t = cerny_table(4)
    model = model_from_automaton({"states": 4, "actions": {"a": t[0].tolist(), "b": t[1].tolist()},
                                  "partition": [1, 0, 1, 0]})
    default, cell = shortest_plan(model), shortest_plan(model, "cell")
    assert default.target == "cell" and default.word == cell.word and default.exact


def test_models_with_different_actions_are_refused_by_name():
    from kruskal_markov.model import TransitionModel

    one = TransitionModel(["a", "b"], [np.eye(2), np.eye(2)])
    other = TransitionModel(["a", "c"], [np.eye(2), np.eye(2)])
    with pytest.raises(ValueError) as err:
        shortest_plan([one, other], "state")
    assert str(err.value) == "models disagree on their actions: ['a', 'b'] and ['a', 'c']"


def test_a_one_letter_search_that_finds_nothing_says_so():
    """``max_length=1`` on C_4 (its plan has 9 letters): no plan, not exact, the lower bound 2 and
    the note, not an error."""
    r = shortest_plan(cerny_model(4), "state", max_length=1)
    assert (r.word, r.exact, r.lower_bound, r.method) == (None, False, 2, "ida*")
    assert r.notes == ("no plan of length <= 1",)


def test_a_plans_sync_keys_are_the_sync_results():
    """``PlanResult.sync_dict`` (what ``kruskal sync`` prints for a plan) has the keys and values of
    ``SyncResult.as_dict``."""
    from kruskal_markov.sync.plan import PlanResult

    model = cerny_model(4)
    res = state_plan(model, time_budget=None)
    assert PlanResult.from_sync(res, model.actions).sync_dict() == res.as_dict(model.actions)


def _two_state(a_rows, b_rows):
    import scipy.sparse as sp

    from kruskal_markov.model import TransitionModel

    return TransitionModel(["a", "b"], [sp.csr_matrix(a_rows), sp.csr_matrix(b_rows)])


def test_an_exhaustive_no_counts_the_distinct_images_and_names_the_model_without_a_plan():
    """A merges both states with ``a``; F sends one state to 0 and the other to {0, 1} under either
    letter, so F's image is {0, 1} after every word (no plan, and the cell masks cannot tell). F alone:
    one distinct image after a letter. A and F together: two, (A{0}, F{0,1}) after ``a`` and
    (A{0,1}, F{0,1}) after ``b``; the witness says model 1 alone has no plan."""
    A = _two_state([[1.0, 0], [1.0, 0]], [[.5, .5], [.5, .5]])
    F = _two_state([[1.0, 0], [.5, .5]], [[.5, .5], [1.0, 0]])
    alone = shortest_plan(F, "state")
    assert (alone.word, alone.exact, alone.witness["kind"]) == (None, True, "exhaustive")
    assert alone.witness["reason"] == ("every reachable image was expanded (1 distinct) and none meets the "
                                       "target state")
    both = shortest_plan([A, F], "state")
    assert (both.word, both.exact) == (None, True) and both.witness["per_model_lengths"] == [1, None]
    assert both.witness["reason"] == ("every reachable image was expanded (2 distinct) and none meets the "
                                      "target state under every model; model(s) [1] alone have no plan")


def test_a_probability_targets_state_slots_take_12_bytes():
    """Probability targets pool each state's index and its quantized value, 12 bytes a state slot: a
    quarter of 0.08 MB gives 1,747 slots, fewer than the 2,000 states of one image, so every pass that
    records images finds no room from the second on (the first records none: not full). At 4 bytes a
    slot (5,242) the depth-2 pass would fit."""
    from tests.kruskal_markov.sync.test_plan import random_model

    n = 2000
    model = random_model(np.random.default_rng(0), n, 2, False, 3)
    r = shortest_plan(model, "probability:0.5", beam_width=1, memory_budget_mb=0.08, max_length=4)
    slots = int(0.08 * 2 ** 20 / 2 / 2 / 12)
    assert slots == 1747 < n
    assert (r.word, r.exact, r.lower_bound, r.method) == (None, False, 5, "ida*")
    noted = [int(x.split("depth-")[1].split()[0]) for x in r.notes if x.startswith("transposition table full")]
    assert noted == [2, 3, 4] and r.notes[-1] == "no plan of length <= 4"


def test_the_beam_tells_distributions_with_one_support_apart():
    """Probability target 0.9 in state 0 from (1/2, 1/2): ``a`` always gives (1/2, 1/2), ``b`` sends
    state 0 to 0 and state 1 to (0.6, 0.4), so ``b`` gives (0.8, 0.2) and ``bb`` (0.92, 0.08). The two
    one-letter images share their support; the beam keeps both (its key holds the values), so the beam
    finds ``bb`` and the bound proves it shortest, with no IDA* pass."""
    import scipy.sparse as sp

    from kruskal_markov.model import TransitionModel

    model = TransitionModel(["a", "b"], [sp.csr_matrix([[.5, .5], [.5, .5]]), sp.csr_matrix([[1.0, 0], [.6, .4]])],
                            partition=[0, 1], n_cells=2)
    r = shortest_plan(model, "probability:0.1")
    assert (r.word, r.exact, r.method, r.final_cell) == (("b", "b"), True, "beam+bound", 0)
    assert r.success_probability == pytest.approx(0.92, abs=1e-12)
