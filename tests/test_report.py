"""analysis.report: the formatting rules a reader relies on (the full report is written from a real
reproduce run in test_reproduce.py, which checks that its numbers agree with the results)."""
from __future__ import annotations

import json
import math

import numpy as np

from analysis.report import _contact_builds, _expected, _fmt, _jsonable


def test_fmt():
    assert _fmt(None) == "-" and _fmt(None, none="n/a") == "n/a"
    assert _fmt(1.23456) == "1.23" and _fmt(3, "d") == "3" and _fmt(0.5, ".0%") == "50%"


def test_expected_mean_interval_or_censored_lower_bound():
    m = {"random_tilts": 12.345, "random_tilts_ci95": [11.0, 13.7], "random_tilts_lower": 12.345}
    assert _expected(m, "random_tilts", "random_tilts_ci95", "random_tilts_lower") == \
        "12.3 (95% interval 11.0-13.7)"
    censored = {"random_tilts": None, "random_tilts_ci95": [None, None], "random_tilts_lower": 40.04}
    text = _expected(censored, "random_tilts", "random_tilts_ci95", "random_tilts_lower")
    assert text.startswith("at least 40.0 ") and "no mean" in text
    # older results without the bound: the mean as recorded, the interval as dashes when missing
    assert _expected({"x": 2.0}, "x", "x_ci", "x_lower") == "2.0 (95% interval ---)"


def test_contact_builds_names_the_settings_only_when_they_differ():
    same = {"key_build": {"tol_mm": 1.0}, "contact_build": None}
    assert _contact_builds(same).startswith("The same build settings")
    assert _contact_builds({"key_build": {"a": 1}, "contact_build": {"a": 1}}).startswith("The same build settings")
    text = _contact_builds({"key_build": {"tol_mm": 1.0}, "contact_build": {"tol_mm": 2.0}})
    assert "{'tol_mm': 2.0}" in text and "{'tol_mm': 1.0}" in text


def test_results_json_fallback():
    """Arrays and numpy scalars become lists and numbers (json calls the fallback only for types it
    cannot write itself; a plain float NaN is written as NaN by json, not through it)."""
    doc = {"a": np.arange(3), "c": np.float32(2.5)}
    assert json.loads(json.dumps(doc, default=_jsonable)) == {"a": [0, 1, 2], "c": 2.5}
    assert _jsonable(float("nan")) is None and _jsonable(math.inf) is None
    assert _jsonable(np.array([1.5])) == [1.5] and _jsonable(object()).startswith("<object")
