"""The distribution search's answers count what they explored."""
from __future__ import annotations

import numpy as np

from kruskal_markov.model import TransitionModel
from kruskal_markov.sync import epsilon_synchronizing_word


def test_an_exhaustive_no_counts_every_reachable_distribution():
    """A 3-cycle and a transposition on three states permute the start (0.5, 0.3, 0.2) into its
    3! = 6 orderings and nothing else; each has entropy 1.485 bits, so no word reaches 0.5 bits and
    the search says so after exploring exactly those 6 distributions."""
    cycle = np.eye(3)[[1, 2, 0]]
    swap = np.eye(3)[[1, 0, 2]]
    model = TransitionModel(["cycle", "swap"], [cycle, swap], initial=[0.5, 0.3, 0.2])
    res = epsilon_synchronizing_word(model, 0.5)
    assert res.word is None and res.exact
    assert res.states_explored == 6
    assert res.witness == {"kind": "exhaustive", "reason": "all 6 reachable distributions have entropy > 0.5"}
