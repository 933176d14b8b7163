"""kruskal_markov.generators: the shared instances are what their docstrings say, and seeded."""
from __future__ import annotations

import numpy as np
import pytest

from kruskal_markov import generators as g


def test_cerny_is_the_classic_automaton():
    t = g.cerny_table(5)
    assert t.shape == (2, 5) and t.dtype == np.int64
    assert t[0].tolist() == [1, 2, 3, 4, 0] and t[1].tolist() == [0, 1, 2, 3, 0]
    assert g.cerny_automaton(5).k == 2 and g.cerny_model(5).is_deterministic()
    assert np.array_equal(g.cerny_model(5).deterministic_table(), t)


def test_seeded_and_shared_streams():
    assert np.array_equal(g.random_table(9, 3, seed=4), g.random_table(9, 3, seed=4))
    assert not np.array_equal(g.random_table(9, 3, seed=4), g.random_table(9, 3, seed=5))
    rng = np.random.default_rng(1)
    first, second = g.random_table(9, 3, rng), g.random_table(9, 3, rng)     # one stream, two draws
    assert not np.array_equal(first, second)
    assert g.random_model(6, 2, seed=3).same_arrays(g.random_model(6, 2, seed=3))


@pytest.mark.parametrize("dense", [False, True])
def test_stochastic_matrices_and_models_are_row_stochastic(dense):
    m = g.random_stochastic_matrix(30, 0.1, seed=2, dense=dense)
    a = m if dense else m.toarray()
    np.testing.assert_allclose(a.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    assert np.all(a >= 0) and np.all((a > 0).sum(axis=1) >= 1)
    model = g.random_model(12, 3, cells=4, seed=0)
    assert model.n_actions == 3 and model.n_cells == 4 and model.partition.max() < 4
    assert abs(model.initial.sum() - 1) < 1e-12
    assert np.allclose(g.random_model(12, 1, initial="uniform", seed=0).initial, 1 / 12)


def test_contracting_and_tray_like_images():
    t = g.contracting_table(64, 4, seed=0)
    assert all(len(set(row.tolist())) <= 8 for row in t)           # each letter lands in an eighth
    m = g.tray_like_model(80, 3, nnz=2, cells=5, seed=0)
    assert all(len(np.unique(p.indices)) <= 10 for p in m.matrices)
    s = g.set_valued_tray_model(128, 2, shrink=16, noise=0.5, seed=0)
    assert all(len(np.unique(p.indices)) <= 8 for p in s.matrices)
    assert any(np.diff(p.indptr).max() == 2 for p in s.matrices)   # some rows split in two


@pytest.mark.parametrize("call", [lambda: g.cerny_table(0), lambda: g.random_table(3, True),
                                  lambda: g.random_model(3, 1, initial="peaked")])
def test_bad_arguments(call):
    with pytest.raises(ValueError):
        call()
