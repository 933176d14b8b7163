"""Tests of kruskal_markov.entropy: the entropy engine against brute force and theory."""
from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from kruskal_markov import generators
from kruskal_markov.entropy import (
    as_sequences,
    batch_entropy,
    distribution_entropy_bits,
    entropy_trajectory,
    histogram_entropy_bits,
    partition_entropy_bits,
    propagate,
)
from kruskal_markov.model import ModelError, TransitionModel


# ------------------------------------------------------------------------------- helpers
def random_model(rng, n, k, density=0.3, cells=None, dense=False, initial="random"):
    """:func:`kruskal_markov.generators.random_model` drawing from ``rng`` (``initial=None``: uniform)."""
    return generators.random_model(n, k, density, cells, dense, initial or "uniform", seed=rng)


def brute_entropy(p):
    """Plain numpy Shannon entropy in bits of p / sum(p)."""
    p = np.asarray(p, dtype=np.float64)
    p = p[p > 0] / p.sum()
    p = p[p > 0]  # terms that underflow to 0 after normalising contribute < 1e-300
    return float(-np.sum(p * np.log2(p)))


def brute_trajectory(model, seq):
    """Dense numpy propagation p_{t+1} = p_t @ P_a, entropies on states and on cells."""
    dense = [m.toarray() for m in model.matrices]
    p = np.array(model.initial, dtype=np.float64)
    dists = [p]
    for a in seq:
        p = p @ dense[a]
        dists.append(p)
    dists = np.array(dists)
    hs = np.array([brute_entropy(d) for d in dists])
    if model.partition is None:
        hc = hs
    else:
        hc = np.array([brute_entropy(np.bincount(model.partition, weights=d, minlength=model.n_cells))
                       for d in dists])
    return dists, hc, hs


# ------------------------------------------------------------------------------- brute force
@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("conservative", [True, False])
def test_matches_dense_brute_force(seed, conservative):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 30))
    k = int(rng.integers(1, 5))
    model = random_model(rng, n, k, density=float(rng.uniform(0.05, 0.6)),
                         cells=int(rng.integers(1, 6)) if seed % 2 else None, dense=bool(seed % 3 == 0))
    seq = rng.integers(0, k, size=int(rng.integers(0, 40)))
    traj = entropy_trajectory(model, seq, return_distributions=True, conservative=conservative)
    dists, hc, hs = brute_trajectory(model, seq)
    np.testing.assert_allclose(traj.distributions, dists, rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj.entropy_bits, hc, rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj.entropy_bits_states, hs, rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj.mass, dists.sum(axis=1), rtol=0, atol=1e-12)
    if conservative:
        np.testing.assert_array_equal(propagate(model, seq), traj.distributions)


@pytest.mark.parametrize("seed", range(6))
def test_batch_equals_single_sequences(seed):
    rng = np.random.default_rng(100 + seed)
    n, k = int(rng.integers(2, 40)), int(rng.integers(1, 9))
    model = random_model(rng, n, k, density=0.15, cells=7 if seed % 2 else None)
    s_count, length = int(rng.integers(1, 300)), int(rng.integers(0, 12))
    seqs = rng.integers(0, k, size=(s_count, length))
    seqs[: s_count // 3] = seqs[0]  # duplicates share the whole trie path
    trie = batch_entropy(model, seqs)
    indep = batch_entropy(model, seqs, share_prefixes=False)
    one_thread = batch_entropy(model, seqs, threads=1)
    for s in range(s_count):
        tr = entropy_trajectory(model, seqs[s])
        np.testing.assert_allclose(trie.entropy_bits[s], tr.entropy_bits, rtol=0, atol=1e-12)
        np.testing.assert_allclose(trie.entropy_bits_states[s], tr.entropy_bits_states, rtol=0, atol=1e-12)
        assert trie.mass_drift[s] <= 1e-12
    np.testing.assert_array_equal(trie.entropy_bits, indep.entropy_bits)
    np.testing.assert_array_equal(trie.entropy_bits_states, one_thread.entropy_bits_states)
    if model.partition is None:
        assert trie.entropy_bits is trie.entropy_bits_states


def test_batch_against_brute_force_directly():
    rng = np.random.default_rng(7)
    model = random_model(rng, 9, 3, cells=4)
    seqs = rng.integers(0, 3, size=(50, 8))
    res = batch_entropy(model, seqs)
    for s in range(50):
        _, hc, hs = brute_trajectory(model, seqs[s])
        np.testing.assert_allclose(res.entropy_bits[s], hc, rtol=0, atol=1e-12)
        np.testing.assert_allclose(res.entropy_bits_states[s], hs, rtol=0, atol=1e-12)


def test_batch_edge_shapes():
    model = random_model(np.random.default_rng(1), 5, 2)
    empty = batch_entropy(model, np.zeros((0, 4), dtype=np.int64))
    assert empty.entropy_bits.shape == (0, 5)
    cells = random_model(np.random.default_rng(1), 5, 2, cells=2)
    empty = batch_entropy(cells, np.zeros((0, 4), dtype=np.int64))
    assert empty.entropy_bits.shape == empty.entropy_bits_states.shape == (0, 5)
    assert empty.mass_drift.shape == (0,) and empty.engine in ("images", "trie", "independent")
    zero_len = batch_entropy(model, np.zeros((3, 0), dtype=np.int64))
    np.testing.assert_allclose(zero_len.entropy_bits[:, 0], brute_entropy(model.initial), atol=1e-12)
    single_action = TransitionModel(["only"], [model.matrices[0]], initial=model.initial)
    res = batch_entropy(single_action, np.zeros((4, 6), dtype=np.int64))
    _, _, hs = brute_trajectory(single_action, [0] * 6)
    np.testing.assert_allclose(res.entropy_bits, np.tile(hs, (4, 1)), atol=1e-12)


def test_batch_with_explicit_initial():
    rng = np.random.default_rng(3)
    model = random_model(rng, 12, 3)
    p = np.zeros(12)
    p[[2, 5]] = [0.25, 0.75]
    seqs = rng.integers(0, 3, size=(20, 5))
    res = batch_entropy(model, seqs, initial=p)
    for s in range(20):
        _, _, hs = brute_trajectory(model.with_initial(p), seqs[s])
        np.testing.assert_allclose(res.entropy_bits_states[s], hs, atol=1e-12)


# ------------------------------------------------------------------------------- theory
@pytest.mark.parametrize("seed", range(5))
def test_permutations_keep_entropy_constant(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 60))
    perms = [np.eye(n)[rng.permutation(n)] for _ in range(3)]
    init = rng.random(n) ** 3
    init /= init.sum()
    model = TransitionModel(["p", "q", "r"], perms, initial=init, partition=np.arange(n) % 3)
    seq = rng.integers(0, 3, 200)
    traj = entropy_trajectory(model, seq)
    np.testing.assert_allclose(traj.entropy_bits_states, brute_entropy(init), rtol=0, atol=1e-12)
    assert traj.mass_drift <= 1e-15
    res = batch_entropy(model, rng.integers(0, 3, (100, 30)))
    np.testing.assert_allclose(res.entropy_bits_states, brute_entropy(init), rtol=0, atol=1e-12)


@pytest.mark.parametrize("target", [0, 3, 9])
def test_rank_one_point_mass_gives_zero_after_one_step(target):
    rng = np.random.default_rng(target)
    n = 10
    collapse = np.zeros((n, n))
    collapse[:, target] = 1.0
    model = TransitionModel(["c", "x"], [collapse, random_model(rng, n, 1).matrices[0]],
                            partition=rng.integers(0, 3, n))
    traj = entropy_trajectory(model, [1, 1, 0, 1, 0])
    assert traj.entropy_bits_states[0] == pytest.approx(math.log2(n), abs=1e-12)
    assert traj.entropy_bits_states[3] == 0.0 and traj.entropy_bits[3] == 0.0
    assert traj.entropy_bits_states[5] == 0.0
    res = batch_entropy(model, [[0, 1, 0], [1, 0, 0]])
    assert res.entropy_bits_states[0, 1] == 0.0 and res.entropy_bits_states[1, 2] == 0.0


def test_rank_one_general_row_gives_row_entropy():
    rng = np.random.default_rng(5)
    n = 8
    pi = rng.random(n)
    pi /= pi.sum()
    model = TransitionModel(["r"], [np.tile(pi, (n, 1))])
    traj = entropy_trajectory(model, [0, 0, 0])
    np.testing.assert_allclose(traj.entropy_bits[1:], brute_entropy(pi), atol=1e-12)


def test_million_step_sequence_keeps_mass():
    """Mass conservation over 10^6 steps of a model whose probabilities are not dyadic."""
    rng = np.random.default_rng(11)
    model = random_model(rng, 40, 3, density=0.3)
    seq = rng.integers(0, 3, 1_000_000)
    traj = entropy_trajectory(model, seq)
    assert traj.mass.size == 1_000_001
    assert traj.mass_drift <= 1e-12
    assert abs(math.fsum([traj.mass[-1], -1.0])) <= 1e-12


def test_tiny_probabilities_and_subnormals():
    tiny = [1e-300, 5e-324, 1e-310, 2.2250738585072014e-308]
    n = 6
    init = np.array([0.0] + tiny + [0.0])
    init[-1] = 1.0 - sum(tiny)
    # an action moving state i to i+1 (cyclic) and a stochastic one with a 1e-300 entry
    shift = np.eye(n)[(np.arange(n) + 1) % n]
    mix = np.eye(n)
    mix[5] = 0
    mix[5, 5], mix[5, 0] = 1.0 - 1e-300, 1e-300
    model = TransitionModel(["shift", "mix"], [shift, mix], initial=init)
    traj = entropy_trajectory(model, [0, 1, 1, 0, 1, 0, 0], return_distributions=True)
    dists, _, _ = brute_trajectory(model, [0, 1, 1, 0, 1, 0, 0])
    np.testing.assert_array_equal(traj.distributions, dists)
    assert np.all(np.isfinite(traj.entropy_bits)) and np.all(traj.entropy_bits >= 0)
    # -sum p log2 p for the start, term by term in exact-enough arithmetic
    expected = -sum(p * math.log2(p) for p in init if p > 0)
    assert traj.entropy_bits[0] == pytest.approx(expected, rel=1e-12, abs=0)
    assert 0 < traj.entropy_bits[0] < 1e-290
    assert distribution_entropy_bits([5e-324, 1.0]) > 0
    assert distribution_entropy_bits([5e-324]) == 0.0


def test_entropy_bounds_uniform_and_point():
    for n in (1, 2, 3, 7, 1000, 4097):
        p = np.full(n, 1.0 / n)
        h = distribution_entropy_bits(p)
        assert 0 <= h <= math.log2(n) and h == pytest.approx(math.log2(n), abs=1e-12)
    assert distribution_entropy_bits([0, 0, 1, 0]) == 0.0
    assert distribution_entropy_bits([0.5, 0.5]) == 1.0
    assert distribution_entropy_bits([]) == 0.0
    assert partition_entropy_bits([0.25, 0.25, 0.5], [0, 0, 1]) == 1.0
    with pytest.raises(ValueError):
        distribution_entropy_bits([0.5, -0.1])


def test_histogram_entropy_unchanged():
    assert histogram_entropy_bits([5, 5, 0, 0]) == 1.0
    assert histogram_entropy_bits([0, 0]) == 0.0
    with pytest.raises(ValueError, match="^histogram counts must be finite and non-negative$"):
        histogram_entropy_bits([1, -1])


def test_histogram_entropy_below_one_bit_by_its_definition():
    """Histograms of less than one bit: one full bin is 0, a 3:1 split is -(3/4 log 3/4 + 1/4 log 1/4)."""
    assert histogram_entropy_bits([7]) == 0.0
    assert histogram_entropy_bits([0, 4, 0]) == 0.0
    want = -(0.75 * math.log2(0.75) + 0.25 * math.log2(0.25))
    assert histogram_entropy_bits([3, 1]) == pytest.approx(want, abs=1e-15) and want < 1


def test_trajectory_keeps_no_distributions_unless_asked():
    model = random_model(np.random.default_rng(2), 6, 2)
    assert entropy_trajectory(model, [0, 1]).distributions is None
    assert entropy_trajectory(model, [0, 1], return_distributions=True).distributions.shape == (3, 6)


def test_uniform_start_entropy_is_log2_n_and_partition_log2_cells():
    rng = np.random.default_rng(0)
    model = TransitionModel(["a"], [np.eye(64)], partition=np.arange(64) // 4)
    traj = entropy_trajectory(model, [0, 0])
    assert traj.entropy_bits_states[0] == pytest.approx(6.0, abs=1e-12) and traj.entropy_bits_states[0] <= 6.0
    assert traj.entropy_bits[0] == pytest.approx(4.0, abs=1e-12) and traj.entropy_bits[0] <= 4.0
    del rng


# ------------------------------------------------------------------------------- properties
@st.composite
def sparse_models(draw):
    n = draw(st.integers(1, 15))
    k = draw(st.integers(1, 4))
    seed = draw(st.integers(0, 2**32 - 1))
    density = draw(st.floats(0.0, 1.0))
    rng = np.random.default_rng(seed)
    mats = []
    for _ in range(k):
        a = rng.random((n, n)) * (rng.random((n, n)) < density)
        a[np.arange(n), rng.integers(0, n, n)] += draw(st.sampled_from([1e-300, 1e-12, 0.5, 1.0]))
        a /= a.sum(axis=1, keepdims=True)
        mats.append(sp.csr_matrix(a))
    cells = draw(st.one_of(st.none(), st.integers(1, 5)))
    init = rng.random(n) * (rng.random(n) < 0.8)
    init[0] += 1e-3
    init /= init.sum()
    return TransitionModel([f"a{i}" for i in range(k)], mats, initial=init,
                           partition=None if cells is None else rng.integers(0, cells, n),
                           n_cells=cells)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(model=sparse_models(), data=st.data())
def test_property_engine_matches_brute_force(model, data):
    seqs = np.array(data.draw(st.lists(
        st.lists(st.integers(0, model.n_actions - 1), min_size=6, max_size=6), min_size=1, max_size=8)))
    res = batch_entropy(model, seqs)
    n = model.n_states
    cells = model.n_cells or n
    for s in range(seqs.shape[0]):
        traj = entropy_trajectory(model, seqs[s], return_distributions=True)
        dists, hc, hs = brute_trajectory(model, seqs[s])
        np.testing.assert_allclose(traj.distributions, dists, rtol=0, atol=1e-12)
        np.testing.assert_allclose(res.entropy_bits[s], hc, rtol=0, atol=1e-12)
        np.testing.assert_allclose(res.entropy_bits_states[s], hs, rtol=0, atol=1e-12)
        assert np.all(traj.distributions >= 0)
    assert np.all(res.entropy_bits_states >= 0) and np.all(res.entropy_bits_states <= math.log2(n))
    assert np.all(res.entropy_bits >= 0) and np.all(res.entropy_bits <= math.log2(cells))
    assert np.all(res.mass_drift <= 1e-12)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(min_value=0, max_value=1e300, allow_subnormal=True), min_size=1, max_size=50))
def test_property_distribution_entropy_bounds(values):
    p = np.asarray(values)
    h = distribution_entropy_bits(p)
    k = np.count_nonzero(p)
    assert 0.0 <= h <= (math.log2(k) if k else 0.0)
    if k:
        assert h == pytest.approx(brute_entropy(p), abs=1e-9)


# ------------------------------------------------------------------------------- bad input
@pytest.fixture(scope="module")
def model3():
    return random_model(np.random.default_rng(0), 4, 3, cells=2)


@pytest.mark.parametrize("seq, pattern", [
    ([0, 3], r"sequence entry 1 is 3, not an action index in \[0, 3\)"),
    ([0, -1], "entry 1 is -1"),
    ([0.5], "entry 0 is 0.5, not an integer"),
    ([np.nan], "not an integer"),
    (["a0", "zz"], "unknown action 'zz'; known actions: a0,a1,a2"),
    (["a0", 7], "sequence entry 1 is 7, not an action name"),
    ([[0, 1]], "1-dimensional"),
    ([True, False], "dtype bool"),
])
def test_bad_sequences_rejected(model3, seq, pattern):
    with pytest.raises(ModelError, match=pattern):
        entropy_trajectory(model3, seq)


def test_names_accepted(model3):
    a = entropy_trajectory(model3, ["a0", "A2", "a1"]).entropy_bits
    b = entropy_trajectory(model3, [0, 2, 1]).entropy_bits
    c = entropy_trajectory(model3, "a0,a2,a1").entropy_bits
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, c)


@pytest.mark.parametrize("seqs, pattern", [
    (np.array([0, 1, 2]), "2-dimensional"),
    (np.array([[0, 1], [2, 5]]), r"sequences entry \(1, 1\) is 5"),
    (np.array([[0, 1], [2, -5]], dtype=np.int64), "is -5"),
    (np.array([[0, 3]], dtype=np.uint8), "is 3"),
    (np.array([[0.0, 1.5]]), "not an integer"),
])
def test_bad_batches_rejected(model3, seqs, pattern):
    with pytest.raises(ModelError, match=pattern):
        batch_entropy(model3, seqs)


def test_bad_initial_and_threads(model3):
    with pytest.raises(ModelError, match="initial distribution has 3 entries"):
        entropy_trajectory(model3, [0], initial=[1, 0, 0])
    with pytest.raises(ModelError, match="sums to"):
        batch_entropy(model3, [[0]], initial=[0.5, 0, 0, 0])
    with pytest.raises(ModelError, match="negative entry -0.5 at state 1"):
        batch_entropy(model3, [[0]], initial=[1.5, -0.5, 0, 0])
    with pytest.raises(ModelError, match="non-finite entry at state 2"):
        batch_entropy(model3, [[0]], initial=[0.5, 0.5, np.nan, 0])
    with pytest.raises(ValueError, match="threads"):
        batch_entropy(model3, [[0]], threads=0)


def test_as_sequences_is_compact(model3):
    out = as_sequences(model3, np.array([[0, 1, 2]], dtype=np.int64))
    assert out.dtype == np.uint8


@pytest.mark.parametrize("seed", range(4))
def test_image_block_path_matches_brute_force(seed):
    """Tray-like model (each action maps into a small image): supports fill the images, so the
    batch engine takes its gather-block path; it must agree with brute force and with the
    scatter path."""
    rng = np.random.default_rng(50 + seed)
    n, k, img, nnz = 60, 5, 12, 4
    mats = _image_matrices(rng, n, k, img, nnz)
    model = TransitionModel([f"a{i}" for i in range(k)], mats, partition=rng.integers(0, 6, n), n_cells=6)
    seqs = rng.integers(0, k, size=(150, 10))
    with_blocks = batch_entropy(model, seqs, image_blocks=True)
    without = batch_entropy(model, seqs, image_blocks=False)
    for s in range(0, 150, 7):
        _, hc, hs = brute_trajectory(model, seqs[s])
        np.testing.assert_allclose(with_blocks.entropy_bits[s], hc, rtol=0, atol=1e-12)
        np.testing.assert_allclose(with_blocks.entropy_bits_states[s], hs, rtol=0, atol=1e-12)
    np.testing.assert_allclose(with_blocks.entropy_bits, without.entropy_bits, rtol=0, atol=1e-12)
    np.testing.assert_allclose(with_blocks.entropy_bits_states, without.entropy_bits_states, rtol=0, atol=1e-12)
    assert with_blocks.mass_drift.max() <= 1e-12


def test_batch_tiny_probabilities_long_supports():
    """Supports of >= 8 states take the vectorized log path of the batch engine; tiny and
    subnormal probabilities must still count exactly (compared term by term)."""
    n = 16
    init = np.array([1e-300, 5e-324, 1e-310, 2.2250738585072014e-308, 3e-320, 1e-200, 1e-17, 0.0] + [0.0] * 8)
    init[8:] = (1.0 - init[:8].sum()) / 8
    rng = np.random.default_rng(2)
    perms = [np.eye(n)[rng.permutation(n)] for _ in range(2)]
    model = TransitionModel(["p", "q"], perms, initial=init)
    expected = -math.fsum(p * math.log2(p) for p in init if p > 0)
    res = batch_entropy(model, rng.integers(0, 2, size=(20, 6)))
    np.testing.assert_allclose(res.entropy_bits_states, expected, rtol=1e-14, atol=0)
    p = rng.random(300) ** 8
    p /= p.sum()
    big = TransitionModel(["id"], [sp.identity(300, format="csr")], initial=p)
    got = batch_entropy(big, np.zeros((3, 2), dtype=np.int64)).entropy_bits_states
    np.testing.assert_allclose(got, brute_entropy(p), rtol=1e-14, atol=0)


def _image_matrices(rng, n, k, img, nnz):
    """k random n x n stochastic matrices, each mapping every state into ``img`` states (``nnz`` per row)."""
    mats = []
    for _ in range(k):
        targets = rng.choice(n, size=img, replace=False)
        cols = targets[rng.integers(0, img, size=(n, nnz))]
        probs = rng.dirichlet(np.ones(nnz), size=n)
        mats.append(sp.csr_matrix((probs.ravel(), (np.repeat(np.arange(n), nnz), cols.ravel())), shape=(n, n)))
    return mats


def _imagey_model(rng, n=300, k=4, img=70, nnz=4, cells=None):
    mats = _image_matrices(rng, n, k, img, nnz)
    init = rng.random(n)
    init /= init.sum()
    return TransitionModel([f"a{i}" for i in range(k)], mats, initial=init,
                           partition=None if cells is None else rng.integers(0, cells, n), n_cells=cells)


@pytest.mark.parametrize("cells, chunk", [(None, 4096), (9, 7), (40, 64)])
def test_image_engine_matches_brute_force_and_trie(cells, chunk):
    rng = np.random.default_rng(cells or 1)
    model = _imagey_model(rng, cells=cells)
    seqs = rng.integers(0, 4, size=(300, 9))
    seqs[:20] = seqs[0]
    img = batch_entropy(model, seqs, method="images", chunk=chunk)
    trie = batch_entropy(model, seqs, method="trie")
    np.testing.assert_allclose(img.entropy_bits, trie.entropy_bits, rtol=0, atol=1e-12)
    np.testing.assert_allclose(img.entropy_bits_states, trie.entropy_bits_states, rtol=0, atol=1e-12)
    for s in range(0, 300, 23):
        _, hc, hs = brute_trajectory(model, seqs[s])
        np.testing.assert_allclose(img.entropy_bits[s], hc, rtol=0, atol=1e-12)
        np.testing.assert_allclose(img.entropy_bits_states[s], hs, rtol=0, atol=1e-12)
    assert img.mass_drift.max() <= 1e-12
    if cells is None:
        assert img.entropy_bits is img.entropy_bits_states


def test_image_engine_auto_choice_and_errors():
    rng = np.random.default_rng(4)
    mixing = _imagey_model(rng, cells=5)
    seqs = rng.integers(0, 4, size=(400, 5))
    from kruskal_markov.entropy import prefers_images
    assert prefers_images(mixing, True)
    auto = batch_entropy(mixing, seqs)
    np.testing.assert_allclose(auto.entropy_bits, batch_entropy(mixing, seqs, method="trie").entropy_bits,
                               rtol=0, atol=1e-12)
    # a contracting model (every tilt halves the support, like a tray) keeps the trie
    n = 200
    halve = np.arange(n) // 2
    det = TransitionModel(["a", "b"], [np.eye(n)[halve], np.eye(n)[halve + 100]])
    assert not prefers_images(det, True)
    with pytest.raises(ValueError, match="unknown method"):
        batch_entropy(mixing, seqs, method="fast")
    with pytest.raises(ValueError, match="chunk"):
        batch_entropy(mixing, seqs, method="images", chunk=0)
    full = random_model(rng, 50, 4, density=0.5)
    with pytest.raises(ValueError, match="gather blocks"):
        batch_entropy(full, rng.integers(0, 4, size=(3, 3)), method="images")


def test_batch_entropy_runs_the_engine_its_documentation_names():
    """``method`` and ``share_prefixes`` pick the engine as documented: ``auto`` is the image engine
    on a mixing model (:func:`prefers_images`) for 256 or more sequences of one or more steps,
    else the trie; ``share_prefixes=False`` means independent; the trie and independent engines
    use the gather blocks by default when they exist, never with ``image_blocks=False``. Read on
    the result (``engine``, ``gather_blocks``); every engine gives the trie's entropies."""
    import kruskal_markov.entropy as ent
    from kruskal_markov.entropy import prefers_images

    rng = np.random.default_rng(4)
    mixing = _imagey_model(rng, cells=5)
    assert prefers_images(mixing, True) and ent._image_blocks(mixing, True) is not None
    seqs = rng.integers(0, 4, size=(300, 5))
    cases = [({}, seqs, ("images", True)),
             ({}, seqs[:, :1], ("images", True)),
             ({}, seqs[:255], ("trie", True)),
             ({"method": "trie"}, seqs, ("trie", True)),
             ({"method": "trie", "image_blocks": False}, seqs, ("trie", False)),
             ({"method": "independent"}, seqs, ("independent", True)),
             ({"share_prefixes": False}, seqs, ("independent", True)),
             ({"method": "images"}, seqs, ("images", True))]
    reference = batch_entropy(mixing, seqs, method="trie").entropy_bits
    for kw, s, engine in cases:
        got = batch_entropy(mixing, s, **kw)
        assert (got.engine, got.gather_blocks) == engine, kw
        np.testing.assert_allclose(got.entropy_bits, reference[:s.shape[0], :s.shape[1] + 1], rtol=0, atol=1e-12)


def test_sequences_in_every_documented_form():
    """One sequence as a tuple of names; a batch as lists of names; a uint8 batch with an index
    past the actions refused naming the entry; more than 256 actions kept as int32 (index 256
    is not wrapped to 0); a negative or non-finite weight refused with the whole message."""
    from kruskal_markov.entropy import as_sequence

    model = TransitionModel(["a", "b"], [np.eye(2), np.eye(2)[[1, 0]]])
    assert as_sequence(model, ("b", "a", "B")).tolist() == [1, 0, 1]
    batch = as_sequences(model, [["a", "b"], ["b", "b"]])
    assert batch.dtype == np.uint8 and batch.tolist() == [[0, 1], [1, 1]]
    with pytest.raises(ModelError) as info:
        as_sequences(model, np.array([[0, 5]], dtype=np.uint8))
    assert str(info.value) == "sequences entry (0, 1) is 5, not an action index in [0, 2)"
    many = TransitionModel([f"a{i}" for i in range(257)], [np.ones((1, 1))] * 257)
    wide = as_sequences(many, [[256, 3]])
    assert wide.dtype == np.int32 and wide.tolist() == [[256, 3]]
    for bad in ([0.5, -0.5], [0.5, np.nan]):
        with pytest.raises(ValueError) as info:
            distribution_entropy_bits(bad)
        assert str(info.value) == "a distribution must be finite and non-negative"


def test_trajectory_support_counts_are_integers():
    model = TransitionModel(["a"], [[[0.5, 0.5, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]], initial=[1.0, 0.0, 0.0])
    tr = entropy_trajectory(model, ["a", "a"])
    assert tr.support.dtype == np.int64 and tr.support.tolist() == [1, 2, 3]       # {0}, {0, 1}, {0, 1, 2}


def test_one_or_two_sequences_on_every_engine_match_their_trajectories():
    """The smallest batches (one task, fewer sequences than blocks) on the trie and independent
    engines: each row is the sequence's own trajectory."""
    rng = np.random.default_rng(11)
    model = random_model(rng, 7, 3, cells=3)
    seqs = rng.integers(0, 3, size=(2, 6))
    for s in (seqs[:1], seqs):
        for kw in ({"method": "trie"}, {"method": "independent"}):
            got = batch_entropy(model, s, **kw)
            for i, seq in enumerate(s):
                tr = entropy_trajectory(model, seq)
                np.testing.assert_allclose(got.entropy_bits[i], tr.entropy_bits, rtol=0, atol=1e-12)
                np.testing.assert_allclose(got.entropy_bits_states[i], tr.entropy_bits_states, rtol=0, atol=1e-12)


def test_gather_blocks_are_kept_per_splitting_mode():
    """The model caches the gather blocks of each splitting mode apart: the non-conservative
    answer computed first does not change the conservative one (bit for bit as on a fresh model)."""
    rng = np.random.default_rng(4)
    mixing = _imagey_model(rng, cells=5)
    seqs = rng.integers(0, 4, size=(300, 5))
    fresh = TransitionModel(mixing.actions, mixing.matrices, initial=mixing.initial, partition=mixing.partition,
                            n_cells=mixing.n_cells)
    want = batch_entropy(fresh, seqs, method="trie").entropy_bits
    batch_entropy(mixing, seqs, method="trie", conservative=False)
    np.testing.assert_array_equal(batch_entropy(mixing, seqs, method="trie").entropy_bits, want)
