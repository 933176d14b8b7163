"""Logs as a camera gives them (docs/fit.md): wild misreads inside and outside the tray.

The exact synthetic family of test_fit.py; a clean log and its copy with 3% of its observed poses
replaced by wild ones (2% uniform over the tray, 1% outside it) give the same estimate within half
the clean fit's interval; a log with more than a tenth of its poses outside the tray is refused.
"""
from __future__ import annotations

import csv

import numpy as np
import pytest

from analysis.cli import main
from analysis.fit import FitSettings, fit_log, read_fit_log
from tests.analysis.test_fit import synthetic_log, synthetic_model


@pytest.fixture(scope="module")
def scene():
    from tests.analysis.test_fit import SHAPE
    from transition_builder.scene import scene_from_options
    return scene_from_options(SHAPE)


def misread_copy(src, dst, inside: float, outside: float, tray, seed: int) -> int:
    """``src`` with ``inside`` of its ok rows' poses uniform over the tray and ``outside`` of them
    beyond its far x wall; returns how many lie outside."""
    with open(src, newline="") as fh:
        rows = list(csv.reader(fh))
    ok = [k for k, r in enumerate(rows[1:], 1) if r[5] == "ok" and r[1] != "0"]
    rng = np.random.default_rng(seed)
    n_in, n_out = round(inside * len(ok)), round(outside * len(ok))
    pick = rng.choice(ok, n_in + n_out, replace=False)
    for m, k in enumerate(pick):
        x = rng.uniform(0, tray[0]) if m < n_in else tray[0] + rng.uniform(5, 500)
        rows[k][2:5] = [repr(x), repr(rng.uniform(0, tray[1])), repr(rng.uniform(0, 2 * np.pi))]
    with open(dst, "w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    return n_out


def _fit(scene, path):
    log = read_fit_log(path, scene.actions, (scene.tray_x_mm, scene.tray_y_mm))
    s = FitSettings(ranges={"mu": (0.1, 0.5)}, points={"mu": 5}, camera=(0.5, 0.5), seed=0, bootstrap=100,
                    replicates=0, local=4, estimator="local")
    return fit_log(scene, log, s, build=lambda sc, st: (synthetic_model(sc, sc.friction.mu), "synthetic")).to_dict()


def test_three_percent_wild_misreads_keep_the_estimate(scene, tmp_path):
    clean, bad = tmp_path / "clean.csv", tmp_path / "bad.csv"
    synthetic_log(scene, clean, 0.29, trials=300, tilts=15, seed=21)
    n_out = misread_copy(clean, bad, 0.02, 0.01, (scene.tray_x_mm, scene.tray_y_mm), seed=22)
    a, b = _fit(scene, clean), _fit(scene, bad)
    lo, hi = a["interval_90"]["mu"]
    assert abs(a["estimate"]["mu"] - b["estimate"]["mu"]) < (hi - lo) / 2
    assert a["misreads"]["outside_tray"] == 0 and b["misreads"]["outside_tray"] == n_out > 0
    assert b["observations"] == a["observations"] - n_out


def test_a_log_mostly_outside_the_tray_is_refused(scene, tmp_path, capsys):
    clean, bad = tmp_path / "clean.csv", tmp_path / "bad.csv"
    synthetic_log(scene, clean, 0.29, trials=20, tilts=5, seed=23)
    misread_copy(clean, bad, 0.0, 0.2, (scene.tray_x_mm, scene.tray_y_mm), seed=24)
    assert main(["fit", "--poses", str(bad), "--shape", "polygon:0,0;40,0;0,25"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "outside the" in err[0] and "units" in err[0]
