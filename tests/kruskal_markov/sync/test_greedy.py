"""The greedy word's stages: which may run, and the pair-merging stage held to its deadline."""
from __future__ import annotations

import pytest

from kruskal_markov.generators import cerny_automaton
from kruskal_markov.sync import greedy_synchronizing_word


def test_an_unknown_stage_is_refused_with_the_known_ones_named():
    with pytest.raises(ValueError) as err:
        greedy_synchronizing_word(cerny_automaton(4), stages=("pairs", "bogus"))
    assert str(err.value) == "unknown greedy stages ['bogus']; known: eppstein, pairs, descent"


def test_the_pair_merging_stage_stops_at_its_deadline():
    """Pair merging alone finds a word on Cerny C_4 before its deadline, and gives up (None) when the
    clock already reads past it."""
    aut = cerny_automaton(4)
    word = greedy_synchronizing_word(aut, stages=("pairs",), deadline=2.0, clock=lambda: 1.0)
    assert word is not None and len(aut.image(range(4), word)) == 1
    assert greedy_synchronizing_word(aut, stages=("pairs",), deadline=0.5, clock=lambda: 1.0) is None
