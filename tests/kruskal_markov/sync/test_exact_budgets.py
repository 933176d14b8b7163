"""The exact reset-word search's budgets, read on the clock and counted in sets as documented
(:func:`~kruskal_markov.sync.exact.shortest_synchronizing_word`, ``ExactSearchOptions.fast_nodes``):
the greedy word's 40% of the time, the exact search on the given clock, the fast path within its
sets, and the node budget that bounds the beam too."""
from __future__ import annotations

import itertools

import pytest

from kruskal_markov.generators import cerny_table as cerny
from kruskal_markov.sync import (
    ExactSearchOptions,
    SyncAutomaton,
    greedy_synchronizing_word,
    shortest_synchronizing_word,
    support_automaton,
)
from tests.kruskal_markov.sync.test_searches import model_from_support


def _ticking(start=10.0 ** 6):
    """A clock far from zero that advances one second per reading."""
    clock = itertools.count(start)
    return lambda: float(next(clock))


def _events(**kw):
    """Options that record the search's ``observe`` events, and the list they go to."""
    seen = []
    return ExactSearchOptions(observe=lambda e, v: seen.append((e, v)), **kw), seen


def test_the_greedy_word_gets_forty_percent_of_the_time_budget_and_no_more():
    """Set-valued rows, so the greedy word comes from pair merging, which reads the clock at every
    step. Counted on a clock alone, it needs G readings; on a clock ticking once a reading, a budget of
    2.5 G seconds gives it exactly G (40%) and it finishes, a budget of 2.5 (G - 1) gives it G - 1 and
    the answer says that no greedy word was found in its share."""
    sup = [[frozenset({1}), frozenset({2}), frozenset({0, 3}), frozenset({3})],
           [frozenset({0}), frozenset({1}), frozenset({3}), frozenset({0})]]
    aut = support_automaton(model_from_support(sup))
    readings = []

    def counting():
        readings.append(None)
        return float(len(readings))

    word = greedy_synchronizing_word(aut, deadline=1e9, clock=counting)
    G = len(readings)
    assert word is not None and G > 2
    enough = shortest_synchronizing_word(aut, time_budget=2.5 * G, node_budget=1, clock=_ticking())
    short = shortest_synchronizing_word(aut, time_budget=2.5 * (G - 1), node_budget=1, clock=_ticking())
    assert enough.greedy_length == len(word) and enough.word == word
    assert "greedy word not found within 40% of the time budget" not in enough.notes
    assert (short.word, short.greedy_length, short.exact) == (None, None, False)
    assert short.notes[-1] == "greedy word not found within 40% of the time budget"


@pytest.mark.parametrize("trie_meet", [True, False])
def test_the_exact_search_reads_the_clock_it_is_given(trie_meet):
    """C_6 (shortest word 25 letters) without the fast path and the beam, on a clock ticking one second
    per reading: a 20-second budget runs out after a few levels, so the answer is Eppstein's greedy
    word with a proven bound below 25, never the exact answer a real clock's milliseconds would
    allow; with no time limit the search proves 25. The same with the meet test by the rarest-member
    index, which reads the clock between its groups."""
    aut = SyncAutomaton.from_table(cerny(6))
    options = ExactSearchOptions(fast_nodes=None, use_beam=False, trie_meet=trie_meet)
    r = shortest_synchronizing_word(aut, time_budget=20.0, options=options, clock=_ticking())
    assert not r.exact and r.method == "greedy-eppstein" and r.length == r.greedy_length
    assert 1 <= r.lower_bound < 25
    assert r.notes[0] == f"exact search stopped by its budget; no synchronizing word is shorter than {r.lower_bound}"
    full = shortest_synchronizing_word(aut, time_budget=None, options=options)
    assert (full.length, full.exact) == (25, True)


def test_the_fast_path_never_generates_more_sets_than_fast_nodes():
    """``fast_nodes``: the sets an exact search may generate before the beam runs. The fast path stops
    before a level that could pass it, so the sets it reports never exceed it, whatever the cap; the
    answer is the Cerny length either way."""
    for n in (5, 6, 7):
        aut = SyncAutomaton.from_table(cerny(n))
        for cap in range(4, 40):
            options, seen = _events(fast_nodes=cap)
            r = shortest_synchronizing_word(aut, time_budget=None, options=options)
            spent = [v for e, v in seen if e == "fast-path"]
            assert len(spent) == 1 and 0 < spent[0] <= cap, (n, cap, spent)
            assert (r.length, r.exact) == ((n - 1) ** 2, True)


def test_the_node_budget_bounds_the_beam_too():
    """C_6 with a node budget of 100 sets: the inverse beam search needs more than that for its
    25-letter word, so it stops without one (its event reads -1) and the bidirectional search proves
    25 itself; with 1,000 sets the beam finds the word and the search proves it shortest."""
    aut = SyncAutomaton.from_table(cerny(6))
    options, seen = _events()
    r = shortest_synchronizing_word(aut, time_budget=None, node_budget=100, options=options)
    assert [v for e, v in seen if e == "beam"] == [-1]
    assert (r.length, r.exact, r.method) == (25, True, "bidirectional-bfs")
    options, seen = _events()
    r = shortest_synchronizing_word(aut, time_budget=None, node_budget=1000, options=options)
    assert [v for e, v in seen if e == "beam"] == [25]
    assert (r.length, r.exact, r.method) == (25, True, "beam+lower-bound")


def test_an_exact_search_left_no_time_by_the_greedy_and_the_beam_stops_at_once():
    """C_6 on a clock that stands still until the beam has answered and then jumps past the 1-second
    budget, ticking 10 ms a reading: the exact search gets the 1 ms floor, so its first level is
    predicted past the deadline, the depth-first phase stops at its first look at the clock, and
    the answer is the beam's 25 letters with the bound 1 (a second would have proven 25)."""
    class Clock:
        now, tick = 0.0, 0.0

        def __call__(self):
            self.now += self.tick
            return self.now

    clock = Clock()

    def observe(event, value):
        seen.append((event, value))
        if event == "beam" and clock.tick == 0.0:
            clock.now, clock.tick = 100.0, 0.01

    seen = []
    r = shortest_synchronizing_word(SyncAutomaton.from_table(cerny(6)), time_budget=1.0, clock=clock,
                                    options=ExactSearchOptions(fast_nodes=None, observe=observe))
    assert (r.length, r.exact, r.method, r.lower_bound) == (25, False, "beam", 1)
    assert [e for e, _ in seen] == ["beam", "meet", "depth-first", "inverse-dfs"]


def test_the_last_level_is_met_unstored_only_when_its_sets_fit_the_node_budget():
    """The 12-state automaton of test_exact_phases (shortest word 9): after 126 sets stored, the last
    length's level is generated unstored from the side with the smaller newest level (26 backward
    sets against 43 forward), 3 preimages a set. A node budget of exactly 126 + 3 x 26 lets it run
    and proves 9; one set less and the level is not generated unstored: it is grown and stored
    instead (its 78 preimages hold fewer new sets), which proves 9 as well."""
    table = [[6, 5, 3, 11, 1, 2, 8, 7, 0, 10, 4, 4], [1, 8, 8, 4, 1, 11, 10, 6, 4, 0, 2, 3],
             [2, 5, 7, 6, 11, 3, 0, 10, 6, 10, 4, 10]]
    aut = SyncAutomaton.from_table(table)
    options, seen = _events(use_beam=False)
    shortest_synchronizing_word(aut, time_budget=None, options=options)
    levels = [(e, v) for e, v in seen if e.endswith("-level")]
    assert levels[-3:] == [("backward-level", 26), ("forward-level", 43), ("last-level", 78)]
    for budget, runs in ((126 + 78, True), (126 + 78 - 1, False)):
        options, seen = _events(use_beam=False)
        r = shortest_synchronizing_word(aut, time_budget=None, node_budget=budget, options=options)
        assert ([v for e, v in seen if e == "last-level"] == [78]) == runs
        assert (r.length, r.exact) == (9, True)
        assert (r.states_explored == budget) if runs else (126 < r.states_explored < budget)


def test_a_proven_no_answer_reports_its_threads():
    """Two copies of a random 14-state automaton, no pair-graph check in 0.0001 MB: the breadth-first
    search proves that no word exists, and says how many threads its kernels were split over."""
    import numpy as np

    table = np.random.default_rng(12).integers(0, 14, (3, 14)).tolist()
    aut = SyncAutomaton.from_table([row + [q + 14 for q in row] for row in table])
    for parallel in (False, True):
        r = shortest_synchronizing_word(aut, time_budget=None, memory_budget_mb=1e-4,
                                        options=ExactSearchOptions(parallel=parallel))
        assert (r.word, r.exact, r.method) == (None, True, "bidirectional-bfs")
        assert r.threads == ExactSearchOptions(parallel=parallel).threads


def test_a_node_budget_stop_is_reproduced_by_a_budget_of_its_own_count():
    """Budgets are in sets and checked as soon as the sets counted reach them: a search stopped by a
    node budget after ``s`` sets stops at the same place, with the same bound, under a budget of
    exactly ``s`` (here inside the inverse depth-first phase, entered at levels over 30 sets, on
    random 4-letter automata of 20-29 states)."""
    import numpy as np

    from kruskal_markov import generators

    rng = np.random.default_rng(4375)
    options = ExactSearchOptions(use_beam=False, dfs_switch_rows=30, dfs_chunk=3)
    stopped = 0
    for _ in range(4):
        aut = SyncAutomaton.from_table(generators.random_table(int(rng.integers(20, 30)), 4, rng))
        for budget in range(50, 3000, 97):
            r = shortest_synchronizing_word(aut, time_budget=None, node_budget=budget, options=options)
            if r.exact:
                continue
            again = shortest_synchronizing_word(aut, time_budget=None, node_budget=r.states_explored, options=options)
            assert (again.states_explored, again.lower_bound, again.word) == (r.states_explored, r.lower_bound, r.word)
            stopped += 1
    assert stopped > 50


def test_budgets_that_are_not_positive_are_refused_by_name():
    aut = SyncAutomaton.from_table(cerny(4))
    for kw in ({"time_budget": 0.0}, {"time_budget": -1.0}, {"memory_budget_mb": 0.0}):
        with pytest.raises(ValueError, match=r"^time and memory budgets must be positive$"):
            shortest_synchronizing_word(aut, **kw)
