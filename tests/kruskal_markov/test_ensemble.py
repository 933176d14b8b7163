"""Tests of kruskal_markov.ensemble: random sequences, Fig. 3 statistics, convergence, best sequence."""
from __future__ import annotations

import numpy as np
import pytest

from kruskal_markov.automaton_json import model_from_automaton
from kruskal_markov.ensemble import (
    best_sequence_index,
    convergence_steps,
    random_sequences,
    run_ensemble,
)
from kruskal_markov.entropy import batch_entropy, entropy_trajectory
from kruskal_markov.generators import cerny_model as cerny
from kruskal_markov.model import ModelError, TransitionModel


def image_sizes(model, seq):
    """Size of the image of the whole state set after every prefix (independent set semantics)."""
    table = model.deterministic_table()
    current = np.arange(model.n_states)
    sizes = [current.size]
    for a in seq:
        current = np.unique(table[a][current])
        sizes.append(current.size)
    return np.array(sizes)


# --------------------------------------------------------------------------- random sequences
def test_random_sequences_reproducible_and_shaped():
    a = random_sequences(8, 100, 20, seed=5)
    b = random_sequences(8, 100, 20, seed=5)
    c = random_sequences(8, 100, 20, seed=6)
    assert a.shape == (100, 20) and a.dtype == np.uint8
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert a.min() >= 0 and a.max() <= 7
    assert random_sequences(300, 2, 3, seed=1).dtype == np.int32


def test_random_sequences_uniform_frequencies():
    s = random_sequences(8, 20000, 10, seed=1)
    freq = np.bincount(s.ravel(), minlength=8) / s.size
    # 200,000 draws: standard error of each frequency ~ 7.4e-4
    assert np.all(np.abs(freq - 1 / 8) < 5e-3)


def test_random_sequences_weights():
    w = [0, 1, 3, 0]
    s = random_sequences(4, 20000, 5, seed=2, weights=w)
    freq = np.bincount(s.ravel(), minlength=4) / s.size
    assert freq[0] == 0 and freq[3] == 0
    assert abs(freq[1] - 0.25) < 0.01 and abs(freq[2] - 0.75) < 0.01
    np.testing.assert_array_equal(s, random_sequences(4, 20000, 5, seed=2, weights=np.array(w) * 7.0))


@pytest.mark.parametrize("kwargs, pattern", [
    (dict(weights=[1, 2]), "2 action weights given for 3 actions"),
    (dict(weights=[1, -1, 1]), "non-negative"),
    (dict(weights=[0, 0, 0]), "not all be zero"),
    (dict(weights=[1, np.nan, 1]), "finite"),
])
def test_random_sequences_bad_weights(kwargs, pattern):
    with pytest.raises(ModelError, match=pattern):
        random_sequences(3, 2, 2, seed=0, **kwargs)


def test_random_sequences_bad_sizes():
    with pytest.raises(ModelError, match="count"):
        random_sequences(3, -1, 2)
    with pytest.raises(ModelError, match="length"):
        random_sequences(3, 1, 2.5)


# --------------------------------------------------------------------------- convergence steps
def test_convergence_steps_by_definition():
    rng = np.random.default_rng(0)
    h = rng.random((200, 9))
    h[rng.random(h.shape) < 0.2] = 0.0
    eps = 1e-9
    got = convergence_steps(h, eps)
    for s in range(200):
        hits = [t for t in range(9) if h[s, t] <= eps]
        assert got[s] == (hits[0] if hits else -1)
    assert convergence_steps(np.zeros((2, 0))).tolist() == [-1, -1]


def test_best_sequence_rules():
    steps = np.array([-1, 4, 2, 2, 3, -1])
    final = np.array([0.0, 0.0, 0.5, 0.1, 0.0, 0.0])
    assert best_sequence_index(steps, final) == 3  # first to converge; tie broken by final entropy
    final2 = np.array([0.0, 0.0, 0.1, 0.1, 0.0, 0.0])
    assert best_sequence_index(steps, final2) == 2  # full tie: lowest index
    assert best_sequence_index(np.array([-1, -1, -1]), np.array([0.3, 0.2, 0.2])) == 1


def test_best_sequence_matches_brute_force_sort():
    rng = np.random.default_rng(3)
    for _ in range(50):
        k = int(rng.integers(1, 30))
        steps = rng.integers(-1, 5, k)
        final = rng.integers(0, 3, k) / 2
        ref = sorted(range(k), key=lambda i: (steps[i] if steps[i] >= 0 else 10**9, final[i], i))[0]
        assert best_sequence_index(steps, final) == ref


# --------------------------------------------------------------------------- ensembles
@pytest.mark.parametrize("n", [3, 4, 5])
def test_cerny_ensemble_against_set_semantics(n):
    model = cerny(n)
    res = run_ensemble(model, 400, (n - 1) ** 2 + 12, seed=n, keep_entropy=True)
    assert res.entropy.shape == (400, (n - 1) ** 2 + 13)
    for s in range(400):
        sizes = image_sizes(model, res.sequences[s])
        # uniform start on a deterministic automaton: entropy 0 exactly when the image is one state
        first = np.flatnonzero(sizes == 1)
        expected = int(first[0]) if first.size else -1
        assert res.convergence_steps[s] == expected
    conv = res.convergence_steps[res.convergence_steps >= 0]
    assert res.converged == conv.size > 0
    assert conv.min() >= (n - 1) ** 2  # Černý: no reset word shorter than (n-1)^2
    best = res.best_sequence
    assert image_sizes(model, best)[conv.min()] == 1
    assert res.convergence_steps[res.best_index] == conv.min()


def test_ensemble_statistics_equal_numpy_on_batch():
    rng = np.random.default_rng(9)
    n = 12
    mats = []
    for _ in range(3):
        a = rng.random((n, n)) * (rng.random((n, n)) < 0.3) + np.eye(n)[rng.integers(0, n // 3, n)]
        mats.append(a / a.sum(axis=1, keepdims=True))
    model = TransitionModel(["x", "y", "z"], mats, partition=np.arange(n) % 4)
    res = run_ensemble(model, 300, 15, seed=4, epsilon=0.5, weights=[1, 2, 1], keep_entropy=True)
    seqs = random_sequences(3, 300, 15, seed=4, weights=[1, 2, 1])
    np.testing.assert_array_equal(res.sequences, seqs)
    h = np.array([entropy_trajectory(model, s).entropy_bits for s in seqs])
    np.testing.assert_allclose(res.entropy, h, atol=1e-12)
    np.testing.assert_allclose(res.mean, h.mean(axis=0), atol=1e-12)
    np.testing.assert_allclose(res.q25, np.quantile(h, 0.25, axis=0), atol=1e-12)
    np.testing.assert_allclose(res.q75, np.quantile(h, 0.75, axis=0), atol=1e-12)
    hs = batch_entropy(model, seqs).entropy_bits_states
    np.testing.assert_allclose(res.mean_states, hs.mean(axis=0), atol=1e-12)
    assert res.converged == int(np.sum((h <= 0.5).any(axis=1)))
    assert res.max_mass_drift <= 1e-12


def test_ensemble_reproducible():
    model = cerny(4)
    a = run_ensemble(model, 50, 12, seed=1)
    b = run_ensemble(model, 50, 12, seed=1)
    np.testing.assert_array_equal(a.sequences, b.sequences)
    np.testing.assert_array_equal(a.mean, b.mean)


def test_never_converging_model():
    model = model_from_automaton({"states": 4, "actions": {"a": [1, 0, 3, 2], "b": [0, 1, 2, 3]}})
    res = run_ensemble(model, 30, 10, seed=0)
    assert res.converged == 0
    assert np.all(res.convergence_steps == -1)
    np.testing.assert_allclose(res.mean, 2.0, atol=1e-12)


@pytest.mark.parametrize("kwargs, pattern", [
    (dict(count=0, length=3), "count must be a positive integer"),
    (dict(count=2, length=-1), "length"),
    (dict(count=2, length=3, epsilon=-1), "epsilon"),
    (dict(count=2, length=3, epsilon="x"), "epsilon must be a number"),
    (dict(count=2, length=3, weights=[1]), "1 action weights given for 2 actions"),
])
def test_ensemble_bad_input(kwargs, pattern):
    with pytest.raises(ModelError, match=pattern):
        run_ensemble(cerny(3), seed=0, **kwargs)


# --------------------------------------------------------------------------- the epsilon boundary
def test_convergence_counts_entropy_equal_to_epsilon():
    """``h <= epsilon`` converges: an entropy exactly at epsilon counts, one just above does not."""
    h = np.array([[2.0, 1.0, 0.5], [2.0, np.nextafter(1.0, 2.0), 1.0], [3.0, 2.0, 1.5]])
    assert convergence_steps(h, 1.0).tolist() == [1, 2, -1]
    assert convergence_steps(h, 0.5).tolist() == [2, -1, -1]


def test_run_ensemble_hits_the_epsilon_boundary_exactly():
    """Uniform over 4 states; action ``a`` merges them pairwise into states 0 and 2, where it stays
    (exactly 1 bit: 0.5 log2 2 twice, exact in floating point), ``b`` is the identity (2 bits).
    With epsilon = 1 bit a sequence converges at its first ``a``: the step is derived here from the
    sequence itself; with epsilon one ulp below 1 bit, none ever does."""
    model = model_from_automaton({"states": 4, "actions": {"a": [0, 0, 2, 2], "b": [0, 1, 2, 3]}})
    assert entropy_trajectory(model, [0]).entropy_bits.tolist() == [2.0, 1.0]
    res = run_ensemble(model, 64, 6, seed=3, epsilon=1.0)
    seqs = res.sequences
    first_a = [int(np.flatnonzero(s == 0)[0]) + 1 if np.any(s == 0) else -1 for s in seqs]
    assert res.convergence_steps.tolist() == first_a
    assert res.converged == sum(x > 0 for x in first_a) > 0
    just_below = run_ensemble(model, 64, 6, seed=3, epsilon=np.nextafter(1.0, 0.0))
    assert np.all(just_below.convergence_steps == -1) and just_below.converged == 0


# --------------------------------------------------------------------------- boundaries (mutation testing)
def test_random_sequences_boundaries_and_messages():
    assert random_sequences(3, 0, 5, seed=0).shape == (0, 5)          # zero sequences, zero length: valid
    assert random_sequences(3, 4, 0, seed=0).shape == (4, 0)
    assert np.all(random_sequences(1, 3, 4, seed=0) == 0)              # one action: always it
    assert random_sequences(256, 2, 2, seed=0).dtype == np.uint8
    assert random_sequences(257, 2, 2, seed=0).dtype == np.int32
    wide = random_sequences(300, 2000, 1, seed=0)
    assert wide.min() == 0 and wide.max() == 299                        # every action reachable
    for kwargs, name in (({"count": -1}, "count"), ({"length": 2.5}, "length"), ({"n_actions": -2}, "n_actions"),
                         ({"count": True}, "count")):
        args = {"n_actions": 3, "count": 2, "length": 2, **kwargs}
        with pytest.raises(ModelError, match=f"^{name} must be a non-negative integer"):
            random_sequences(**args)
    with pytest.raises(ModelError, match=r"^n_actions must be >= 1$"):
        random_sequences(0, 2, 2)


def test_weighted_sequences_follow_their_weights():
    """Weights (0.1, 0.2, 0.7): frequencies within 5 standard errors, and a last action of positive
    weight is drawn; a zero-weight action never is (even at the top of the cumulative sum)."""
    seqs = random_sequences(3, 400, 50, seed=8, weights=[1, 2, 7])
    freq = np.bincount(seqs.ravel(), minlength=3) / seqs.size
    se = np.sqrt(np.array([0.1, 0.2, 0.7]) * np.array([0.9, 0.8, 0.3]) / seqs.size)
    assert np.all(np.abs(freq - [0.1, 0.2, 0.7]) < 5 * se), freq
    tail_zero = random_sequences(4, 300, 30, seed=1, weights=[0.1] * 3 + [0.0])
    assert tail_zero.max() == 2 and tail_zero.dtype == np.uint8
    # uniform weights draw uniformly (the weighted path); chunks of 4 rows when a row is 2^20 tilts
    long = random_sequences(2, 9, 1 << 20, seed=2, weights=[1, 1])
    assert long.shape == (9, 1 << 20)
    row_means = long.mean(axis=1)
    assert np.all(np.abs(row_means - 0.5) < 5 * 0.5 / np.sqrt(1 << 20))
    assert len({r.tobytes()[:64] for r in long}) == 9                   # no chunk repeated


def test_run_ensemble_checks_its_memory_before_allocating(monkeypatch):
    """The estimate is count x (length + 1) x 25 bytes (entropy, two quantile buffers, a
    sequence byte): at exactly the allowed share it runs, one byte of room less and it refuses,
    naming the request and the options that change it."""
    import kruskal_markov.limits as limits

    model = cerny(3)
    need = 100 * (9 + 1) * 25
    monkeypatch.setattr(limits, "available_memory_bytes", lambda: need / limits.MEMORY_SHARE)
    run_ensemble(model, 100, 9, seed=0)
    monkeypatch.setattr(limits, "available_memory_bytes", lambda: (need - 1) / limits.MEMORY_SHARE)
    with pytest.raises(ModelError, match=r"^100 random sequences of 9 tilts needs .*; use a smaller --count or --length$"):
        run_ensemble(model, 100, 9, seed=0)


def test_run_ensemble_fields_and_boundaries():
    model = cerny(3)
    res = run_ensemble(model, 1, 4, seed=0, epsilon=0.0)               # one sequence, epsilon 0: valid
    assert res.sequences.shape == (1, 4) and res.entropy is None and res.epsilon == 0.0
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ModelError, match="count must be a positive integer"):
            run_ensemble(model, bad, 4)
    # a sequence that converges at step 0 counts as converged (steps >= 0)
    start_done = run_ensemble(model, 5, 3, seed=1, initial=[1.0, 0.0, 0.0])
    assert start_done.converged == 5 and np.all(start_done.convergence_steps == 0)
    # the best sequence's own entropy curve and the final entropy decide it
    res = run_ensemble(model, 40, 6, seed=3, keep_entropy=True)
    np.testing.assert_array_equal(res.best_entropy, res.entropy[res.best_index])
    assert res.best_index == best_sequence_index(res.convergence_steps, res.entropy[:, -1])
    weighted = run_ensemble(model, 40, 6, seed=3, weights=[1, 0])
    assert np.all(weighted.sequences == 0)
    assert not np.array_equal(weighted.mean, res.mean)
    init = run_ensemble(model, 40, 6, seed=3, initial=[0.5, 0.5, 0.0])
    assert init.mean[0] == pytest.approx(1.0)


def test_convergence_steps_and_best_index_messages():
    with pytest.raises(ValueError, match=r"^entropy must be a 2-D array \(sequences x steps\)$"):
        convergence_steps(np.zeros(3))
    empty = convergence_steps(np.zeros((4, 0)))
    assert empty.tolist() == [-1] * 4 and empty.dtype == np.int64
    with pytest.raises(ValueError, match="^no sequences$"):
        best_sequence_index(np.zeros(0, dtype=np.int64), np.zeros(0))


def test_best_sequence_without_convergence_is_the_lowest_final_entropy():
    """Nothing converges (``a`` merges states 0 and 1 and nothing merges further): the best
    sequence is the first one (lowest index) that contains ``a`` anywhere, decided by the final
    entropy, not by the entropy after any earlier step."""
    model = model_from_automaton({"states": 3, "actions": {"a": [0, 0, 2], "c": [0, 1, 2]}})
    for seed in (5, 6):       # seed 6: the first sequence holding ``a`` holds it at its last step only
        res = run_ensemble(model, 40, 4, seed=seed)
        assert res.converged == 0
        has_a = [bool(np.any(s == 0)) for s in res.sequences]
        assert res.best_index == has_a.index(True)
    assert res.best_index == 0 and res.sequences[0].tolist() == [1, 1, 1, 0]
