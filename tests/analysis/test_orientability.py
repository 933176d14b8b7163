"""analysis.orientability: the metrics of one part (on models whose answers are known) and the
ranking's order rules."""
from __future__ import annotations

import dataclasses
import math

import pytest

from analysis.orientability import PartMetrics, part_metrics, random_tilts_text, rank_parts
from kruskal_markov.convergence import exact_expected_length
from kruskal_markov.generators import cerny_automaton, cerny_model


def test_part_metrics_of_a_cerny_automaton():
    """Černý C_4 from the uniform distribution: shortest word (n - 1)^2 = 9, proven; initial
    entropy log2 4 = 2 bits; the Monte Carlo mean random length is within its 95% interval... of
    the exact expected length (chain solve) up to a few standard errors."""
    model = cerny_model(4)
    m = part_metrics(model, seed=1, count=300, runs=400, sync_node_budget=10_000)
    assert m.states == 4 and m.sync_length == 9 and m.sync_exact and m.sync_lower_bound == 9
    assert len(m.sync_word) == 9 and set(m.sync_word) <= {"a", "b"}
    assert m.initial_entropy == pytest.approx(2.0, abs=1e-12)
    exact, _ = exact_expected_length(cerny_automaton(4))
    lo, hi = m.random_sync_ci95
    half = (hi - lo) / 2
    assert m.random_sync_censored == 0 and abs(m.random_sync_length - exact) < 2.5 * half
    # on a deterministic automaton from a uniform start the entropy is 0 exactly when synchronized:
    # the random tilts to entropy <= epsilon and the random synchronizing length estimate one thing
    assert m.random_tilts == pytest.approx(exact, rel=0.25)
    assert 0.0 <= m.converging_share_50 <= 1.0 and m.mean_entropy_50 <= m.mean_entropy_10 <= 2.0
    assert m.to_dict()["sync_word"] == m.sync_word


def test_part_metrics_are_the_same_on_any_machine():
    """With a node budget the shortest-word search, and so every metric but the time, repeats."""
    a = part_metrics(cerny_model(6), seed=2, count=50, runs=20, sync_node_budget=12)
    b = part_metrics(cerny_model(6), seed=2, count=50, runs=20, sync_node_budget=12)
    assert dataclasses.replace(a, seconds=0.0) == dataclasses.replace(b, seconds=0.0)
    assert a.sync_exact is False and a.sync_lower_bound <= 25 < a.sync_length   # stopped by its budget


def _metrics(**kw):
    base = PartMetrics(10, ["N"], 1, True, 1, "exact", 3.0, (2.0, 4.0), 0, 3.0, (2.0, 4.0), 0,
                       3.0, 3.0, 0.1, 0.0, 1.0, 4.0, 1e-3, 0.0)
    return dataclasses.replace(base, **kw)


def test_rank_order_rules():
    parts = {
        "no-word": _metrics(sync_word=None, sync_length=None, random_tilts=1.0),
        "censored": _metrics(random_tilts=None, random_tilts_lower=2.0, random_tilts_censored=3),
        "slow": _metrics(random_tilts=5.0),
        "fast": _metrics(random_tilts=2.0),
        "fast-longer-word": _metrics(random_tilts=2.0, sync_length=3, sync_word=["N", "E", "S"]),
    }
    rows = rank_parts(parts)
    assert [r["shape"] for r in rows] == ["fast", "fast-longer-word", "slow", "censored", "no-word"]
    assert [r["rank"] for r in rows] == [1, 2, 3, 4, 5]
    assert [r["decided_by"] for r in rows] == ["sync_length", "random_tilts", "random_tilts", "synchronizable",
                                               None]


def test_ties_fall_through_to_share_then_entropies_then_name():
    parts = {"b": _metrics(), "a": _metrics(), "share": _metrics(converging_share_50=0.5),
             "h50": _metrics(mean_entropy_50=0.2)}
    rows = rank_parts(parts)
    assert [r["shape"] for r in rows] == ["a", "b", "h50", "share"]
    assert rows[0]["decided_by"] == "name"               # a and b tie on every metric: the name orders them
    assert rows[1]["decided_by"] == "mean_entropy_50"


def test_random_tilts_text():
    assert random_tilts_text({"random_tilts": 3.14159}) == "3.1"
    assert random_tilts_text({"random_tilts": None, "random_tilts_lower": 7.0}) == ">= 7.0"
    assert random_tilts_text({"random_tilts": None, "random_tilts_lower": None}) == "-"
    assert not math.isnan(_metrics().random_tilts)


def test_part_metrics_by_value_against_their_definitions():
    """Each metric recomputed from its definition with the documented random streams (ensemble:
    seed; random tilts: [seed, 5]; random synchronizing length: [seed, 6]) on a stochastic model."""
    import numpy as np

    from kruskal_markov.convergence import monte_carlo_entropy_tilts, monte_carlo_sync_length
    from kruskal_markov.ensemble import run_ensemble
    from kruskal_markov.sync import start_set, support_automaton
    from tests.kruskal_markov.test_answers import _counted_model

    model = _counted_model(seed=5)
    seed, count, runs, eps, cap = 3, 120, 50, 1e-3, 300
    m = part_metrics(model, seed=seed, count=count, runs=runs, epsilon=eps, max_tilts=cap, draws=0,
                     sync_node_budget=2000)
    ens = run_ensemble(model, count, 50, seed=seed, epsilon=eps)
    assert m.mean_entropy_10 == pytest.approx(ens.mean[10]) and m.mean_entropy_50 == pytest.approx(ens.mean[50])
    assert m.converging_share_50 == ens.converged / count
    t = monte_carlo_entropy_tilts(model, eps, runs=runs, seed=[seed, 5], max_steps=cap)
    assert (m.random_tilts, m.random_tilts_censored, m.random_tilts_lower) == (
        None if t["mean"] is None else pytest.approx(t["mean"]), t["censored"], pytest.approx(t["lower"]))
    aut = support_automaton(model, 0.0)
    r = monte_carlo_sync_length(aut, start_set(model, False), runs=runs, seed=[seed, 6], max_steps=cap)
    assert m.random_sync_censored == r["censored"] and m.random_sync_lower == pytest.approx(r["lower"])
    # every run censored (none reaches 1e-3 bits in 300 tilts): no mean and no interval, only the lower bound
    assert t["censored"] == r["censored"] == runs and m.random_tilts_lower == m.random_sync_lower == cap
    assert (m.random_tilts, m.random_sync_length) == (None, None)
    assert m.random_tilts_ci95 == m.random_sync_ci95 == (None, None)
    assert m.initial_entropy == pytest.approx(2.0)            # 12 states uniform on 4 cells of 3
    assert m.epsilon == eps and m.states == 12
    iv = m.intervals
    assert iv["converging_share"]["value"] == m.converging_share_50
    assert iv["mean_entropy_10"]["value"] == pytest.approx(m.mean_entropy_10)
    assert iv["settings"]["draws"] == 0 and iv["settings"]["structural_source"] == "none"
    assert iv["settings"]["structural_sequences"] == 100 and iv["settings"]["runs"] == runs
    assert iv["settings"]["epsilon"] == eps and iv["settings"]["count"] == count
    assert np.isfinite(m.seconds)
    # defaults: the convergence threshold 1e-3 bits, posterior draws on at most 1,000 sequences
    big = part_metrics(model, seed=seed, count=1200, runs=20, max_tilts=cap, draws=2, sync_node_budget=2000)
    assert big.epsilon == 1e-3 and big.intervals["settings"]["epsilon"] == 1e-3
    assert big.intervals["settings"]["draw_count"] == 1000 and big.intervals["settings"]["draws"] == 2


def test_the_word_synchronizes_and_every_interval_is_its_monte_carlo():
    """Černý C_4 (runs that all finish): the word printed takes every state to one state (checked by
    following it from each), and the random tilts' and random synchronizing length's means, 95%
    intervals and lower bounds are those of their Monte Carlo on the documented streams."""
    import numpy as np

    from kruskal_markov.convergence import monte_carlo_entropy_tilts, monte_carlo_sync_length
    from kruskal_markov.ensemble import run_ensemble
    from kruskal_markov.sync import shortest_word, start_set, support_automaton

    model = cerny_model(4)
    seed, count, runs = 1, 100, 60
    m = part_metrics(model, seed=seed, count=count, runs=runs, sync_node_budget=10_000, draws=0)
    images = set()
    for s in range(model.n_states):
        for name in m.sync_word:
            s = int(np.argmax(model.matrices[model.actions.index(name)].toarray()[s]))
        images.add(s)
    assert len(images) == 1
    assert m.sync_method == shortest_word(model, "state", start="initial", node_budget=10_000).method
    t = monte_carlo_entropy_tilts(model, 1e-3, runs=runs, seed=[seed, 5], max_steps=1000)
    r = monte_carlo_sync_length(support_automaton(model, 0.0), start_set(model, False), runs=runs, seed=[seed, 6],
                                max_steps=1000)
    assert t["censored"] == r["censored"] == 0
    assert (m.random_tilts, m.random_tilts_lower, m.random_tilts_censored) == (t["mean"], t["lower"], 0)
    assert m.random_tilts_ci95 == pytest.approx(tuple(t["ci95"]))
    assert (m.random_sync_length, m.random_sync_lower, m.random_sync_censored) == (r["mean"], r["lower"], 0)
    assert m.random_sync_ci95 == pytest.approx(tuple(r["ci95"]))
    ens = run_ensemble(model, count, 50, seed=seed, epsilon=1e-3)
    assert (m.mean_entropy_10, m.mean_entropy_50, m.converging_share_50) == pytest.approx(
        (ens.mean[10], ens.mean[50], ens.converged / count))
    assert m.intervals["random_tilts"]["value"] == m.random_tilts
    assert m.intervals["random_tilts"]["mc_ci95"] == pytest.approx(list(t["ci95"]))
    # the cap reaches the intervals too: at 3 tilts every run of C_4 is censored, in both
    import time

    t0 = time.perf_counter()
    capped = part_metrics(model, seed=seed, count=count, runs=runs, max_tilts=3, sync_node_budget=10_000, draws=0)
    elapsed = time.perf_counter() - t0
    assert capped.random_tilts_censored == capped.intervals["random_tilts"]["censored"] == runs
    assert 0.0 <= capped.seconds <= elapsed                     # the call's own duration, not a clock reading



def test_the_documented_defaults_of_part_metrics():
    """part_metrics(model) with its defaults: seed 0, 2,000 ensemble sequences, 500 Monte Carlo runs
    censored at 1,000 tilts (this model never reaches 1e-3 bits: every run counts 1,000), 10 posterior
    draws on min(2,000, 1,000) sequences, the model's own structural term (none: not built)."""
    from kruskal_markov.ensemble import run_ensemble
    from tests.kruskal_markov.test_answers import _counted_model

    model = _counted_model(seed=5)
    m = part_metrics(model, sync_node_budget=2000)
    ens = run_ensemble(model, 2000, 50, seed=0, epsilon=1e-3)
    assert (m.mean_entropy_10, m.mean_entropy_50) == pytest.approx((ens.mean[10], ens.mean[50]))
    assert (m.random_tilts_censored, m.random_tilts_lower, m.random_sync_censored, m.random_sync_lower) == (
        500, 1000.0, 500, 1000.0)
    s = m.intervals["settings"]
    # the intervals are of the 50-tilt answers the metrics report (their posterior draws run 50-tilt sequences)
    assert (s["count"], s["length"], s["runs"], s["draws"], s["draw_count"], s["epsilon"], s["structural_source"]) == (
        2000, 50, 500, 10, 1000, 1e-3, "none")


def test_the_deprecated_as_dict_warns_at_the_callers_line_and_equals_to_dict():
    """A deprecation warning points at the caller's code (stacklevel 2), where the user can change it.
    Not under mutmut, whose trampoline adds a frame between the caller and every mutated method (the
    operators of tools/mutate_ops.py run it)."""
    import sys
    import warnings

    if "mutmut.mutation.trampoline" in sys.modules:         # this module was imported as mutmut's mutant
        pytest.skip("mutmut's trampoline adds a frame: the warning's stack level cannot be checked under it")

    from kruskal_markov.errors import KruskalDeprecationWarning

    m = _metrics()
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        d = m.as_dict()
    assert d == m.to_dict()
    assert [(x.category, str(x.message), x.filename) for x in w] == [
        (KruskalDeprecationWarning, "PartMetrics.as_dict is deprecated; use to_dict", __file__)]


def test_the_tilt_cap_reaches_the_posterior_draws():
    """``max_tilts`` caps the random tilts of the answers' posterior draws as it caps the point value:
    at a cap of 2 tilts every run of this model (1.5 bits, about 6 tilts uncapped) is censored at 2, in
    the model and in every draw, so the posterior interval is the single point 2."""
    from tests.kruskal_markov.test_answers import _counted_model

    m = part_metrics(_counted_model(seed=5), seed=3, count=100, runs=30, epsilon=1.5, max_tilts=2, draws=2,
                     sync_node_budget=2000)
    assert (m.random_tilts, m.random_tilts_censored, m.random_tilts_lower) == (None, 30, 2.0)
    assert m.intervals["random_tilts"]["posterior_ci90"] == [2.0, 2.0]


def test_the_shortest_word_fields_are_the_searchs():
    """The word, its length, exactness, lower bound and method are the ``state`` search's from the initial
    support (``shortest_word(model, "state", start="initial")``): on Černý C_4 a proven word of 9 letters; on
    a model whose every row spreads over two states, no word (the part cannot be oriented sensorlessly)."""
    from kruskal_markov.sync import shortest_word
    from tests.kruskal_markov.test_answers import _counted_model

    for model in (cerny_model(4), _counted_model(seed=5)):
        m = part_metrics(model, seed=1, count=50, runs=20, max_tilts=50, draws=0, sync_node_budget=2000)
        s = shortest_word(model, "state", start="initial", node_budget=2000)
        assert (m.sync_word, m.sync_length, m.sync_exact, m.sync_lower_bound, m.sync_method) == (
            None if s.word is None else list(s.word), s.length, s.exact, s.lower_bound if not s.exact else s.length,
            s.method)
    assert m.sync_word is None and m.sync_length is None                # the counted model: no word


def test_censored_parts_rank_by_their_lower_bound_not_their_word():
    """Two parts with the same number of censored runs: the smaller lower bound on the random tilts ranks
    first, though its word is longer and its name comes later."""
    parts = {"z-low": _metrics(random_tilts=None, random_tilts_censored=3, random_tilts_lower=5.0, sync_length=4,
                               sync_word=["N"] * 4),
             "a-high": _metrics(random_tilts=None, random_tilts_censored=3, random_tilts_lower=7.0)}
    rows = rank_parts(parts)
    assert [r["shape"] for r in rows] == ["z-low", "a-high"] and rows[0]["decided_by"] == "random_tilts"


def test_a_tie_on_everything_else_falls_to_the_mean_entropy_after_10_tilts():
    """Parts equal in every metric but the mean entropy after 10 tilts: the lower one ranks first (before
    the name decides)."""
    rows = rank_parts({"a": _metrics(mean_entropy_10=0.3), "b": _metrics(mean_entropy_10=0.2)})
    assert [r["shape"] for r in rows] == ["b", "a"] and rows[0]["decided_by"] == "mean_entropy_10"
