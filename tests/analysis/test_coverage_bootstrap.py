"""The sequence-level bootstrap interval of pooled band coverage (benchmarks.bench_coverage)."""
import numpy as np
import pytest

from benchmarks.bench_coverage import _split, sequence_bootstrap_interval


def test_all_or_nothing_sequences_give_the_binomial_spread_of_sequences():
    # 8 sequences of 30 steps, 4 wholly inside and 4 wholly outside: the pooled coverage is 50%, and
    # resampling 8 sequences gives Binomial(8, 1/2) / 8, whose 2.5% and 97.5% quantiles are 2/8 and 6/8
    # (P(X <= 1) = 9/256 < 0.025 < P(X <= 2) = 37/256), far wider than a Wilson interval over 240 steps.
    seqs = [np.ones(30, bool)] * 4 + [np.zeros(30, bool)] * 4
    lo, hi = sequence_bootstrap_interval(seqs)
    assert 0.125 <= lo <= 0.25
    assert 0.75 <= hi <= 0.875


def test_every_sequence_inside_gives_a_point_and_the_seed_fixes_the_interval():
    assert sequence_bootstrap_interval([np.ones(30, bool)] * 5) == (1.0, 1.0)
    seqs = [np.arange(30) < k for k in (30, 25, 10, 29, 0, 30)]
    assert sequence_bootstrap_interval(seqs, seed=3) == sequence_bootstrap_interval(seqs, seed=3)
    lo, hi = sequence_bootstrap_interval(seqs)
    assert lo < sum(map(np.sum, seqs)) / 180 < hi


def test_unequal_sequences_are_weighted_by_their_steps_and_no_sequences_is_refused():
    # one sequence of 90 steps inside, nine of 10 steps outside: k ~ Binomial(10, 0.1) copies of the long
    # one give coverage 90k / (90k + 10 (10 - k)); P(k <= 2) = 0.930 < 0.975 < P(k <= 3) = 0.987, so the
    # upper end is k = 3's 270 / 340 (an unweighted mean of sequence shares would give 0.3)
    seqs = [np.ones(90, bool)] + [np.zeros(10, bool)] * 9
    lo, hi = sequence_bootstrap_interval(seqs)
    assert lo == 0.0
    assert hi == pytest.approx(270 / 340)
    with pytest.raises(ValueError):
        sequence_bootstrap_interval([])


def test_split_cuts_a_kept_runs_steps_back_into_its_sequences():
    res = {"per_sequence": [{"reference": [0.0] * 31}, {"reference": [0.0] * 21}]}
    inside = np.arange(50) % 3 == 0
    parts = _split(res, inside)
    assert [len(p) for p in parts] == [30, 20]
    assert np.array_equal(np.concatenate(parts), inside)
