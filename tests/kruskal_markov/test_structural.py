"""The structural error term and the predictive band: exact entropy ranges, nominal coverage on toys."""
from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse as sp

from analysis.validate import model_band, wilson_interval
from kruskal_markov.entropy import histogram_entropy_bits
from kruskal_markov.model import TransitionModel
from kruskal_markov.plugin_entropy import bootstrap_entropy_sd
from kruskal_markov.posterior import resample_model
from kruskal_markov.structural import (
    band_with_structure,
    conformal_quantile,
    entropy_range_tv,
    structural_score,
    structural_share,
)


def _h(p):
    p = np.asarray(p, dtype=float)
    p = p[p > 0]
    return float(-(p * np.log2(p)).sum())


@pytest.mark.parametrize("a, delta", [(0.9, 0.1), (0.9, 0.5), (0.7, 0.05), (0.5, 0.2), (1.0, 0.3), (0.2, 0.25)])
def test_entropy_range_of_two_cells_is_the_binary_entropy_at_the_ends(a, delta):
    """Two cells: the TV ball is the interval a +- delta; entropy is largest nearest 1/2, smallest farthest."""
    lo_a, hi_a = max(0.0, a - delta), min(1.0, a + delta)
    near = min(max(0.5, lo_a), hi_a)
    far = lo_a if abs(lo_a - 0.5) > abs(hi_a - 0.5) else hi_a
    lo, hi = entropy_range_tv([a, 1 - a], delta)
    assert float(hi) == pytest.approx(_h([near, 1 - near]), abs=1e-9)
    assert float(lo) == pytest.approx(_h([far, 1 - far]), abs=1e-9)


def test_entropy_range_of_three_cells_by_hand():
    """(0.5, 0.3, 0.2) within 0.1: most even (0.4, 0.3, 0.3), most peaked (0.6, 0.3, 0.1)."""
    lo, hi = entropy_range_tv([0.5, 0.3, 0.2], 0.1)
    assert float(hi) == pytest.approx(_h([0.4, 0.3, 0.3]), abs=1e-9)
    assert float(lo) == pytest.approx(_h([0.6, 0.3, 0.1]), abs=1e-9)
    lo, hi = entropy_range_tv([0.5, 0.3, 0.2], 0.25)     # the two smallest emptied in turn
    assert float(lo) == pytest.approx(_h([0.75, 0.25, 0.0]), abs=1e-9)


def test_entropy_range_brackets_every_distribution_in_the_ball():
    rng = np.random.default_rng(5)
    for _ in range(60):
        n = int(rng.integers(3, 9))
        p = rng.dirichlet(np.full(n, 0.5))
        delta = float(rng.uniform(0.0, 0.4))
        lo, hi = entropy_range_tv(p, delta)
        for _ in range(3000):
            q = np.clip(p + rng.normal(0, delta, n), 0, None)
            if q.sum() == 0:
                continue
            q /= q.sum()
            if 0.5 * np.abs(q - p).sum() <= delta:
                assert lo - 1e-9 <= _h(q) <= hi + 1e-9


def test_entropy_range_limits():
    p = np.array([0.5, 0.3, 0.2, 0.0])
    lo, hi = entropy_range_tv(p, 0.0)
    assert float(lo) == float(hi) == pytest.approx(_h(p))
    lo, hi = entropy_range_tv(p, 1.0)
    assert float(lo) == pytest.approx(0.0, abs=1e-12) and float(hi) == pytest.approx(2.0)
    with pytest.raises(ValueError):
        entropy_range_tv([0.5, -0.1], 0.1)
    with pytest.raises(ValueError):
        entropy_range_tv([0.5, 0.5], -0.1)


def test_structural_share_and_zero_delta_give_the_dirichlet_band():
    cells = np.array([[0.5, 0.25, 0.25], [1.0, 0.0, 0.0]])
    assert structural_share(cells).tolist() == [0.5, 0.0]
    centre, width = np.array([1.5, 0.0]), np.array([0.1, 0.02])
    lo, hi = band_with_structure(cells, centre, width, 0.0)
    assert lo.tolist() == (centre - width).tolist() and hi.tolist() == (centre + width).tolist()
    lo, hi = band_with_structure(cells, centre, width, 0.2)
    # a converged step (all mass in one cell) keeps its band; the other widens on both sides
    assert lo[1] == pytest.approx(-0.02) and hi[1] == pytest.approx(0.02)
    assert lo[0] < 1.4 and hi[0] > 1.6


def test_structural_score_is_the_smallest_delta_that_covers():
    cells = np.array([[0.6, 0.3, 0.1]] * 3)
    centre = np.full(3, _h([0.6, 0.3, 0.1]))
    width = np.full(3, 0.01)
    ref = centre + np.array([0.0, 0.2, -0.3])
    s = structural_score(cells, centre, width, ref)
    assert s[0] == 0.0 and 0 < s[1] < np.inf and 0 < s[2] < np.inf
    for i in (1, 2):
        lo, hi = band_with_structure(cells, centre, width, s[i])
        assert lo[i] - 1e-9 <= ref[i] <= hi[i] + 1e-9
        lo, hi = band_with_structure(cells, centre, width, 0.98 * s[i])
        assert not (lo[i] - 1e-9 <= ref[i] <= hi[i] + 1e-9)
    # a converged model step cannot be widened: no delta covers a reference away from it
    s = structural_score(np.array([[1.0, 0.0, 0.0]]), np.zeros(1), np.full(1, 0.01), np.array([0.5]))
    assert s[0] == np.inf


def test_structural_score_below_one_bisects_to_the_same_smallest_delta():
    """With ``hi_delta`` <= 1 the score bisects arithmetically in [0, hi_delta]: the same smallest covering delta
    as the default's geometric bisection where that is below ``hi_delta``, inf where it is above."""
    rng = np.random.default_rng(1)
    cells = rng.dirichlet(np.full(6, 0.3), size=60)
    centre = np.array([_h(c) for c in cells])
    width = np.full(60, 0.01)
    ref = centre + rng.normal(0, 0.3, 60)
    full = structural_score(cells, centre, width, ref)
    half = structural_score(cells, centre, width, ref, hi_delta=0.5)
    below = np.isfinite(full) & (full < 0.5)
    assert 0 < np.sum(below & (full > 0)) and np.any(np.isfinite(full) & (full > 0.5))
    assert np.array_equal(np.isfinite(half), below)
    assert np.allclose(half[below], full[below], rtol=1e-9, atol=1e-12)
    for i in np.flatnonzero(below & (half > 0)):          # the smallest: a little less does not hold
        lo, hi = band_with_structure(cells, centre, width, half[i])
        assert lo[i] - 1e-9 <= ref[i] <= hi[i] + 1e-9
        lo, hi = band_with_structure(cells, centre, width, 0.99 * half[i])
        assert not (lo[i] - 1e-12 <= ref[i] <= hi[i] + 1e-12)


def test_conformal_quantile_rank():
    assert conformal_quantile([3.0, 1.0, 2.0], 0.5) == 2.0
    assert conformal_quantile(np.arange(19.0), 0.9) == 17.0     # ceil(20 * 0.9) = 18th smallest
    assert conformal_quantile([1.0, 2.0], 0.9) == math.inf
    with pytest.raises(ValueError):
        conformal_quantile([1.0], 1.0)


def test_wilson_interval_known_values():
    lo, hi = wilson_interval(0, 10)
    assert lo == 0.0 and hi == pytest.approx(0.2775, abs=1e-4)
    lo, hi = wilson_interval(45, 50)
    assert lo == pytest.approx(0.7864, abs=1e-3) and hi == pytest.approx(0.9565, abs=1e-3)
    with pytest.raises(ValueError):
        wilson_interval(3, 2)


def _toy_truth(rng, n=6, n_actions=2):
    """Rows with two or three targets of probability >= 0.15 each (so counts observe every target)."""
    mats = []
    for _ in range(n_actions):
        m = np.zeros((n, n))
        for i in range(n):
            k = int(rng.integers(2, 4))
            tg = rng.choice(n, k, replace=False)
            w = 0.15 + rng.dirichlet(np.ones(k)) * (1 - 0.15 * k)
            m[i, tg] = w
        mats.append(m)
    return mats


def test_dirichlet_band_covers_simulated_references_at_its_nominal_rate():
    """Known rows, counts drawn from them, references drawn from the truth: the 90% band (structural
    term 0) holds the reference's plug-in entropy at 84-96% of steps over 120 repetitions (1,200 steps;
    the binomial sd at 90% is 0.9 points, and 58% is 30 sd away)."""
    from analysis.validate import coverage_verdict

    rng = np.random.default_rng(2024)
    n, steps, counts_per_row, trials = 6, 10, 40, 400
    inside, wide, narrow = [], [], []
    for rep in range(120):
        truth = _toy_truth(rng, n)
        init = np.full(n, 1.0 / n)
        est, extras = [], {}
        for a, t in enumerate(truth):
            c = np.vstack([rng.multinomial(counts_per_row, row) for row in t])
            csr = sp.csr_matrix(c.astype(float))
            extras[f"counts_{a}"] = csr.data.astype(np.int64)
            est.append(sp.csr_matrix((csr.data / counts_per_row, csr.indices, csr.indptr), shape=(n, n)))
        model = TransitionModel(["a", "b"], est, initial=init, partition=np.arange(n), n_cells=n, extras=extras)
        seq = rng.integers(0, 2, steps)
        # reference: `trials` trajectories of the true chain
        state = rng.choice(n, trials, p=init)
        labels = [state.copy()]
        for a in seq:
            cum = np.cumsum(truth[a][state], axis=1)
            state = (rng.random(trials)[:, None] > cum).sum(1).clip(0, n - 1)
            labels.append(state.copy())
        href = np.array([histogram_entropy_bits(np.bincount(lab, minlength=n)) for lab in labels])
        sd = np.array([bootstrap_entropy_sd(lab, n, rng) for lab in labels])
        draws = [resample_model(model, rng) for _ in range(40)]
        band = model_band(model, seq, draws, np.full(steps + 1, trials), sd, 0.0, rng)
        inside.append(((href >= band["lo"] - 1e-12) & (href <= band["hi"] + 1e-12))[1:])
        c, w = band["centre"], band["width"]
        wide.append((np.abs(href - c) <= 3 * w + 1e-12)[1:])
        narrow.append((np.abs(href - c) <= 0.3 * w + 1e-12)[1:])
    cover = np.concatenate(inside).mean()
    print(f"coverage {cover:.3f}")
    assert 0.84 <= cover <= 0.96, cover
    assert coverage_verdict(int(np.concatenate(inside).sum()), len(cover_steps := np.concatenate(inside))) \
        == "consistent", len(cover_steps)
    # the same judge fails a band three times as wide (too wide) and one at 0.3 times (too narrow)
    wide, narrow = np.concatenate(wide), np.concatenate(narrow)
    assert wide.mean() > 0.96 and coverage_verdict(int(wide.sum()), len(wide)) == "too wide", wide.mean()
    assert narrow.mean() < 0.84 and coverage_verdict(int(narrow.sum()), len(narrow)) == "too narrow"


def test_one_bad_row_or_delta_among_good_ones_is_refused_with_its_whole_message():
    """Every row and every per-row delta is checked, not only the first or all at once; the messages
    are the one-line errors the CLI prints."""
    import re

    good = [0.5, 0.5]
    for p in ([good, [0.5, -0.1]], [good, [np.nan, 0.5]], [good, [np.inf, 0.5]]):
        with pytest.raises(ValueError, match="^distributions must be finite and non-negative$"):
            entropy_range_tv(p, 0.1)
    with pytest.raises(ValueError, match="^every distribution needs positive mass$"):
        entropy_range_tv([good, [0.0, 0.0]], 0.1)
    for d in ([0.1, -0.1], [0.1, np.nan], [0.1, np.inf]):
        with pytest.raises(ValueError, match="^" + re.escape(f"delta must be finite and non-negative, got {d!r}") + "$"):
            entropy_range_tv([good, good], d)
        cells = np.array([[0.5, 0.5], [0.9, 0.1]])
        with pytest.raises(ValueError, match="^" + re.escape(f"structural delta must be a non-negative number, got {d!r}")
                           + "$"):
            band_with_structure(cells, np.zeros(2), np.zeros(2), d)
    # a delta above 1 is the whole simplex: the same range as 1
    assert [float(x) for x in entropy_range_tv([0.7, 0.2, 0.1], 5.0)] == pytest.approx(
        [float(x) for x in entropy_range_tv([0.7, 0.2, 0.1], 1.0)])
    assert float(entropy_range_tv([0.7, 0.2, 0.1], 5.0)[1]) == pytest.approx(math.log2(3))
    # and so is a huge one (structural_score tries 1e6): the kernel alone would stop short of uniform there
    lo, hi = entropy_range_tv(np.random.default_rng(0).dirichlet(np.ones(6), size=50), 1e6)
    assert np.allclose(hi, math.log2(6)) and np.allclose(lo, 0.0, atol=1e-12)


def test_the_conformal_quantile_is_at_90_percent_by_default():
    assert conformal_quantile(np.arange(19.0)) == 17.0        # ceil(20 * 0.9) = 18th smallest
    assert conformal_quantile(np.arange(9.0)) == 8.0          # ceil(10 * 0.9) = 9th of 9
    with pytest.raises(ValueError, match=r"^level must lie in \(0, 1\), got 0$"):
        conformal_quantile([1.0], 0)
