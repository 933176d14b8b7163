"""The exact reset-word search's budgets, read on the clock and counted in sets as documented
(:func:`~kruskal_markov.sync.exact.shortest_synchronizing_word`, ``ExactSearchOptions.fast_nodes``):
the greedy word's 40% of the time, the exact search on the given clock, the fast path within its
sets, and the node budget that bounds the beam too."""
from __future__ import annotations

import itertools

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


def test_the_exact_search_reads_the_clock_it_is_given():
    """C_6 (shortest word 25 letters) without the fast path and the beam, on a clock ticking one second
    per reading: a 20-second budget runs out after a few levels, so the answer is Eppstein's greedy
    word with a proven bound below 25, never the exact answer a real clock's milliseconds would
    allow; with no time limit the search proves 25."""
    aut = SyncAutomaton.from_table(cerny(6))
    options = ExactSearchOptions(fast_nodes=None, use_beam=False)
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
