"""The fit's model-error term (analysis/fit/model_error.py): builds that disagree widen the interval.

The synthetic family of test_fit.py, with build noise planted: a build of coefficient ``mu`` with
build seed ``s`` is the family at ``mu + delta``, ``delta ~ N(0, 0.03)`` drawn from ``(s, mu)`` (a
grid model that is its own sampled build). The log comes from the exact family, so the likelihood
is misspecified the way a physics log's is; the trials alone say nothing about it.
"""
from __future__ import annotations

import numpy as np
import pytest

from analysis.fit import FitSettings, fit_log, read_fit_log
from analysis.fit.model_error import model_error, trials_needed
from tests.analysis.test_fit import synthetic_log, synthetic_model

PLANTED_SD = 0.03


@pytest.fixture(scope="module")
def scene():
    from tests.analysis.test_fit import SHAPE
    from transition_builder.scene import scene_from_options
    return scene_from_options(SHAPE)


def _noisy_build(sc, st):
    mu = sc.friction.mu
    delta = np.random.default_rng([int(st.seed), int(round(mu * 1e6))]).normal(0.0, PLANTED_SD)
    return synthetic_model(sc, float(np.clip(mu + delta, 0.01, 0.9))), "synthetic"


def _fit(scene, path, seed, replicates=1, build=_noisy_build):
    """The fit of one log; its grid's builds use build seed ``1000 + seed`` (each log its own builds)."""
    from transition_builder.builder import BuildSettings

    log = read_fit_log(path, scene.actions, (scene.tray_x_mm, scene.tray_y_mm))
    s = FitSettings(ranges={"mu": (0.1, 0.5)}, points={"mu": 9}, camera=(0.5, 0.5), seed=seed, bootstrap=200,
                    replicates=replicates)
    return fit_log(scene, log, s, build=build, build_settings=BuildSettings(seed=1000 + seed))


def test_planted_build_noise_widens_the_interval_to_cover(scene, tmp_path):
    """10 logs at coefficients drawn before looking (each with its own grid of builds): the interval with the model term covers >= 8 of 10 (a 90% interval does so with
    probability 0.93) and is wider on every log than the trials-only interval, which covers fewer."""
    truths = np.random.default_rng(4144).uniform(0.2, 0.4, 10)
    covered = trials_only = 0
    for i, mu in enumerate(truths):
        path = tmp_path / f"log{i}.csv"
        synthetic_log(scene, path, mu, trials=200, tilts=15, seed=300 + i)
        r = _fit(scene, path, seed=i).to_dict()
        lo, hi = r["interval_90"]["mu"]
        tlo, thi = r["interval_90_trials_only"]["mu"]
        covered += lo <= mu <= hi
        trials_only += tlo <= mu <= thi
        assert hi - lo > thi - tlo
        assert r["model_error"]["replicated_points"] and len(r["models"]) == len(r["criterion"]) + 3
    assert covered >= 8
    assert trials_only < covered


def test_model_dominated_fit_says_more_trials_do_not_help(scene, tmp_path):
    path = tmp_path / "log.csv"
    synthetic_log(scene, path, 0.31, trials=300, tilts=20, seed=77)
    r = _fit(scene, path, seed=1).to_dict()
    need = r["trials_needed"]
    assert need["dominated_by"] == "model" and need["model_sd"] > need["bootstrap_sd"]
    assert need["half_width_90"]["0.01"] is None            # the builds' error alone exceeds it


def test_exact_models_keep_a_narrow_interval(scene, tmp_path):
    """Replicates of exact (noise-free) builds agree: the model term stays small beside the trials'."""
    path = tmp_path / "log.csv"
    synthetic_log(scene, path, 0.33, trials=300, tilts=20, seed=1)
    r = _fit(scene, path, seed=0, build=lambda sc, st: (synthetic_model(sc, sc.friction.mu), "synthetic")).to_dict()
    assert r["model_error"]["replicate_differences"] == [0.0, 0.0, 0.0]
    lo, hi = r["interval_90"]["mu"]
    assert lo <= 0.33 <= hi and hi - lo < 0.06
    assert r["trials_needed"]["dominated_by"] != "model"       # the builds agree: not their error
    assert r["model_error"]["resolution"] == pytest.approx(0.025)   # 0.05 refined once


def test_model_error_carries_the_larger_of_replicates_and_residuals():
    x = np.linspace(0.2, 0.4, 5)
    y = -1000 * (x - 0.3) ** 2                         # an exact quadratic: no residual
    e = model_error(x, y, np.ones(5), 2, [3.0, -4.0])
    assert e.replicate_sd == pytest.approx(np.sqrt((9 + 16) / 2 / 2))
    assert e.residual_sd == pytest.approx(0.0, abs=1e-6)
    assert e.var == pytest.approx((9 + 16) / 2 / 2) and e.dof == 2      # the larger of the two is carried
    bumpy = y + np.array([0.0, 50.0, 0.0, -50.0, 0.0])
    e = model_error(x, bumpy, np.ones(5), 2, [3.0, -4.0])
    assert e.var == pytest.approx(e.residual_sd ** 2) and e.var > 100
    assert model_error(x[1:4], y[1:4], np.ones(3), 1, []).var is None     # nothing measured it


def test_trials_needed_splits_the_terms():
    need = trials_needed(500, sd_trials=0.004, sd_model=0.001)
    assert need["dominated_by"] == "trials"
    h = 0.01 / 1.6448536
    assert need["half_width_90"]["0.01"] == int(np.ceil(500 * 0.004 ** 2 / (h ** 2 - 0.001 ** 2)))
    assert trials_needed(500, 0.001, 0.02)["half_width_90"] == {"0.01": None, "0.02": None, "0.05": 1}
    grid = trials_needed(500, 0.001, 0.008, sd_resolution=0.0072)
    assert grid["dominated_by"] == "grid resolution" and "finer grid" in grid["note"]


def test_camera_noise_below_the_models_tolerance_is_not_called_an_estimate(scene, tmp_path):
    path = tmp_path / "log.csv"
    synthetic_log(scene, path, 0.3, trials=100, tilts=10, seed=5)

    def coarse(sc, st):       # the same family, labelled as 2 mm / 2 degree snapped states
        m = synthetic_model(sc, sc.friction.mu)
        m.metadata["build_settings"] = {"tol_mm": 2.0, "tol_deg": 2.0}
        return m, "synthetic"

    log = read_fit_log(path, scene.actions, (scene.tray_x_mm, scene.tray_y_mm))
    r = fit_log(scene, log, FitSettings(ranges={"mu": (0.1, 0.5)}, points={"mu": 9}, bootstrap=50), build=coarse)
    cam = r.camera_noise
    assert cam["estimated"] and cam["model_tolerance"] == {"mm": 2.0, "deg": 2.0}
    assert cam["identifiable"] is (cam["mm"] > 2.0)
    if not cam["identifiable"]:
        assert "not identifiable" in cam["note"]
    exact = _fit(scene, path, seed=0, build=lambda sc, st: (synthetic_model(sc, sc.friction.mu), "synthetic"))
    assert exact.camera_noise["model_tolerance"] == {"mm": 0.0, "deg": 0.0}


def test_command_line_reports_the_model_error(monkeypatch, scene, tmp_path, capsys):
    """``kruskal fit`` (builds stood in by the noisy family): the JSON's model-error keys, replicate
    models labelled ``mu#1``, and the text summary naming the dominating term."""
    import json
    from types import SimpleNamespace

    import transition_builder.cache as cache
    from analysis.cli import main
    from tests.analysis.test_fit import SHAPE

    monkeypatch.setattr(cache, "cached_build",
                        lambda sc, st, **kw: (SimpleNamespace(model=_noisy_build(sc, st)[0]), f"{sc.friction}", None))
    path = tmp_path / "log.csv"
    synthetic_log(scene, path, 0.31, trials=150, tilts=12, seed=21)
    args = ["fit", "--poses", str(path), "--shape", SHAPE, "--range", "0.1..0.5", "--points", "9",
            "--camera-noise", "0.5,0.5", "--bootstrap", "50"]
    assert main([*args, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {"model_error", "interval_90_trials_only"} <= set(out)
    assert sum(k.endswith("#1") for k in out["models"]) == 3
    assert out["trials_needed"]["dominated_by"] in ("trials", "model", "grid resolution")
    assert main([*args, "--replicates", "0", "--json"]) == 0
    assert not any(k.endswith("#1") for k in json.loads(capsys.readouterr().out)["models"])
    assert main(args) == 0
    assert "the interval is dominated by: " + out["trials_needed"]["dominated_by"] in capsys.readouterr().out
    assert main([*args, "--replicates", "-1"]) == 2
    assert "--replicates" in capsys.readouterr().err


def test_estimators_on_a_criterion_with_a_cliff():
    """A misspecified curve: the best model at 0.275 and a cliff at 0.3 (the shape of a spent
    validation log, docs/fit.md). The vertex of the window's quadratic is pulled away from the best
    point; the grid estimate stays on it, and its resampled interval (builds' noise plus the
    resolution term) contains the estimate."""
    from analysis.fit.model_error import ESTIMATORS, best_point, resample_vertices, weighted_vertex

    x = np.array([0.15, 0.2, 0.225, 0.25, 0.275, 0.3, 0.35, 0.4])
    y = np.array([-147e3, -100e3, -70e3, -30e3, -16e3, -119e3, -193e3, -216e3])
    n = np.ones(len(x))
    j = int(np.argmax(y))
    assert best_point(x, y, n, j) == 0.275 and ESTIMATORS["grid"] is best_point
    assert abs(weighted_vertex(x, y, n, j) - 0.275) > 0.02        # the quadratic's pull
    err = model_error(x, y, n, j, [], resolution=0.025)
    L = np.tile(y / 10, (10, 1))                                  # 10 identical trials
    v = resample_vertices(x, L, n, err, np.random.default_rng(0), 400, estimator=best_point)
    lo, hi = np.quantile(v, [0.05, 0.95])
    assert lo < 0.275 < hi
    assert np.all(np.abs(v - np.round(v / 0.025) * 0.025) <= 0.0125 + 1e-12)   # grid points +- h/2


def test_estimator_setting_and_option(monkeypatch, scene, tmp_path, capsys):
    """``--estimator vertex`` gives version 2's estimate, the default the best grid point; an unknown
    estimator is refused."""
    import json
    from types import SimpleNamespace

    import transition_builder.cache as cache
    from analysis.cli import main
    from tests.analysis.test_fit import SHAPE

    with pytest.raises(ValueError, match="estimator"):
        FitSettings(estimator="median")
    monkeypatch.setattr(cache, "cached_build",
                        lambda sc, st, **kw: (SimpleNamespace(model=_noisy_build(sc, st)[0]), f"{sc.friction}", None))
    path = tmp_path / "log.csv"
    synthetic_log(scene, path, 0.31, trials=150, tilts=12, seed=21)
    args = ["fit", "--poses", str(path), "--shape", SHAPE, "--range", "0.1..0.5", "--points", "9",
            "--camera-noise", "0.5,0.5", "--bootstrap", "50", "--json"]
    assert main(args) == 0
    grid = json.loads(capsys.readouterr().out)
    assert any(abs(c["mu"] - grid["estimate"]["mu"]) < 1e-6 for c in grid["criterion"])   # a grid point
    lo, hi = grid["interval_90"]["mu"]
    assert lo <= grid["estimate"]["mu"] <= hi
    assert main([*args, "--estimator", "vertex"]) == 0
    vertex = json.loads(capsys.readouterr().out)
    assert vertex["criterion"] == grid["criterion"]
    assert main([*args, "--estimator", "median"]) == 2
