"""The README's headline figures are the committed report's: every number in its first paragraph,
its "Results at a glance" table and its speed table is recomputed from ``reports/full/results.json``
and ``reports/full/pareto.md`` (both written by code), so the text cannot drift from the numbers."""
from __future__ import annotations

import json
import re

import pytest

import tests
from analysis.experiments.curves import settled_steps

ROOT = tests.ROOT
README = (ROOT / "README.md").read_text()
PARETO = (ROOT / "reports" / "full" / "pareto.md").read_text()


@pytest.fixture(scope="module")
def results():
    return json.loads((ROOT / "reports" / "full" / "results.json").read_text())


def _glance(label: str) -> str:
    """The README's "Results at a glance" cell of the row starting with ``label``."""
    row = next(line for line in README.splitlines() if line.startswith(f"| {label}"))
    return row.split("|")[3]


def _pareto_row(prefix: str) -> list[str]:
    row = next(line for line in PARETO.splitlines() if line.startswith(f"| {prefix}"))
    return [c.strip() for c in row.strip("|").split("|")]


def test_headline_speed_and_error_are_the_pareto_reports():
    """The default model's row of pareto.md's experiment-A table: the speed-up and both mean errors."""
    faster, m, direct_err, model_err = (_pareto_row("deterministic, defaults")[i] for i in (2, 3, 4, 5))
    speedup = re.search(r"experiment A\s+(\d+) times faster", README)
    assert speedup and f"{speedup.group(1)}x" == faster
    errors = re.search(r"mean error ([\d.]+) against the\s+model's ([\d.]+) bits", README)
    assert errors and errors.group(1) == direct_err.split(" / ")[0] and errors.group(2) == model_err.split(" / ")[0]
    # "direct simulation given the same time is the more accurate" holds only if its error is smaller
    assert float(errors.group(1)) < float(errors.group(2))


def test_speed_table_rows_are_pareto_rows():
    for readme_label, pareto_prefix in (("direct Monte Carlo, M = 200", "direct Monte Carlo, M = 200 "),
                                        ("direct Monte Carlo, M = 1,000", "direct Monte Carlo, M = 1,000 ")):
        row = next(line for line in README.splitlines() if line.startswith(f"| {readme_label} |"))
        seconds, errors, another = (c.strip() for c in row.strip("|").split("|")[1:4])
        p = _pareto_row(pareto_prefix)
        assert (seconds, errors, another) == (p[1], f"{p[2]} / {p[3]}", p[4])
    row = next(line for line in README.splitlines() if line.startswith("| model, default build |"))
    p = _pareto_row("model (simulator v4): deterministic, defaults")
    assert row.split("|")[2].strip() == f"{p[1].split(' ')[0]}, once" and row.split("|")[3].strip() == f"{p[2]} / {p[3]}"


def test_results_at_a_glance_are_the_full_reports(results):
    a, e, km = results["A"], results["ensemble"], results["key_metrics"]
    eps = results["settings"]["epsilon"]
    stay = int((settled_steps(a["entropy"], eps) >= 0).sum())
    assert f"{stay} reach zero and stay, {a['converged']} reach it" in _glance("A: 43 random")
    share = f"{100 * e['converged'] / e['count']:.1f}% reach zero, {100 * e['settled']['converged'] / e['count']:.1f}% " \
            f"stay there ({e['seconds']:.0f} s)"
    assert share in _glance("the same over 10^6")
    rep = results["sync_replay"]
    plan = (f"{km['sync_length']} tilts, {'proven shortest' if km['sync_exact'] else 'not proven'}; "
            f"{rep['entropy_bits'][-1]:.3f} bits in {rep['trials']:,} trials")
    assert plan in _glance("shortest plan for the key")
    lo, hi = km["random_tilts_ci95"]
    assert f"{km['random_tilts']:.0f} (95% interval {lo:.0f}-{hi:.0f})" in _glance("expected random tilts")
    b = results["B"]
    assert (f"{b['converged']} of {len(b['parts'])} by the models, {b['converged_direct']} in direct simulation"
            in _glance("B: 15 triangles"))


def test_the_contact_row_is_the_reports(results):
    cm = results["contact_models"]
    old, new = cm["sphere, 1/240 s (the old default)"], cm["coulomb (compared resolution)"]
    text = (f"{old['a_converged']} against {new['a_converged']} of 43 converge; plans of {old['sync_length']} and "
            f"{new['sync_length']} tilts; {old['random_tilts']:.0f} against {new['random_tilts']:.0f} expected tilts")
    assert text in _glance("the old contact")
