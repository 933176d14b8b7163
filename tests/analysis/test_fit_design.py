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
