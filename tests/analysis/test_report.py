"""analysis.report and analysis.experiments: the formatting rules a reader relies on (the full report is written from a real
reproduce run in test_reproduce.py, which checks that its numbers agree with the results)."""
from __future__ import annotations

import json
import math

import numpy as np

from analysis.commands import strict_json
from analysis.experiments.contact import contact_builds
from analysis.experiments.text import expected_text, fmt


def testfmt():
    assert fmt(None) == "-" and fmt(None, none="n/a") == "n/a"
    assert fmt(1.23456) == "1.23" and fmt(3, "d") == "3" and fmt(0.5, ".0%") == "50%"


def test_expected_mean_interval_or_censored_lower_bound():
    m = {"random_tilts": 12.345, "random_tilts_ci95": [11.0, 13.7], "random_tilts_lower": 12.345}
    assert expected_text(m, "random_tilts", "random_tilts_ci95", "random_tilts_lower") == \
        "12.3 (95% interval 11.0-13.7)"
    censored = {"random_tilts": None, "random_tilts_ci95": [None, None], "random_tilts_lower": 40.04}
    text = expected_text(censored, "random_tilts", "random_tilts_ci95", "random_tilts_lower")
    assert text.startswith("at least 40.0 ") and "no mean" in text
    # older results without the bound: the mean as recorded, the interval as dashes when missing
    assert expected_text({"x": 2.0}, "x", "x_ci", "x_lower") == "2.0 (95% interval ---)"


def test_contact_builds_names_the_settings_only_when_they_differ():
    same = {"key_build": {"tol_mm": 1.0}, "contact_build": None}
    assert contact_builds(same).startswith("The same build settings")
    assert contact_builds({"key_build": {"a": 1}, "contact_build": {"a": 1}}).startswith("The same build settings")
    text = contact_builds({"key_build": {"tol_mm": 1.0}, "contact_build": {"tol_mm": 2.0}})
    assert "{'tol_mm': 2.0}" in text and "{'tol_mm': 1.0}" in text


def test_results_json_is_strict_json():
    """Arrays and numpy scalars become lists and numbers; NaN and infinities (which json would write as
    NaN and Infinity, refused by strict readers) become null; other objects their text."""
    doc = {"a": np.arange(3), "c": np.float32(2.5), "n": [float("nan"), math.inf, -math.inf], "m": np.array([1.5])}
    assert json.loads(strict_json(doc)) == {"a": [0, 1, 2], "c": 2.5, "n": [None, None, None], "m": [1.5]}
    assert "NaN" not in strict_json({"x": np.float64("nan")}) and "Infinity" not in strict_json([math.inf])
    assert json.loads(strict_json({"o": object()}))["o"].startswith("<object")
