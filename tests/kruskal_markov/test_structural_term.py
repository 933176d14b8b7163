"""The structural term per model: none for a model that was not sampled, the model's own calibration
when it has one (stored by `kruskal validate --calibrate`), the default for a built model without."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.sparse as sp

from analysis.commands import InputError
from analysis.commands.validate import calibrate_model
from kruskal_markov.answers import answer_intervals, plan_success_interval
from kruskal_markov.automaton_json import model_from_automaton
from kruskal_markov.model import TransitionModel
from kruskal_markov.structural import (
    NO_TERM_NOTE,
    STRUCTURAL_DELTA,
    conformal_quantile,
    is_sampled,
    structural_term,
    with_calibration,
)

BUILT = {"kind": "kruskal.built_model", "stats": {"states": 12}, "scene": {}, "noise": "none"}


def _counted(n=12, cells=4, seed=3, metadata=None):
    rng = np.random.default_rng(seed)
    mats, extras = [], {}
    for a in range(3):
        c = np.zeros((n, n))
        for i in range(n):
            c[i, rng.choice(n, 2, replace=False)] = rng.multinomial(20, [0.8, 0.2])
        m = sp.csr_matrix(c)
        extras[f"counts_{a}"] = m.data.astype(np.int64)
        mats.append(sp.csr_matrix((m.data / 20.0, m.indices, m.indptr), shape=(n, n)))
    return TransitionModel(["a", "b", "c"], mats, initial=np.full(n, 1.0 / n), partition=np.arange(n) % cells,
                           n_cells=cells, extras=extras, metadata=metadata)


def _automaton():
    rng = np.random.default_rng(1)
    n = 12
    # a JSON automaton, even one whose metadata claims to be built, carries no sample counts
    return model_from_automaton({"states": n, "actions": {"a": rng.integers(0, n, n).tolist(),
                                                          "b": rng.integers(0, n, n).tolist()},
                                 "metadata": BUILT})


def test_a_model_that_was_not_sampled_has_no_structural_term():
    for m in (_automaton(), _counted()):
        assert not is_sampled(m)
        t = structural_term(m)
        assert (t.delta, t.source, t.note) == (0.0, "none", NO_TERM_NOTE)


def test_an_automaton_given_as_json_has_zero_width_structural_ranges_and_says_so():
    m = _automaton()
    out = answer_intervals(m, seed=0, count=200, length=20, epsilon=1e-9, runs=40, max_steps=300,
                           structural_sequences=30)
    assert out["settings"]["structural_source"] == "none"
    assert out["settings"]["structural_delta"] == 0.0
    for k in ("converging_share", "mean_entropy_10", "mean_entropy_20", "random_tilts"):
        v = out[k]
        assert v["structural_range"] == [v["value"], v["value"]], k
        assert v["note"] == NO_TERM_NOTE
    # an explicit delta is the caller's choice and is applied
    given = answer_intervals(m, seed=0, count=200, length=20, epsilon=1e-9, structural_delta=0.3,
                             structural_sequences=30)
    assert given["settings"]["structural_source"] == "given"
    assert "note" not in given["mean_entropy_10"]


def test_a_built_model_uses_its_stored_calibration_else_the_default():
    m = _counted(metadata=BUILT)
    assert is_sampled(m)
    t = structural_term(m)
    assert (t.delta, t.source) == (STRUCTURAL_DELTA, "default")
    cal = with_calibration(m, 0.02, steps=60, seeds=[5])
    t = structural_term(cal)
    assert (t.delta, t.source) == (0.02, "calibrated") and "60 steps" in t.note and "seeds 5)" in t.note
    # the structural range scales with the model's own delta: a 5x smaller delta, a narrower range
    a = answer_intervals(m, seed=1, count=300, length=20, draws=0, structural_sequences=40)["mean_entropy_10"]
    b = answer_intervals(cal, seed=1, count=300, length=20, draws=0, structural_sequences=40)["mean_entropy_10"]
    wa = a["structural_range"][1] - a["structural_range"][0]
    wb = b["structural_range"][1] - b["structural_range"][0]
    assert wa > 0 and 0 < wb < wa / 2
    with pytest.raises(ValueError, match="built model"):
        with_calibration(_automaton(), 0.1)
    with pytest.raises(ValueError, match="non-negative"):
        with_calibration(m, -0.1)


def test_plan_success_interval_of_an_automaton_has_no_structural_term():
    m = _automaton()
    out = plan_success_interval(m, [0, 1, 0], 0.7, draws=0)
    assert out["structural_range"] == [0.7, 0.7] and out["note"] == NO_TERM_NOTE
    built = plan_success_interval(_counted(metadata=BUILT), [0, 1], 0.7, draws=0)
    assert built["structural_range"][0] < 0.7 < built["structural_range"][1]


def _result(needed, seed=11, contact="plain"):
    return {"seed": seed, "contact": contact, "model_contact": "plain",
            "per_sequence": [{"structural_needed": [0.0, *row]} for row in needed]}


def test_calibrate_writes_the_conformal_quantile_into_the_model_file_and_pools_runs(tmp_path):
    path = str(tmp_path / "m.npz")
    m = _counted(metadata=BUILT)
    m.save(path)
    first = [[0.0] * 8 + [0.05, 0.3], [0.0] * 9 + [None]]         # 20 steps, one unreachable (inf)
    c = calibrate_model(m, _result(first), path)
    scores = [0.0] * 17 + [0.05, 0.3, math.inf]
    # ceil(21 * 0.9) = 19th smallest of 20 -> 0.3
    assert c["delta"] == conformal_quantile(scores, 0.9) == 0.3 and c["steps"] == 20
    stored = TransitionModel.load(path)
    assert structural_term(stored).delta == 0.3 and structural_term(stored).source == "calibrated"
    assert np.array_equal(stored.matrices[0].toarray(), m.matrices[0].toarray())
    # a second run pools its steps with the first: 40 steps, ceil(41 * 0.9) = 37th smallest
    second = [[0.0] * 19 + [0.01]]
    c2 = calibrate_model(stored, _result(second, seed=12), path)
    pooled = scores + [0.0] * 19 + [0.01]
    assert c2["steps"] == 40 and c2["seeds"] == [11, 12]
    assert c2["delta"] == conformal_quantile(pooled, 0.9) == 0.01
    json.dumps(TransitionModel.load(path).metadata)


def test_a_calibration_of_few_sequences_says_so_until_enough_are_pooled(tmp_path):
    """The stored record counts the sequences pooled; below MIN_CALIBRATION_SEQUENCES the calibration and
    the model's note warn, at or above it they do not; a record without the count stays unknown."""
    from kruskal_markov.structural import MIN_CALIBRATION_SEQUENCES, calibration_warning

    path = str(tmp_path / "m.npz")
    m = _counted(metadata=BUILT)
    m.save(path)
    two = [[0.0] * 9 + [0.2], [0.0] * 10]
    c = calibrate_model(m, _result(two), path)
    assert c["sequences"] == 2 and "2 sequences, fewer than" in c["warning"]
    t = structural_term(TransitionModel.load(path))
    assert "20 steps of 2 sequences" in t.note and "fewer than" in t.note
    rest = [[0.0] * 10] * (MIN_CALIBRATION_SEQUENCES - 2)
    c2 = calibrate_model(TransitionModel.load(path), _result(rest, seed=12), path)
    assert c2["sequences"] == MIN_CALIBRATION_SEQUENCES and "warning" not in c2
    t2 = structural_term(TransitionModel.load(path))
    assert f"of {MIN_CALIBRATION_SEQUENCES} sequences" in t2.note and "fewer than" not in t2.note
    # a record from before the count: its sequences are unknown, and pooling it keeps them unknown
    old = with_calibration(m, 0.02, steps=60, seeds=[5], scores=[0.0] * 59 + [0.02])
    assert "unrecorded number of sequences" in structural_term(old).note
    c3 = calibrate_model(old, _result([[0.0] * 10] * 20, seed=13), path)
    assert c3["sequences"] is None and "unrecorded" in c3["warning"]
    assert calibration_warning(MIN_CALIBRATION_SEQUENCES - 1) and calibration_warning(True)
    assert calibration_warning(MIN_CALIBRATION_SEQUENCES) is None


def test_calibrate_refuses_what_it_cannot_calibrate(tmp_path):
    path = str(tmp_path / "m.npz")
    m = _counted(metadata=BUILT)
    with pytest.raises(InputError, match="finite"):
        calibrate_model(m, _result([[0.1, 0.2]]), path)               # 2 steps: no 90% quantile
    with pytest.raises(InputError, match="contact"):
        calibrate_model(m, _result([[0.0] * 30], contact="other"), path)


def test_the_numba_range_equals_an_independent_bisection_on_random_rows():
    """The exact per-row kernel against plain bisection on the clipping levels (tests/kruskal_markov/test_answers.py),
    on rows of 2-64 cells with zeros, radii from 0 past the distance to uniform."""
    from kruskal_markov.structural import entropy_range_tv
    from tests.kruskal_markov.test_answers import _range_by_bisection

    rng = np.random.default_rng(45)
    for n in (2, 3, 7, 64):
        p = rng.dirichlet(np.full(n, 0.4), size=40)
        p[p < 0.03] = 0.0
        p[:, 0] += 1e-3
        d = rng.uniform(0, 1.1, size=40) * (rng.random(40) < 0.9)
        lo, hi = entropy_range_tv(p, d)
        for i in range(40):
            want = _range_by_bisection(p[i], min(d[i], 1.0))
            assert (lo[i], hi[i]) == pytest.approx(want, abs=1e-9), (n, i, d[i])


def test_row_variance_is_the_dirichlet_variance_of_each_rows_report_cells():
    """(1 - sum_j c_j^2) / (n + 1), checked by hand on a 3-state model: a row sampled once and a row
    whose samples agree on one cell add nothing; a row split 3:1 between two cells adds 0.375 / 5."""
    from kruskal_markov.structural import row_variance

    counts = sp.csr_matrix(np.array([[1, 0, 0],      # sampled once
                                     [0, 2, 2],      # 4 samples, targets 1 and 2 share cell 1
                                     [3, 0, 1]]))    # 3:1 between cells 0 and 1
    m = TransitionModel(["a"], [sp.csr_matrix((counts.data / np.repeat(np.asarray(counts.sum(1)).ravel(),
                                                                        np.diff(counts.indptr)),
                                               counts.indices, counts.indptr), shape=(3, 3))],
                        initial=np.full(3, 1 / 3), partition=np.array([0, 1, 1]), n_cells=2,
                        extras={"counts_0": counts.data.astype(np.int64)}, metadata=BUILT)
    v = row_variance(m)[0]
    assert v == pytest.approx([0.0, 0.0, (1 - 0.75 ** 2 - 0.25 ** 2) / 5])
    # a model without counts has no row variance (and no structural term)
    assert not np.any(row_variance(_automaton())[0])


def test_structural_flow_accumulates_the_row_variance_along_the_sequence():
    from kruskal_markov.entropy import entropy_trajectory
    from kruskal_markov.structural import row_variance, structural_flow

    m = _counted(metadata=BUILT)
    seq = [0, 2, 1, 1, 0]
    tr = entropy_trajectory(m, seq, return_distributions=True)
    v = row_variance(m)
    flow = structural_flow(m, seq, tr.distributions)
    by_hand = [0.0]
    for k, a in enumerate(seq):
        p = np.asarray(tr.distributions[k])
        by_hand.append(by_hand[-1] + sum(p[s] * v[a][s] for s in range(m.n_states)) / p.sum())
    assert flow == pytest.approx(by_hand)
    assert flow[0] == 0 and np.all(np.diff(flow) >= 0) and flow[-1] > 0
    with pytest.raises(ValueError, match="distributions"):
        structural_flow(m, seq, tr.distributions[:-1])


def test_flow_scores_divide_by_the_flow_and_a_band_at_the_score_holds_the_reference():
    from kruskal_markov.structural import band_with_structure, flow_scores, structural_score

    assert flow_scores([0.0, 0.4, 0.4, 0.0], [0.0, 2.0, 0.0, 0.0]).tolist() == [0.0, 0.2, math.inf, 0.0]
    cells = np.array([[0.7, 0.2, 0.1], [0.5, 0.3, 0.2], [0.6, 0.4, 0.0]])
    centre = np.array([1.10, 1.40, 0.95])
    width = np.full(3, 0.01)
    ref = np.array([1.25, 1.30, 0.80])
    flow = np.array([0.3, 0.5, 0.8])
    s = flow_scores(structural_score(cells, centre, width, ref), flow)
    for i in range(3):
        lo, hi = band_with_structure(cells[i:i + 1], centre[i:i + 1], width[i:i + 1], s[i] * flow[i] * 1.0001)
        assert lo[0] <= ref[i] <= hi[0]
        lo, hi = band_with_structure(cells[i:i + 1], centre[i:i + 1], width[i:i + 1], 0.97 * s[i] * flow[i])
        assert not lo[0] <= ref[i] <= hi[0]


def test_a_calibration_of_another_rule_is_not_used():
    """A stored delta of another rule (the flow rule, measured and not adopted) is on another scale: the
    model falls back to the default and says why. A record without a rule predates the name and is used."""
    m = _counted(metadata={**BUILT, "structural": {"delta": 2.27, "steps": 390, "seeds": [2031], "rule": "flow"}})
    t = structural_term(m)
    assert (t.delta, t.source) == (STRUCTURAL_DELTA, "default") and "another rule ('flow'" in t.note
    old = _counted(metadata={**BUILT, "structural": {"delta": 0.0119, "steps": 270, "seeds": [2031]}})
    assert (structural_term(old).delta, structural_term(old).source) == (0.0119, "calibrated")
    cal = with_calibration(m, 0.05, steps=60, seeds=[5])
    assert cal.metadata["structural"]["rule"] == "relative"
    assert (structural_term(cal).delta, structural_term(cal).source) == (0.05, "calibrated")


def test_every_note_and_error_is_its_whole_line():
    """The structural note is printed with every answer (``structural_note``) and the errors as one-line
    CLI errors: each whole, for every source."""
    import re

    m = _counted(metadata=BUILT)
    assert structural_term(m, 0.25).to_dict() == {"structural_delta": 0.25, "structural_source": "given",
                                                   "structural_note": "structural delta 0.25 given by the caller"}
    assert structural_term(m, 0).delta == 0.0 and structural_term(m, 0).source == "given"
    assert structural_term(m).note == ("structural delta 0.105: the allen key's calibration, this model has none "
                                       "of its own (`kruskal validate --calibrate` stores one)")
    other = _counted(metadata={**BUILT, "structural": {"delta": 2.27, "rule": "flow"}})
    assert structural_term(other).note == (
        "structural delta 0.105: the allen key's calibration; the model's stored calibration is of another "
        "rule ('flow'; `kruskal validate --calibrate` renews it)")
    cal = with_calibration(m, 0.0123456, steps=60, seeds=[5, 7], sequences=12)
    assert structural_term(cal).to_dict() == {
        "structural_delta": 0.0123456, "structural_source": "calibrated",
        "structural_note": "structural delta 0.01235 calibrated on this model (60 steps of 12 sequences of "
                           "`kruskal validate --calibrate`, seeds 5, 7)"}
    warning = ("fewer than 12: such a delta is unstable (docs/uncertainty.md); pool more `kruskal validate "
               "--calibrate` runs of other seeds")
    few = with_calibration(m, 0.0123456, steps=60, seeds=[5, 7], sequences=4)
    assert structural_term(few).note == ("structural delta 0.01235 calibrated on this model (60 steps of 4 sequences "
                                         "of `kruskal validate --calibrate`, seeds 5, 7); calibrated on 4 sequences, "
                                         + warning)
    bare = _counted(metadata={**BUILT, "structural": {"delta": 0}})
    assert structural_term(bare).to_dict() == {
        "structural_delta": 0.0, "structural_source": "calibrated",
        "structural_note": "structural delta 0 calibrated on this model (? steps of `kruskal validate --calibrate`, "
                           "seeds ?); calibrated on an unrecorded number of sequences, " + warning}
    for bad in (-0.1, math.nan, math.inf):
        with pytest.raises(ValueError, match="^" + re.escape(f"structural delta must be a non-negative number, got {bad!r}")
                           + "$"):
            structural_term(m, bad)
        with pytest.raises(ValueError, match="^" + re.escape(
                f"calibrated delta must be a finite non-negative number, got {bad!r}") + "$"):
            with_calibration(m, bad)
    with pytest.raises(ValueError, match="^only a built model has a structural term to calibrate$"):
        with_calibration(_counted(), 0.1)
    # a stored delta that is not a finite non-negative number is no calibration: the default
    for rec in ({"delta": -1.0}, {"delta": "0.1"}, {"steps": 3}, "0.1"):
        t = structural_term(_counted(metadata={**BUILT, "structural": rec}))
        assert (t.delta, t.source) == (STRUCTURAL_DELTA, "default"), rec


def test_a_calibrated_copy_is_the_same_model_with_its_record():
    c = _counted(metadata=BUILT)
    m = TransitionModel(c.actions, c.matrices, initial=c.initial, partition=c.partition, n_cells=c.n_cells,
                        metadata=BUILT, tol=1e-6, extras=c.extras)          # a tolerance other than the default
    cal = with_calibration(m, 0.05, steps=60, seeds=[5], level=0.9)
    assert cal.metadata["structural"] == {"delta": 0.05, "steps": 60, "seeds": [5], "level": 0.9, "rule": "relative"}
    assert {k: v for k, v in cal.metadata.items() if k != "structural"} == m.metadata
    assert "structural" not in m.metadata                               # the original is left alone
    assert cal.actions == m.actions and cal.n_cells == m.n_cells and cal.tol == m.tol
    assert np.array_equal(cal.initial, m.initial) and np.array_equal(cal.partition, m.partition)
    for a in range(m.n_actions):
        assert (cal.matrices[a] != m.matrices[a]).nnz == 0
        assert np.array_equal(cal.extras[f"counts_{a}"], m.extras[f"counts_{a}"])


def test_only_a_model_built_with_statistics_and_counts_is_sampled():
    counts = _counted()
    assert is_sampled(_counted(metadata=BUILT))
    assert not is_sampled(_counted(metadata={**BUILT, "kind": "kruskal.automaton"}))
    assert not is_sampled(_counted(metadata={**BUILT, "stats": "12 states"}))
    assert not is_sampled(_counted(metadata={k: v for k, v in BUILT.items() if k != "stats"}))
    no_counts = TransitionModel(counts.actions, counts.matrices, initial=counts.initial, partition=counts.partition,
                                n_cells=counts.n_cells, metadata=BUILT)
    assert not is_sampled(no_counts)
