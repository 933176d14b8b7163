"""The deprecated aliases still work, say so, and name their replacement; each is called here and
nowhere else in the suite (pyproject.toml turns ``KruskalDeprecationWarning`` into an error)."""
from __future__ import annotations

import numpy as np
import pytest

from analysis.orientability import part_metrics
from kruskal_markov.errors import KruskalDeprecationWarning
from kruskal_markov.generators import cerny_model
from kruskal_markov.sync import epsilon_synchronizing_word
from transition_builder.grid import ReportGrid
from transition_builder.tilting import DirectResult


def test_direct_result_to_json_is_to_dict():
    grid = ReportGrid(90.0, 90.0, 4, 4, 4)
    res = DirectResult(sequence=np.array([0]), action_names=("E",), poses=np.zeros((1, 2, 3)),
                       status=np.zeros((1, 2), np.int8), fault_step=np.array([-1]), entropy_bits=np.zeros(2),
                       surviving=np.array([1, 1]), occupied_voxels=np.array([1, 1]), faults={}, grid=grid)
    with pytest.warns(KruskalDeprecationWarning, match="DirectResult.to_json is deprecated; use to_dict"):
        assert res.to_json() == res.to_dict()


def test_part_metrics_as_dict_is_to_dict():
    m = part_metrics(cerny_model(4), seed=2, count=20, runs=10, sync_node_budget=100)
    with pytest.warns(KruskalDeprecationWarning, match="PartMetrics.as_dict is deprecated; use to_dict"):
        assert m.as_dict() == m.to_dict()


def test_epsilon_search_max_nodes_is_node_budget():
    model = cerny_model(4)
    with pytest.warns(KruskalDeprecationWarning, match="max_nodes is deprecated; use node_budget") as rec:
        old = epsilon_synchronizing_word(model, 0.01, max_nodes=500)
    assert rec[0].filename == __file__          # the warning points at the caller's line
    new = epsilon_synchronizing_word(model, 0.01, node_budget=500)
    assert (old.word, old.length, old.exact, old.states_explored) == (new.word, new.length, new.exact,
                                                                     new.states_explored)
