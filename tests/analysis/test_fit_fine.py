"""Estimates finer than the grid (``FitSettings.local``, the ``local`` estimator; docs/fit.md).

The exact synthetic family of test_fit.py: a log drawn at a coefficient between grid points, the
grid refined, a fine local patch of models around the best point, the estimate the vertex of the
quadratic through the patch. The estimate is recomputed here by hand from the criterion the fit
reports, and its error shrinks as the log grows.
"""
from __future__ import annotations

import numpy as np
import pytest

from analysis.fit import FitSettings, fit_log, read_fit_log
from analysis.fit.model_error import patch_vertex
from tests.analysis.test_fit import synthetic_log, synthetic_model


@pytest.fixture(scope="module")
def scene():
    from tests.analysis.test_fit import SHAPE
    from transition_builder.scene import scene_from_options
    return scene_from_options(SHAPE)


def _exact(sc, st):
    return synthetic_model(sc, sc.friction.mu), "synthetic"


def _fit(scene, path, local=4, estimator="local", seed=0):
    log = read_fit_log(path, scene.actions, (scene.tray_x_mm, scene.tray_y_mm))
    s = FitSettings(ranges={"mu": (0.1, 0.5)}, points={"mu": 5}, camera=(0.5, 0.5), seed=seed, bootstrap=100,
                    replicates=0, local=local, estimator=estimator)
    return fit_log(scene, log, s, build=_exact)


def test_local_estimate_is_the_patch_quadratic_recomputed_by_hand(scene, tmp_path):
    path = tmp_path / "log.csv"
    synthetic_log(scene, path, 0.333, trials=300, tilts=15, seed=11)
    r = _fit(scene, path).to_dict()
    rows = sorted((c["mu"], c["loglik"]) for c in r["criterion"])
    x, y = np.array(rows).T
    best = x[int(np.argmax(y))]
    # the grid: 0.1..0.5 at 0.1, one refinement (0.05), then 4 models each side at 0.01
    fine = np.round(np.diff(x), 6)
    assert 0.01 in fine and len(x) >= 5 + 2 + 8
    # the patch: the best point +- 0.05 (re-centred on the best fine model), 11 models at 0.01
    lo, hi = best - 0.05, best + 0.05
    inside = (x >= lo - 1e-9) & (x <= hi + 1e-9)
    assert inside.sum() == 11
    a, b, _ = np.polyfit(x[inside], y[inside], 2)
    vertex = float(np.clip(-b / (2 * a), lo, hi))
    assert a < 0
    assert r["estimate"]["mu"] == pytest.approx(vertex, abs=1e-6)
    assert abs(vertex - 0.333) < 0.01                 # finer than the grid's 0.05 and its fine 0.01
    lo90, hi90 = r["interval_90"]["mu"]
    assert lo90 <= 0.333 <= hi90
    assert r["model_error"]["resolution"] == pytest.approx(0.01)


def test_local_estimate_error_shrinks_as_the_log_grows(scene, tmp_path):
    """4 truths drawn before looking (``default_rng(5151).uniform(0.2, 0.4, 4)``), logs of 100 and
    1,000 trials (the first 100 of the same draw are not a prefix: each size its own seed): the mean
    absolute error at 1,000 is below that at 100, and below the grid estimator's at 1,000."""
    truths = np.random.default_rng(5151).uniform(0.2, 0.4, 4)
    err = {100: [], 1000: []}
    grid_err = []
    for i, mu in enumerate(truths):
        for n in err:
            path = tmp_path / f"log{i}_{n}.csv"
            synthetic_log(scene, path, mu, trials=n, tilts=10, seed=500 + 10 * i + (n == 1000))
            err[n].append(abs(_fit(scene, path).estimate["mu"] - mu))
            if n == 1000:
                grid_err.append(abs(_fit(scene, path, local=0, estimator="grid").estimate["mu"] - mu))
    assert np.mean(err[1000]) < np.mean(err[100])
    assert np.mean(err[1000]) < np.mean(grid_err)
    assert np.mean(err[1000]) < 0.005


def test_patch_vertex_without_patch_is_the_best_point():
    x = np.array([0.1, 0.2, 0.3])
    y = np.array([-3.0, -1.0, -2.0])
    assert patch_vertex(x, y, np.ones(3), 1) == 0.2
    # a convex patch: its best point
    assert patch_vertex(x, np.array([-1.0, -3.0, -2.0]), np.ones(3), 0, lo=0.1, hi=0.3) == 0.1


def test_bad_local_options_one_line(tmp_path, capsys):
    from analysis.cli import main
    path = tmp_path / "log.csv"
    path.write_text("trial,step,x_mm,y_mm,theta_rad,status,action\n0,0,50,50,0,ok,\n")
    for argv in (["--local", "-1"], ["--estimator", "local"]):
        assert main(["fit", "--poses", str(path), "--sequence", "N", *argv]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--local" in err[0]


def test_local_interval_ends_agree_with_the_likelihood_curvature(scene, tmp_path):
    """The ``--local`` fit's interval ends recomputed a second way. With exact models the only errors
    are the trials' and the fine grid's resolution; the trials' sd is ``1 / sqrt(-2a)`` from the
    curvature ``a`` of the quadratic through the patch's reported criterion (the observed Fisher
    information, Pawitan 2001, sec. 2.5), the resolution's ``h / sqrt(12)`` (a uniform error over
    the fine spacing ``h``). The bootstrap's trials-only interval is the estimate +- 1.645 sd_trials,
    and the full interval the estimate +- 1.645 sqrt(sd_trials^2 + h^2 / 12), each within 15%
    of its half-width (an 80% interval, 1.28 sd, would be 22% short; measured: within 5%)."""
    path = tmp_path / "log.csv"
    synthetic_log(scene, path, 0.287, trials=400, tilts=12, seed=31)
    log = read_fit_log(path, scene.actions, (scene.tray_x_mm, scene.tray_y_mm))
    s = FitSettings(ranges={"mu": (0.1, 0.5)}, points={"mu": 5}, camera=(0.5, 0.5), seed=3, bootstrap=400,
                    replicates=0, local=4, estimator="local")
    r = fit_log(scene, log, s, build=_exact).to_dict()
    lo, hi = r["model_error"]["local_patch"]
    rows = sorted((c["mu"], c["loglik"]) for c in r["criterion"] if lo - 1e-9 <= c["mu"] <= hi + 1e-9)
    x, y = np.array(rows).T
    a, b, _ = np.polyfit(x, y, 2)
    est = r["estimate"]["mu"]
    sd_trials = 1 / np.sqrt(-2 * a)
    h = r["model_error"]["resolution"]
    for key, sd in (("interval_90_trials_only", sd_trials), ("interval_90", np.hypot(sd_trials, h / np.sqrt(12)))):
        ends = r[key]["mu"]
        half = 1.6448536 * sd
        assert ends[0] == pytest.approx(est - half, abs=0.15 * half), key
        assert ends[1] == pytest.approx(est + half, abs=0.15 * half), key
