"""kruskal_markov.posterior: Dirichlet resampling of a built model's rows, checked against the
posterior's own formulas (mean, variance) and the rules for rows without counts."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from kruskal_markov.model import ModelError, TransitionModel
from kruskal_markov.posterior import has_counts, resample_model, row_counts


def _model():
    """Action 0: row 0 counted (3, 1, 0 over three targets), row 1 one target (2 samples), row 2
    without counts (imputed: kept as given). Action 1: the identity, counted once per row."""
    p0 = sp.csr_matrix(np.array([[0.6, 0.3, 0.1], [0.0, 1.0, 0.0], [0.5, 0.0, 0.5]]))
    p1 = sp.identity(3, format="csr")
    return TransitionModel(["a", "b"], [p0, p1], initial=[0.2, 0.3, 0.5], partition=[0, 1, 1], n_cells=2,
                           extras={"counts_0": [3, 1, 0, 2, 0, 0], "counts_1": [1, 1, 1]})


def test_counts_are_read_and_checked():
    m = _model()
    assert has_counts(m)
    assert row_counts(m, 0).tolist() == [3, 1, 0, 2, 0, 0] and row_counts(m, 0).dtype == np.int64
    plain = TransitionModel(["a"], [np.eye(2)])
    assert not has_counts(plain)
    with pytest.raises(ModelError, match="'a'"):
        row_counts(plain, 0)
    bad = TransitionModel(["a"], [np.eye(2)], extras={"counts_0": [1, 2, 3]})
    with pytest.raises(ModelError, match="do not match"):
        row_counts(bad, 0)
    negative = TransitionModel(["a"], [np.eye(2)], extras={"counts_0": [1, -1]})
    with pytest.raises(ModelError, match="do not match"):
        row_counts(negative, 0)


def test_draws_average_to_the_posterior_mean_with_its_variance():
    """Row (3, 1, 0) with prior 0.5 on the observed targets: Dirichlet(3.5, 1.5) on the first two,
    the unobserved third stays 0. Mean 0.7 / 0.3, variance a b / (s^2 (s + 1)) = 0.035 (s = 5)."""
    m = _model()
    rng = np.random.default_rng(7)
    draws = np.array([resample_model(m, rng).matrices[0].toarray()[0] for _ in range(4000)])
    assert np.all(draws[:, 2] == 0.0)
    np.testing.assert_allclose(draws.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    mean, var = 3.5 / 5, 3.5 * 1.5 / (25 * 6)
    se = np.sqrt(var / len(draws))
    assert abs(draws[:, 0].mean() - mean) < 4 * se
    assert draws[:, 0].var(ddof=1) == pytest.approx(var, rel=0.08)
    # a larger prior pulls the mean toward uniform over the observed targets: (3 + 2) / (4 + 4)
    wide = np.array([resample_model(m, rng, prior=2.0).matrices[0].toarray()[0, 0] for _ in range(4000)])
    assert abs(wide.mean() - 5 / 8) < 4 * np.sqrt((5 * 3) / (64 * 9) / len(wide))


def test_rows_without_choice_or_counts_are_kept():
    m = _model()
    r = resample_model(m, 3)
    dense = r.matrices[0].toarray()
    assert dense[1].tolist() == [0.0, 1.0, 0.0]          # one observed target: a one-point posterior
    assert dense[2].tolist() == [0.5, 0.0, 0.5]          # no counts: as given
    assert np.array_equal(r.matrices[1].toarray(), np.eye(3))
    assert np.array_equal(r.initial, m.initial) and np.array_equal(r.partition, m.partition)
    assert r.n_cells == 2 and r.actions == m.actions and r.extras["counts_0"] is not None
    # same sparsity where every stored entry was observed (an unobserved one draws 0 and the
    # model drops it: then the carried counts no longer align -- see docs/testing.md)
    assert np.array_equal(r.matrices[1].indices, m.matrices[1].indices)
    assert np.array_equal(r.matrices[1].indptr, m.matrices[1].indptr)


def test_seeded_draws_repeat_and_differ_between_seeds():
    m = _model()
    a = resample_model(m, 11).matrices[0].toarray()
    b = resample_model(m, np.random.default_rng(11)).matrices[0].toarray()
    c = resample_model(m, 12).matrices[0].toarray()
    assert np.array_equal(a, b) and not np.array_equal(a, c)


@pytest.mark.parametrize("prior", [0.0, -1.0, float("nan"), float("inf")])
def test_bad_prior(prior):
    with pytest.raises(ValueError, match="prior"):
        resample_model(_model(), 0, prior=prior)


def test_missing_counts_message_is_whole():
    plain = TransitionModel(["a"], [np.eye(2)])
    with pytest.raises(ModelError) as err:
        row_counts(plain, 0)
    assert str(err.value) == "the model has no sample counts for action 'a' (only built models carry them)"


def test_resampled_model_keeps_shape_cells_metadata_and_tolerance():
    """Everything but the counted rows is carried over: a last state no row leads to (its column is
    empty, so the shape cannot be inferred from the entries), a last report cell no state is in,
    the metadata and a tolerance above the 1e-9 floor."""
    p = sp.csr_matrix(np.array([[0.5, 0.5, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]))
    m = TransitionModel(["a"], [p], partition=[0, 1, 1], n_cells=3, metadata={"scene": "x"}, tol=1e-6,
                        extras={"counts_0": [3, 1, 2, 4]})
    r = resample_model(m, 5)
    assert r.matrices[0].shape == (3, 3) and r.n_states == 3
    assert r.n_cells == 3
    assert r.metadata == {"scene": "x"}
    assert r.tol == 1e-6
    assert resample_model(TransitionModel(["a"], [p], extras={"counts_0": [3, 1, 2, 4]}), 5).tol == 1e-9


def test_a_row_observed_once_puts_all_its_mass_on_the_observed_target():
    """Counts (1, 0): the prior goes to observed targets only, so the posterior is a point mass on
    the first target, whatever the row held before."""
    p = sp.csr_matrix(np.array([[0.5, 0.5], [0.0, 1.0]]))
    m = TransitionModel(["a"], [p], extras={"counts_0": [1, 0, 3]})
    r = resample_model(m, 2).matrices[0].toarray()
    assert r[0].tolist() == [1.0, 0.0] and r[1].tolist() == [0.0, 1.0]


def test_counts_are_int64_whatever_they_were_stored_as():
    """Built models store counts as int32 (builder assembly); row_counts promises int64."""
    m = TransitionModel(["a"], [np.eye(2)], extras={"counts_0": np.array([1, 2], dtype=np.int32)})
    c = row_counts(m, 0)
    assert c.dtype == np.int64 and c.tolist() == [1, 2]
