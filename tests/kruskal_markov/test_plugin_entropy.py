"""kruskal_markov.plugin_entropy: the plug-in entropy estimate's bias (its expectation under m trials)
and its bootstrap noise, the two terms ``kruskal validate`` compares a model with direct simulation by."""
from __future__ import annotations

import numpy as np
import pytest

from kruskal_markov.plugin_entropy import bootstrap_entropy_sd, expected_plugin_entropy


def test_expected_plugin_entropy_matches_its_closed_form():
    """Two equally likely cells and m = 2 draws: the plug-in entropy is 0 (same cell, probability
    1/2) or 1 bit, so its expectation is 0.5 bits; one draw or one cell: 0."""
    rng = np.random.default_rng(5)
    assert expected_plugin_entropy(np.array([0.5, 0.5]), 1, rng) == 0.0
    assert expected_plugin_entropy(np.array([0.0, 1.0, 0.0]), 40, rng) == 0.0
    assert expected_plugin_entropy(np.array([0.5, 0.5]), 0, rng) == 0.0
    values = [expected_plugin_entropy(np.array([0.5, 0.5]), 2, rng) for _ in range(40)]    # 40 x 200 draws
    assert abs(np.mean(values) - 0.5) < 4 * 0.5 / np.sqrt(40 * 200)
    # negative round-off is clipped and the distribution renormalised
    assert expected_plugin_entropy(np.array([-1e-18, 2.0]), 10, rng) == 0.0


def testbootstrap_entropy_sd():
    rng = np.random.default_rng(0)
    assert bootstrap_entropy_sd(np.zeros(30, dtype=np.int64), 4, rng) == 0.0      # one cell: no spread
    assert bootstrap_entropy_sd(np.array([2]), 4, rng) == 0.0                      # fewer than 2 labels
    # half the trials in each of two cells: the plug-in entropy's sd over resamples is about
    # the delta method's sqrt(var(log-ratio term) / m), near zero at p = 1/2; it is small and positive
    sd = bootstrap_entropy_sd(np.repeat([0, 1], 50), 2, rng)
    assert 0.0 < sd < 0.05
    # two trials are enough for a bootstrap: resamples of (0, 1) give 0 or 1 bit, an sd near 0.5
    assert 0.4 < bootstrap_entropy_sd(np.array([0, 1]), 2, rng) < 0.6


def test_the_plugin_expectation_and_the_bootstrap_each_use_200_draws():
    """The expected plug-in entropy (validate's model curve) is the mean over 200 multinomial draws by
    default, and the bootstrap sd (validate's reference noise) the sd (ddof 1) over 200 resamples, each
    taken from the rng it is given: recomputed here from the same generator state, draw for draw."""
    from kruskal_markov.entropy import histogram_entropy_bits

    q, m = np.array([0.5, 0.3, 0.2]), 7
    got = expected_plugin_entropy(q, m, np.random.default_rng(11))
    want = np.mean([histogram_entropy_bits(d) for d in np.random.default_rng(11).multinomial(m, q, size=200)])
    assert got == pytest.approx(want, rel=1e-12)
    labels = np.array([0, 0, 1, 2, 2, 2, 3])
    rng = np.random.default_rng(12)
    hs = [histogram_entropy_bits(np.bincount(labels[rng.integers(0, 7, 7)], minlength=4)) for _ in range(200)]
    assert bootstrap_entropy_sd(labels, 4, np.random.default_rng(12)) == pytest.approx(np.std(hs, ddof=1), rel=1e-12)
