"""``kruskal fit --design`` (analysis/fit/design.py) on the exact synthetic family of test_fit.py.

The family's Fisher information is known in closed form (after the first tilt the camera sees the
state, and each tilt is a Bernoulli(mu) choice between two successors): the design's estimate from
simulated trials and the models' log-likelihoods is checked against it, and the predicted widths
and the recommendation against their formulas.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.fit.design import DesignSettings, design, fisher_information, predicted_width
from analysis.montecarlo import report_grid_for
from tests.analysis.test_fit import _family, synthetic_model

MU0, STEP = 0.3, 0.02


@pytest.fixture(scope="module")
def scene():
    from tests.analysis.test_fit import SHAPE
    from transition_builder.scene import scene_from_options
    return scene_from_options(SHAPE)


def exact_information(scene, seq, mu):
    """Per-trial Fisher information of the family along ``seq`` (unobserved start, exact states after)."""
    grid, poses, n_start, first, second, _ = _family(scene)
    n_rest = len(poses)
    a = seq[0]
    c1 = np.bincount(first[a, :n_start], minlength=n_rest) / n_start
    c2 = np.bincount(second[a, :n_start], minlength=n_rest) / n_start
    p = (1 - mu) * c1 + mu * c2
    seen = p > 0
    info = float(np.sum((c2[seen] - c1[seen]) ** 2 / p[seen]))
    dist = p
    for a in seq[1:]:
        split = first[a, n_start:] != second[a, n_start:]
        info += float(np.sum(dist[split])) / (mu * (1 - mu))
        nxt = np.zeros(n_rest)
        np.add.at(nxt, first[a, n_start:], (1 - mu) * dist)
        np.add.at(nxt, second[a, n_start:], mu * dist)
        dist = nxt
    return info


def test_information_matches_the_closed_form(scene):
    grid = report_grid_for(scene)
    models = [synthetic_model(scene, m) for m in (MU0 - STEP, MU0, MU0 + STEP)]
    seq = [int(v) for v in np.random.default_rng(71).integers(0, 8, 8)]
    got = fisher_information(models, seq, STEP, 3000, (0.5, 0.5), np.random.default_rng(72), grid)
    exact = exact_information(scene, seq, MU0)
    assert got["per_trial"] == pytest.approx(exact, rel=0.05, abs=3 * got["se"])


def test_widths_and_recommendation_follow_their_formulas(scene):
    grid = report_grid_for(scene)
    models = [synthetic_model(scene, m) for m in (MU0 - STEP, MU0, MU0 + STEP)]
    rng = np.random.default_rng(73)
    randoms = [list(rng.integers(0, 8, 6)) for _ in range(3)]
    s = DesignSettings(at=(MU0,), step=STEP, sequences=3, tilts=6, trials=200, target=0.02, simulated=300)
    out = design([models], scene.actions, s, grid, randoms)
    assert len(out["candidates"]) == 4 and out["candidates"][-1]["designed"]
    designed = out["candidates"][-1]["sequence"]
    assert len(designed) == 6 and all(a != b for a, b in zip(designed, designed[1:]))   # never a tilt twice
    for c in out["candidates"]:
        i = c["information_per_trial"]
        assert c["predicted_width_90"]["mu"] == pytest.approx(2 * 1.6448536 / math.sqrt(200 * i))
    best = max(out["candidates"], key=lambda c: c["information_per_trial"])
    rec = out["recommended"]
    assert rec["sequence"] == best["sequence"]
    assert rec["trials"] == math.ceil((2 * 1.6448536 / 0.02) ** 2 / best["information_per_trial"])
    assert rec["predicted_width_90"]["mu"] <= 0.02 < predicted_width(best["information_per_trial"], rec["trials"] - 1)


def test_maximin_takes_each_candidates_smallest_information(scene):
    """Two points of the prior range: a candidate's information is the smaller of its two, and the
    recommendation the candidate whose smaller one is the largest."""
    grid = report_grid_for(scene)
    at = (0.2, 0.4)
    sets = [[synthetic_model(scene, m) for m in (mu - STEP, mu, mu + STEP)] for mu in at]
    rng = np.random.default_rng(74)
    randoms = [list(rng.integers(0, 8, 6)) for _ in range(2)]
    s = DesignSettings(at=at, step=STEP, sequences=2, tilts=6, trials=200, simulated=300)
    out = design(sets, scene.actions, s, grid, randoms)
    for c in out["candidates"]:
        assert len(c["information_by_point"]) == 2
        assert c["information_per_trial"] == min(c["information_by_point"])
    best = max(out["candidates"], key=lambda c: min(c["information_by_point"]))
    assert out["recommended"]["sequence"] == best["sequence"] and out["at"] == [0.2, 0.4]


def test_bad_design_options_one_line(tmp_path, capsys):
    from analysis.cli import main
    for argv in (["--design", "--poses", str(tmp_path / "x.csv")], ["--design", "--fit", "mu,noise"],
                 ["--design", "--at", "0.01"], ["--design", "--at", "x"], ["--design", "--trials", "0"], []):
        assert main(["fit", *argv]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1, argv


def test_design_command_keys_and_determinism(tmp_path, monkeypatch, capsys):
    """The command on a small planar case (rectangle, 2 mm builds): SPEC's keys, and the same seed
    gives the same candidates and recommendation."""
    import json

    from analysis.cli import main
    monkeypatch.setenv("KRUSKAL_CACHE", str(tmp_path / "cache"))
    argv = ["fit", "--design", "--shape", "rectangle:60x20", "--engine", "planar", "--resolution", "2,2",
            "--start-samples", "200", "--recenter-rounds", "0", "--sequences", "2", "--tilts", "5",
            "--trials", "100", "--workers", "1", "--seed", "3", "--at", "0.3", "--json"]
    outs = []
    for _ in range(2):
        assert main(argv) == 0
        outs.append(json.loads(capsys.readouterr().out))
    a, b = outs
    assert {"candidates", "recommended", "seconds"} <= set(a)
    assert len(a["candidates"]) == 3
    for c in a["candidates"]:
        assert len(c["sequence"]) == 5 and set(c["predicted_width_90"]) == {"mu"}
    assert {"sequence", "trials"} <= set(a["recommended"])
    for k in ("candidates", "recommended"):
        assert a[k] == b[k]


# --- the recommended sequence against random ones, where the trials limit the fit ------------------
# On the key the models' own error dominates every interval (docs/fit.md), so no sequence can narrow
# it; here the models are exact and the trials are the limit. Four of the eight tilts are made
# uninformative (the second successor is the first: mu does not act), so a random sequence spends
# about half its tilts on nothing, and the design must find the other half.

INFORMATIVE = (0, 2, 4, 6)


def _masked_family(scene):
    grid, poses, n_start, first, second, third = _family(scene)
    second = second.copy()
    for a in range(8):
        if a not in INFORMATIVE:
            second[a] = first[a]
    return grid, poses, n_start, first, second, third


def masked_model(scene, mu):
    """The family at ``mu`` with only :data:`INFORMATIVE` tilts acting on mu."""
    return synthetic_model(scene, mu, family=_masked_family)


def masked_log(scene, mu, trials, seq, seed):
    """A :class:`~analysis.fit.log.FitLog` of the masked family at ``mu`` along ``seq`` (camera 0.5)."""
    from tests.analysis.test_fit_calibration import family_log

    return family_log(scene, mu, trials, seq, seed, (0.5, 0.5), family=_masked_family)


def test_recommended_sequence_gives_narrower_intervals_than_random_ones(scene):
    """The design (maximin over 0.25 and 0.35, three random candidates of 12 tilts drawn from
    ``default_rng(8484)``) recommends its designed sequence, made of informative tilts only; logs of
    600 trials at four truths named before looking (``default_rng(8383).uniform(0.25, 0.35, 4)``)
    along the recommended sequence and along each random candidate are fitted by the exact models
    (fit seeds 900 + i and 950 + 10 i + j):
    the recommended sequence's realised 90% interval (trials only) is narrower than every random
    candidate's at every truth, and the mean ratio of widths is the predicted one within 25%
    (measured: 0.019-0.022 against 0.021-0.032, mean ratio 1.28 against 1.34 predicted; a first
    version at 120 trials compared nothing: every width was the local patch's, 0.05)."""
    from analysis.fit import FitSettings, fit_log

    grid = report_grid_for(scene)
    s = DesignSettings(at=(0.25, 0.35), step=STEP, sequences=3, tilts=12, trials=600, simulated=200,
                       camera=(0.5, 0.5), seed=2)
    sets = [tuple(masked_model(scene, m + d) for d in (-STEP, 0.0, STEP)) for m in s.at]
    randoms = [list(r) for r in np.random.default_rng(8484).integers(0, 8, (3, 12))]
    out = design(sets, scene.actions, s, grid, randoms)
    rec = out["recommended"]
    # the greedy rule measures how far apart the predictions are, not what a tilt adds: it may still
    # spend a tilt where mu does not act (measured: 10 of 12 informative, against 3-7 of 12 at random)
    assert rec["designed"] and sum(scene.actions.index(a) in INFORMATIVE for a in rec["sequence"]) >= 9
    rec_seq = [scene.actions.index(a) for a in rec["sequence"]]

    def build(sc, st):
        return masked_model(sc, sc.friction.mu), "masked"

    def width(seq, mu, seed):
        fs = FitSettings(ranges={"mu": (0.15, 0.45)}, points={"mu": 7}, camera=(0.5, 0.5), seed=seed,
                         bootstrap=200, replicates=0, local=3, estimator="local", gof_draws=20, gof_sibling=False)
        r = fit_log(scene, masked_log(scene, mu, 600, seq, seed), fs, build=build).to_dict()
        lo, hi = r["interval_90_trials_only"]["mu"]
        return hi - lo

    ratios = []
    for i, mu in enumerate(np.random.default_rng(8383).uniform(0.25, 0.35, 4)):
        w_rec = width(rec_seq, mu, 900 + i)
        w_rand = [width(q, mu, 950 + 10 * i + j) for j, q in enumerate(randoms)]
        assert w_rec < min(w_rand)
        ratios.append(np.mean(w_rand) / w_rec)
    info = {tuple(c["sequence"]): c["information_per_trial"] for c in out["candidates"]}
    predicted = np.mean([np.sqrt(info[tuple(rec["sequence"])] / info[tuple(scene.actions[a] for a in q)])
                         for q in randoms])
    assert np.mean(ratios) == pytest.approx(predicted, rel=0.25)
