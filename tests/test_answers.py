"""Paper-level answers with their intervals: every interval holds its point estimate, the terms vanish
where they should, and the structural range is the entropy ball's on the model's own distributions."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from kruskal_markov.answers import answer_intervals, plan_success_interval
from kruskal_markov.generators import cerny_model
from kruskal_markov.model import TransitionModel


def _counted_model(seed=3, n=12, cells=4):
    """A random stochastic model whose rows are counts / 20 (so it carries a posterior)."""
    rng = np.random.default_rng(seed)
    mats, extras = [], {}
    for a in range(3):
        c = np.zeros((n, n))
        for i in range(n):
            tg = rng.choice(n, 2, replace=False)
            c[i, tg] = rng.multinomial(20, [0.8, 0.2])
        m = sp.csr_matrix(c)
        extras[f"counts_{a}"] = m.data.astype(np.int64)
        mats.append(sp.csr_matrix((m.data / 20.0, m.indices, m.indptr), shape=(n, n)))
    return TransitionModel(["a", "b", "c"], mats, initial=np.full(n, 1.0 / n), partition=np.arange(n) % cells,
                           n_cells=cells, extras=extras)


def _intervals(d):
    for k, v in d.items():
        if k == "settings":
            continue
        for name in ("mc_ci95", "posterior_ci90", "structural_range", "model_ci90"):
            if v.get(name) is not None and None not in v[name]:
                yield k, name, v["value"], v[name]


@pytest.mark.parametrize("delta", [0.0, 0.105, 0.5])
def test_every_interval_contains_its_point_estimate(delta):
    m = _counted_model()
    out = answer_intervals(m, seed=1, count=300, length=20, epsilon=1e-3, runs=60, max_steps=200, draws=8,
                           draw_count=200, structural_delta=delta, structural_sequences=40)
    seen = list(_intervals(out))
    assert {k for k, *_ in seen} == {"converging_share", "mean_entropy_10", "mean_entropy_20", "random_tilts"}
    for k, name, value, (lo, hi) in seen:
        assert lo <= value <= hi, (k, name, value, lo, hi)
    for k, _, value, _ in seen:
        post, struct, model = out[k]["posterior_ci90"], out[k]["structural_range"], out[k]["model_ci90"]
        # the model interval is the posterior interval widened by the structural range, end to end
        assert model[0] == pytest.approx(post[0] - (value - struct[0]))
        assert model[1] == pytest.approx(post[1] + (struct[1] - value))


def test_zero_structural_error_leaves_the_posterior_interval():
    m = _counted_model()
    out = answer_intervals(m, seed=1, count=300, length=20, epsilon=1e-3, draws=8, draw_count=200,
                           structural_delta=0.0, structural_sequences=40)
    for k in ("converging_share", "mean_entropy_10", "mean_entropy_20"):
        v = out[k]
        assert v["structural_range"] == [v["value"], v["value"]]
        assert v["model_ci90"] == v["posterior_ci90"]
    wide = answer_intervals(m, seed=1, count=300, length=20, epsilon=1e-3, draws=8, draw_count=200,
                            structural_delta=0.3, structural_sequences=40)
    # a mixed distribution's entropy ball is not a point: the structural range of the mean entropy opens
    v = wide["mean_entropy_10"]
    assert v["structural_range"][1] > v["value"] + 1e-3 and v["structural_range"][0] < v["value"] - 1e-3


def test_a_model_without_counts_has_no_posterior_and_a_synchronized_one_no_structural_range():
    m = cerny_model(2)           # deterministic and synchronizing, no counts
    out = answer_intervals(m, seed=0, count=200, length=50, epsilon=1e-9, runs=50, max_steps=500, draws=5,
                           structural_sequences=30)
    assert out["settings"]["draws"] == 0
    assert all(out[k]["posterior_ci90"] is None for k in ("converging_share", "mean_entropy_10", "random_tilts"))
    # Černý C_2 synchronizes a random 50-letter sequence unless it is all one letter (2^-49)
    assert out["converging_share"]["value"] == 1.0
    assert out["converging_share"]["structural_range"] == [1.0, 1.0]
    assert out["mean_entropy_50"]["structural_range"] == [0.0, 0.0]


def test_plan_success_interval():
    m = _counted_model()
    out = plan_success_interval(m, [0, 1, 2], 0.6, draws=8, structural_delta=0.2)
    assert out["structural_range"][0] < 0.6 < out["structural_range"][1]
    assert out["model_ci90"][0] <= out["posterior_ci90"][0] <= 0.6 <= out["posterior_ci90"][1] <= out["model_ci90"][1]
    none = plan_success_interval(m, [0, 1, 2], 0.6, draws=0, structural_delta=0.0)
    assert none["posterior_ci90"] is None and none["model_ci90"] == [0.6, 0.6]
