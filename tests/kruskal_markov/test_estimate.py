"""The frozen Estimate type: combination of the terms, JSON form, round trip."""
import json

import pytest

from kruskal_markov.estimate import Estimate


def test_combine_adds_the_terms_end_to_end():
    # hand-checked: posterior 0.40-0.70 around 0.5, structural 0.25-0.5 -> model 0.15-0.70
    e = Estimate.combine(0.5, mc=(0.45, 0.55), posterior=(0.40, 0.70), structural=(0.25, 0.5))
    assert e.model_ci90 == pytest.approx((0.15, 0.70))
    assert e.posterior_ci90 == pytest.approx((0.40, 0.70))
    assert e.structural_range == pytest.approx((0.25, 0.5))
    assert e.mc_ci95 == (0.45, 0.55)


def test_combine_widens_each_term_to_hold_the_value():
    e = Estimate.combine(1.0, posterior=(1.2, 1.5), structural=(1.1, 1.3))
    assert e.posterior_ci90 == pytest.approx((1.0, 1.5))
    assert e.structural_range == pytest.approx((1.0, 1.3))
    assert e.model_ci90 == pytest.approx((1.0, 1.8))


def test_missing_terms_are_zero_width_and_clip_bounds_probabilities():
    e = Estimate.combine(0.98, structural=(0.9, 1.05), clip=(0.0, 1.0))
    assert e.posterior_ci90 is None
    assert e.model_ci90 == pytest.approx((0.9, 1.0))
    bare = Estimate.combine(3.0)
    assert bare.structural_range == (3.0, 3.0) and bare.model_ci90 == (3.0, 3.0)


def test_to_dict_keys_and_round_trip():
    e = Estimate.combine(2.0, mc=(1.5, None), posterior=(1.9, 2.1), note="why", censored=3)
    d = e.to_dict()
    assert list(d) == ["value", "mc_ci95", "posterior_ci90", "structural_range", "model_ci90", "note", "censored"]
    assert d["mc_ci95"] == [1.5, None]
    assert Estimate.from_dict(json.loads(json.dumps(d))) == e
    assert "note" not in Estimate.combine(1.0).to_dict()


def test_bad_intervals_are_refused():
    with pytest.raises(ValueError, match="above"):
        Estimate(1.0, mc_ci95=(2.0, 1.0))
    with pytest.raises(ValueError, match="NaN"):
        Estimate(float("nan"))


def test_contains():
    e = Estimate.combine(0.5, posterior=(0.4, 0.6))
    assert e.contains(0.4) and e.contains(0.6) and not e.contains(0.61)
    assert not e.contains(0.5, "mc_ci95")
