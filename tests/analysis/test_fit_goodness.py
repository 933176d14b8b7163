"""The fit's goodness of fit (analysis/fit/goodness.py), on the exact synthetic family of test_fit.py.

The log's statistic is recomputed by hand from the exact prediction (each trial's start cell
propagated through its tilts); logs drawn from the model are explained at the stated rate; a log
from far elsewhere in the family is not.
"""
from __future__ import annotations

import numpy as np
import pytest

from analysis.fit import read_fit_log
from analysis.fit.goodness import ALPHA, goodness_of_fit, simulate_cell_histograms
from analysis.fit.histograms import log_histograms
from analysis.montecarlo import report_grid_for
from tests.analysis.test_fit import synthetic_log, synthetic_model


@pytest.fixture(scope="module")
def scene():
    from tests.analysis.test_fit import SHAPE
    from transition_builder.scene import scene_from_options
    return scene_from_options(SHAPE)


def _log(scene, tmp_path, mu, seed, trials=100, tilts=6):
    path = tmp_path / f"log{seed}.csv"
    synthetic_log(scene, path, mu, trials=trials, tilts=tilts, seed=seed)
    return read_fit_log(path, scene.actions, (scene.tray_x_mm, scene.tray_y_mm))


def _exact_prediction(model, log, grid):
    """(L+1, cells): the mean over trials of each trial's exact cell distribution, started in its
    observed start cell's state (a dense loop, independent of the sampler)."""
    mats = [m.toarray() if hasattr(m, "toarray") else np.asarray(m) for m in model.matrices]
    part = np.asarray(model.partition)
    cell_state = {int(part[s]): s for s in np.flatnonzero(np.asarray(model.initial) > 0)}
    L1 = log.obs.shape[1]
    pred = np.zeros((L1, model.n_cells))
    for t in range(log.trials):
        v = np.zeros(model.n_states)
        v[cell_state[int(grid.voxel_index(log.obs[t, 0][None])[0])]] = 1.0
        for k in range(L1):
            if k:
                v = v @ mats[log.actions[t, k - 1]]
            pred[k] += np.bincount(part, weights=v, minlength=model.n_cells)
    return pred / log.trials


def test_the_logs_statistic_recomputed_by_hand(scene, tmp_path):
    grid = report_grid_for(scene)
    log = _log(scene, tmp_path, 0.3, seed=31)
    model = synthetic_model(scene, 0.3)
    counts = log_histograms(log, grid)
    g = goodness_of_fit(model, log, grid, counts, np.random.default_rng(1), draws=2000)
    p = _exact_prediction(model, log, grid)
    n = counts[1:].sum(axis=1, keepdims=True)
    by_hand = float(np.mean(0.5 * np.abs(counts[1:] / n - p[1:]).sum(axis=1)))
    assert g["log"] == pytest.approx(by_hand, abs=0.01)     # the prediction is the mean of 2,000 simulated logs
    # the p-value from the same draws, recounted
    sim = simulate_cell_histograms(model, log, grid, np.random.default_rng(1), 2000)
    ps = (sim / sim.sum(axis=2, keepdims=True)).mean(axis=0)
    d = 0.5 * np.abs(sim[:, 1:] / sim[:, 1:].sum(axis=2, keepdims=True) - ps[1:]).sum(axis=2).mean(axis=1)
    assert g["p_value"] == pytest.approx((1 + np.sum(d >= g["log"])) / 2001)
    assert g["model_95"] == pytest.approx(np.quantile(d, 0.95))
    # the simulated histograms' mean is the exact prediction
    assert np.abs(ps - p).max() < 0.01


def test_logs_from_the_model_are_explained_and_a_far_log_is_not(scene, tmp_path):
    grid = report_grid_for(scene)
    model = synthetic_model(scene, 0.3)
    verdicts = []
    for seed in range(40, 52):
        log = _log(scene, tmp_path, 0.3, seed=seed)
        verdicts.append(goodness_of_fit(model, log, grid, log_histograms(log, grid), np.random.default_rng(seed),
                                        draws=200)["verdict"])
    assert verdicts.count("explained") >= 11              # each fails with probability ALPHA
    far = _log(scene, tmp_path, 0.05, seed=60)
    g = goodness_of_fit(model, far, grid, log_histograms(far, grid), np.random.default_rng(0), draws=200)
    assert g["verdict"] == "not explained" and g["p_value"] < ALPHA


def test_a_sibling_build_widens_the_reference(scene, tmp_path):
    """Reference logs drawn from a sibling (here the family at 0.33 standing in for another build of
    0.3), scored against the model's own prediction: recounted from the same draws, and wider."""
    grid = report_grid_for(scene)
    log = _log(scene, tmp_path, 0.3, seed=33)
    model, sib = synthetic_model(scene, 0.3), synthetic_model(scene, 0.33)
    counts = log_histograms(log, grid)
    own = goodness_of_fit(model, log, grid, counts, np.random.default_rng(2), draws=300)
    g = goodness_of_fit(model, log, grid, counts, np.random.default_rng(2), draws=300, sibling=sib)
    rng = np.random.default_rng(2)
    sim = simulate_cell_histograms(model, log, grid, rng, 300)
    ref = simulate_cell_histograms(sib, log, grid, rng, 300)
    p = (sim / sim.sum(axis=2, keepdims=True)).mean(axis=0)
    d = 0.5 * np.abs(ref[:, 1:] / ref[:, 1:].sum(axis=2, keepdims=True) - p[1:]).sum(axis=2).mean(axis=1)
    assert g["p_value"] == pytest.approx((1 + np.sum(d >= g["log"])) / 301)
    assert g["log"] == own["log"] and g["reference"] == "sibling build"
    assert g["model_95"] > own["model_95"]
