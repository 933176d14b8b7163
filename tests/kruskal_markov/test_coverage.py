"""kruskal_markov.coverage: band coverage with the sequence as the unit (the bootstrap interval of the
pooled coverage, resampled calibrations, conformal risk control per sequence)."""
import math

import numpy as np
import pytest

from kruskal_markov.coverage import calibration_study, sequence_bootstrap_interval, sequence_risk_delta


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


def test_calibration_study_spreads_with_few_sequences_and_not_with_identical_ones():
    # 20 sequences of 30 steps: 18 need no term (score 0), 2 need 0.5 at every step. A calibration from
    # 2 sequences that drew neither has delta 0: of the other 18 sequences 16 are covered (88.9%), of all
    # 20, 18 (90%). One that drew a bad sequence has 30 of its 60 scores at 0.5, so its 55th smallest
    # (ceil(61 * 0.9)) is 0.5 and every step is covered.
    seqs = [np.zeros(30)] * 18 + [np.full(30, 0.5)] * 2
    out = calibration_study(seqs, sizes=(2, 25), resamples=400)
    assert set(out) == {2}                               # k = 25 > 20 sequences is skipped
    held, every = out[2]["held_out"], out[2]["all"]
    assert set(np.round(held, 6)) == {round(16 / 18, 6), 1.0}
    assert set(np.round(every, 6)) == {0.9, 1.0}
    # P(neither bad sequence among 2 of 20) = (18 * 17) / (20 * 19) = 0.805
    assert abs(np.mean(held < 1) - 0.805) < 0.06
    # identical sequences: every calibration gives the same delta and coverage
    same = calibration_study([np.linspace(0, 1, 30)] * 6, sizes=(3,), resamples=50)[3]
    assert np.ptp(same["held_out"]) == 0 and np.ptp(same["all"]) == 0
    with pytest.raises(ValueError):
        calibration_study([np.zeros(3)])


def test_sequence_risk_delta_by_its_definition():
    """The smallest delta with (sum of the sequences' shares outside + 1) / (k + 1) <= 0.1, worked by hand."""
    # below 9 sequences no delta is small enough even with every step inside: 1 / (k + 1) > 0.1
    assert sequence_risk_delta([np.zeros(5)] * 8) == math.inf
    assert sequence_risk_delta([np.zeros(5)] * 9) == 0.0
    # 19 sequences: one bad one is tolerated at 0.2 ((1 + 1) / 20 = 0.1), two are not (3 / 20)
    assert sequence_risk_delta([np.full(10, 0.2)] * 18 + [np.full(10, 0.5)]) == 0.2
    assert sequence_risk_delta([np.full(10, 0.2)] * 17 + [np.full(10, 0.5)] * 2) == 0.5
    # shares, not counts: two sequences half outside at 0.2 lose 1 in all (2 / 20), three lose 1.5 (2.5 / 20)
    half = np.r_[np.full(5, 0.2), np.full(5, 0.3)]
    assert sequence_risk_delta([np.full(10, 0.2)] * 17 + [half] * 2) == 0.2
    assert sequence_risk_delta([np.full(10, 0.2)] * 16 + [half] * 3) == 0.3
    # a step no finite delta covers stays outside: 19 such sequences leave no finite delta
    assert sequence_risk_delta([np.r_[0.1, math.inf]] * 19) == math.inf
    assert sequence_risk_delta([np.r_[0.1, math.inf]] + [np.full(3, 0.1)] * 18) == 0.1
    with pytest.raises(ValueError):
        sequence_risk_delta([])
    with pytest.raises(ValueError):
        sequence_risk_delta([np.zeros(3), np.zeros(0)])
