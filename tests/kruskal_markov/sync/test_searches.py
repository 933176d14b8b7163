"""Synchronizing words: checked against independent plain-Python breadth-first searches."""
from __future__ import annotations

import itertools
import math
from collections import deque

import numpy as np
import pytest
import scipy.sparse as sp

from kruskal_markov.generators import cerny_table as cerny
from kruskal_markov.generators import random_table as _random_table
from kruskal_markov.model import TransitionModel
from kruskal_markov.sync import (
    ExactSearchOptions,
    SyncAutomaton,
    epsilon_synchronizing_word,
    greedy_synchronizing_word,
    is_synchronizing_word,
    shortest_synchronizing_word,
    start_set,
    support_automaton,
    synchronizability,
)


# ----------------------------------------------------------------------------- independent judges
def plain_image(table, states, word):
    cur = {int(s) for s in states}
    for a in word:
        cur = {int(table[a][q]) for q in cur}
    return cur


def plain_union_image(supports, states, word):
    """supports[a][q] = set of successors."""
    cur = {int(s) for s in states}
    for a in word:
        cur = set().union(*(supports[a][q] for q in cur))
    return cur


def brute_shortest(step, k, start, single=None):
    """Plain BFS over sets of states; step(set, a) -> set. Returns the length or None. The sets are
    frozensets (``start``: the states), or whatever ``step`` maps (``start``: one such set, and
    ``single(set)`` says whether it holds one state)."""
    s = frozenset(int(x) for x in start) if single is None else start
    single = single or (lambda x: len(x) == 1)
    if single(s):
        return 0
    seen = {s}
    queue = deque([(s, 0)])
    while queue:
        x, d = queue.popleft()
        for a in range(k):
            y = step(x, a)
            if single(y):
                return d + 1
            if y not in seen:
                seen.add(y)
                queue.append((y, d + 1))
    return None


def brute_det(table, start=None):
    table = [list(map(int, r)) for r in np.asarray(table)]
    n = len(table[0])
    start = range(n) if start is None else start
    return brute_shortest(lambda x, a: frozenset(table[a][q] for q in x), len(table), start)


def brute_pair_mergeable(table, p, q):
    k = len(table)
    seen = {(p, q)}
    queue = deque([(p, q)])
    while queue:
        x, y = queue.popleft()
        if x == y:
            return True
        for a in range(k):
            nxt = (int(table[a][x]), int(table[a][y]))
            if nxt not in seen:
                seen.add(nxt)
                queue.append(nxt)
    return False


def random_table(rng, n, k):
    return _random_table(n, k, rng)


def random_tables(seed, trials, n_range, k=2):
    """``trials`` random automata ``(rng, n, table)`` from one seeded stream: ``n`` drawn from the
    half-open ``n_range``, then the letter count from ``k`` (an int, or a half-open range drawn
    from), then the table; a test may draw more from ``rng`` between automata."""
    rng = np.random.default_rng(seed)
    for _ in range(trials):
        n = int(rng.integers(*n_range))
        letters = k if isinstance(k, int) else int(rng.integers(*k))
        yield rng, n, random_table(rng, n, letters)


# ----------------------------------------------------------------------------- Cerny automata
@pytest.mark.parametrize("n", list(range(2, 17)) + [20])
def test_cerny_exact(n):
    table = cerny(n)
    res = shortest_synchronizing_word(SyncAutomaton.from_table(table))
    assert res.exact is True
    assert res.length == (n - 1) ** 2
    assert len(plain_image(table, range(n), res.word)) == 1


def test_cerny_small_cross_check_brute():
    for n in range(2, 8):
        assert brute_det(cerny(n)) == (n - 1) ** 2


# ----------------------------------------------------------------------------- random small, brute force
def test_random_small_automata_match_brute_force():
    checked_none = 0
    for rng, n, table in random_tables(20240501, 400, (1, 11), k=(1, 4)):
        start = None
        if rng.random() < 0.4:
            start = rng.choice(n, size=int(rng.integers(1, n + 1)), replace=False)
        aut = SyncAutomaton.from_table(table)
        res = shortest_synchronizing_word(aut, start)
        expected = brute_det(table, start)
        assert res.exact is True
        assert res.length == expected
        if expected is None:
            checked_none += 1
            assert res.word is None and res.witness is not None
        else:
            assert len(res.word) == expected
            assert len(plain_image(table, range(n) if start is None else start, res.word)) == 1
    assert checked_none > 10


def brute_bitmask(table, start=None):
    """BFS with subsets as Python ints; images via per-letter, per-byte lookup tables."""
    table = np.asarray(table)
    k, n = table.shape
    nb = (n + 7) // 8
    tabs = [[[0] * 256 for _ in range(nb)] for _ in range(k)]
    for a in range(k):
        for b in range(nb):
            t = tabs[a][b]
            for v in range(1, 256):
                low = v & -v
                q = b * 8 + low.bit_length() - 1
                t[v] = t[v ^ low] | ((1 << int(table[a][q])) if q < n else 0)

    def step(x, a):
        ta, y, b = tabs[a], 0, 0
        while x:
            y |= ta[b][x & 255]
            x >>= 8
            b += 1
        return y

    s = sum(1 << int(q) for q in (range(n) if start is None else start))
    return brute_shortest(step, k, s, single=lambda y: y & (y - 1) == 0)


def test_bitmask_brute_agrees_with_frozenset_brute():
    for rng, n, table in random_tables(2, 50, (1, 12), k=(1, 4)):
        assert brute_bitmask(table) == brute_det(table)


@pytest.mark.parametrize("k,sizes", [(2, list(range(20, 61, 2))), (8, [20, 22, 24, 26, 28, 30, 20, 24, 28, 32])])
def test_medium_random_automata_match_plain_bfs(k, sizes):
    rng = np.random.default_rng(7 + k)
    for n in sizes:
        table = random_table(rng, n, k)
        start = None
        if rng.random() < 0.25:
            start = rng.choice(n, size=n // 2, replace=False)
        res = shortest_synchronizing_word(SyncAutomaton.from_table(table), start)
        assert res.exact is True
        assert res.length == brute_bitmask(table, start)
        if res.word is not None:
            assert len(plain_image(table, range(n) if start is None else start, res.word)) == 1


@pytest.mark.slow
@pytest.mark.parametrize("k", [2, 8])
def test_larger_random_automata_match_plain_bfs(k):
    rng = np.random.default_rng(100 + k)
    sizes = [60, 64, 70, 80] if k == 2 else [36, 40, 50]
    for n in sizes:
        for _ in range(2):
            table = random_table(rng, n, k)
            res = shortest_synchronizing_word(SyncAutomaton.from_table(table))
            assert res.exact is True
            assert res.length == brute_bitmask(table)


def test_structured_slowly_synchronizing_match_brute():
    # Cerny-like automata with an extra random letter, and automata with a permutation letter
    rng = np.random.default_rng(3)
    for _ in range(40):
        n = int(rng.integers(3, 12))
        table = np.vstack([cerny(n), rng.integers(0, n, size=(1, n))]) if rng.random() < 0.5 else \
            np.vstack([rng.permutation(n), rng.integers(0, n, size=(1, n))])
        res = shortest_synchronizing_word(SyncAutomaton.from_table(table))
        assert res.exact and res.length == brute_det(table)


# ----------------------------------------------------------------------------- non-synchronizing
def test_permutation_automaton_has_pair_witness():
    rng = np.random.default_rng(1)
    for _ in range(20):
        n = int(rng.integers(2, 9))
        table = np.array([rng.permutation(n) for _ in range(2)])
        aut = SyncAutomaton.from_table(table)
        res = shortest_synchronizing_word(aut)
        assert res.word is None and res.length is None and res.exact is True
        p, q = res.witness["states"]
        assert p != q and not brute_pair_mergeable(table, p, q)
        assert synchronizability(aut)["synchronizing"] is False


def test_two_closed_classes_witness():
    # states {0,1} and {2,3} are closed under both letters
    table = np.array([[1, 1, 3, 3], [0, 0, 2, 2]])
    aut = SyncAutomaton.from_table(table)
    res = shortest_synchronizing_word(aut)
    assert res.word is None and res.exact
    p, q = res.witness["states"]
    assert not brute_pair_mergeable(table, p, q)
    assert (p < 2) != (q < 2)
    # restricted to one class it synchronizes in one letter
    res2 = shortest_synchronizing_word(aut, start=[0, 1])
    assert res2.length == 1 and res2.exact


def test_synchronizability_agrees_with_brute_force():
    for rng, n, table in random_tables(11, 200, (2, 9)):
        verdict = synchronizability(SyncAutomaton.from_table(table))["synchronizing"]
        assert verdict == (brute_det(table) is not None)


# ----------------------------------------------------------------------------- set-valued automata
def random_support(rng, n, k, pmax):
    sup = []
    for _ in range(k):
        rows = []
        for _ in range(n):
            m = 1 if rng.random() > pmax else int(rng.integers(1, 3))
            rows.append(frozenset(int(x) for x in rng.choice(n, size=m, replace=False)))
        sup.append(rows)
    return sup


def model_from_support(sup, initial=None):
    n = len(sup[0])
    mats = []
    for rows in sup:
        m = np.zeros((n, n))
        for q, succ in enumerate(rows):
            for r in succ:
                m[q, r] = 1.0 / len(succ)
        mats.append(sp.csr_matrix(m))
    return TransitionModel([f"a{i}" for i in range(len(sup))], mats, initial=initial)


def test_support_automata_match_union_bfs():
    rng = np.random.default_rng(5)
    hits = 0
    for _ in range(200):
        n = int(rng.integers(2, 9))
        k = int(rng.integers(1, 4))
        sup = random_support(rng, n, k, 0.3)
        model = model_from_support(sup)
        aut = support_automaton(model)
        start = list(range(n))
        if rng.random() < 0.3:
            start = sorted(int(x) for x in rng.choice(n, size=int(rng.integers(1, n + 1)), replace=False))
        expected = brute_shortest(lambda x, a, sup=sup: frozenset().union(*(sup[a][q] for q in x)), k, start)
        res = shortest_synchronizing_word(aut, start)
        assert res.exact and res.length == expected
        if expected is not None:
            hits += 1
            assert len(plain_union_image(sup, start, res.word)) == 1
        else:
            assert res.witness is not None
            if res.witness["kind"] == "pair":
                p, q = res.witness["states"]
                assert brute_shortest(lambda x, a, sup=sup: frozenset().union(*(sup[a][s] for s in x)), k,
                                      [p, q]) is None
    assert hits > 50


def test_support_threshold_and_mass_dropped():
    m = np.array([[0.9, 0.1, 0.0], [0.0, 0.5, 0.5], [0.0, 0.0, 1.0]])
    model = TransitionModel(["a"], [m])
    aut = support_automaton(model, threshold=0.2)
    assert aut.deterministic is False
    assert aut.mass_dropped == pytest.approx(0.1)
    assert aut.image([0], [0]) == [0]
    assert aut.image([1], [0]) == [1, 2]
    full = support_automaton(model)
    assert full.image([0], [0]) == [0, 1] and full.mass_dropped == 0.0
    # a row whose entries are all below the threshold keeps its largest entry
    aut2 = support_automaton(model, threshold=0.95)
    assert aut2.image([1], [0]) in ([1], [2])
    with pytest.raises(ValueError):
        support_automaton(model, threshold=1.5)


def test_start_set_of_model():
    model = TransitionModel(["a"], [np.eye(3)], initial=[0.5, 0.0, 0.5])
    assert start_set(model, whole=False).tolist() == [0, 2]
    assert start_set(model, whole=True).tolist() == [0, 1, 2]


# ----------------------------------------------------------------------------- budgets and greedy
def test_budget_fallback_is_greedy_and_verified():
    table = cerny(12)
    aut = SyncAutomaton.from_table(table)
    res = shortest_synchronizing_word(aut, node_budget=64)     # a budget of work: the same on any machine
    assert res.word is not None and len(plain_image(table, range(12), res.word)) == 1
    assert res.lower_bound is not None and res.lower_bound <= 121 <= res.length
    assert res.exact == (res.length == res.lower_bound)


def test_greedy_words_synchronize():
    for rng, n, table in random_tables(9, 50, (2, 30)):
        aut = SyncAutomaton.from_table(table)
        word = greedy_synchronizing_word(aut)
        if brute_det(table) is None if n <= 12 else synchronizability(aut)["synchronizing"] is False:
            assert word is None
        else:
            assert len(plain_image(table, range(n), word)) == 1
            if n <= 12:
                assert len(word) >= brute_det(table)


def test_bad_input():
    with pytest.raises(ValueError):
        SyncAutomaton.from_table([[0, 3]])
    with pytest.raises(ValueError):
        shortest_synchronizing_word(SyncAutomaton.from_table([[0, 1]]), start=[5])
    with pytest.raises(ValueError):
        shortest_synchronizing_word(SyncAutomaton.from_table([[0, 1]]), time_budget=0)
    for bad in (0, -3, 2.5):
        with pytest.raises(ValueError, match="node_budget"):
            shortest_synchronizing_word(SyncAutomaton.from_table([[1, 0], [0, 0]]), node_budget=bad)


def test_is_synchronizing_word():
    aut = SyncAutomaton.from_table(cerny(3))
    assert is_synchronizing_word(aut, [1, 0, 0, 1])
    assert not is_synchronizing_word(aut, [1, 0, 0])


# ----------------------------------------------------------------------------- epsilon-synchronizing
def _entropy(p, partition):
    cells = {}
    for s, x in enumerate(p):
        c = s if partition is None else int(partition[s])
        cells[c] = cells.get(c, 0.0) + x
    v = np.array([x for x in cells.values() if x > 0])
    v = v / v.sum()
    return float(-np.sum(v * np.log2(v)))


def test_epsilon_word_matches_exhaustive_enumeration():
    rng = np.random.default_rng(17)
    for trial in range(12):
        n, k = 6, 3
        mats = []
        for _ in range(k):
            m = rng.random((n, n)) * (rng.random((n, n)) < 0.35)
            m[np.arange(n), rng.integers(0, n, n)] += 1.0
            mats.append(m / m.sum(axis=1, keepdims=True))
        partition = rng.integers(0, 3, n) if trial % 2 else None
        model = TransitionModel([f"a{i}" for i in range(k)], mats, partition=partition,
                                n_cells=None if partition is None else 3)
        eps = float(rng.uniform(0.2, 1.2))
        res = epsilon_synchronizing_word(model, eps, max_length=5, time_budget=math.inf)   # bounded by work
        # exhaustive: all words up to length 5
        best = None
        for length in range(6):
            for word in itertools.product(range(k), repeat=length):
                p = np.asarray(model.initial, dtype=float)
                for a in word:
                    p = p @ mats[a]
                if _entropy(p, partition) <= eps + 1e-12:
                    best = length
                    break
            if best is not None:
                break
        if best is None:
            assert res.word is None
        else:
            assert res.length == best and res.exact
            p = np.asarray(model.initial, dtype=float)
            for a in res.word:
                p = p @ mats[a]
            assert _entropy(p, partition) <= eps + 1e-9


@pytest.mark.parametrize("parallel", [False, True])
@pytest.mark.parametrize("chunk,block", [(1, 64), (7, 128), (256, 1 << 16)])
def test_meet_kernel_against_numpy(chunk, block, parallel):
    """The parallel subset test finds a pair F <= B exactly when one exists."""
    from kruskal_markov import _sync_kernels as kern

    rng = np.random.default_rng(chunk)
    n = 70
    outcomes = set()
    for _ in range(80):
        nf, nb = int(rng.integers(1, 300)), int(rng.integers(1, 400))
        F = rng.random((nf, n)) < rng.uniform(0.1, 0.3)
        B = rng.random((nb, n)) < rng.uniform(0.4, 0.8)
        F[F.sum(axis=1) == 0, 0] = True

        def pack(M):
            out = np.zeros((M.shape[0], 2), dtype=np.uint64)
            for i, row in enumerate(M):
                for q in np.flatnonzero(row):
                    out[i, q >> 6] |= np.uint64(1) << np.uint64(q & 63)
            return out

        f, b = kern.meet(pack(F), 0, nf, pack(B), 0, nb, n, block, chunk, parallel)
        exists = bool(np.any((F[:, None, :] & ~B[None, :, :]).sum(axis=2) == 0))
        assert (f >= 0) == exists
        outcomes.add(exists)
        if f >= 0:
            assert not np.any(F[f] & ~B[b])
    assert outcomes == {True, False}


def test_functions_take_a_model_or_its_support_automaton_alike():
    """A TransitionModel stands for its support automaton and start set: same words, same answers;
    anything else is refused."""
    from kruskal_markov.convergence import exact_expected_length, pair_chain_bounds

    rng = np.random.default_rng(4)
    n = 7
    mats = []
    for _ in range(2):
        a = np.zeros((n, n))
        a[np.arange(n), rng.integers(0, n, n)] = 0.7
        a[np.arange(n), rng.integers(0, n, n)] += 0.3
        mats.append(sp.csr_matrix(a))
    init = np.zeros(n)
    init[[1, 3, 4]] = 1 / 3
    model = TransitionModel(["a", "b"], mats, initial=init)
    aut, start = support_automaton(model), start_set(model)
    assert list(start) == [1, 3, 4]
    via_model = shortest_synchronizing_word(model)
    via_aut = shortest_synchronizing_word(aut, start)
    assert via_model.as_dict() == via_aut.as_dict()
    assert greedy_synchronizing_word(model) == greedy_synchronizing_word(aut, start)
    assert synchronizability(model) == synchronizability(aut, start)
    if via_aut.word is not None:
        assert is_synchronizing_word(model, via_aut.word)
    e_model = exact_expected_length(model)
    e_aut = exact_expected_length(aut, start)
    assert e_model == e_aut
    assert pair_chain_bounds(model) == pair_chain_bounds(aut, start)
    with pytest.raises(TypeError, match="SyncAutomaton or a TransitionModel"):
        shortest_synchronizing_word([[0, 1], [1, 1]])


def test_pair_by_pair_greedy_when_eppstein_does_not_fit():
    """Without room for Eppstein's tables the greedy word comes from merging one pair at a time,
    also through set-valued start rows (a model's uniform first tilt): the word must synchronize."""
    rng = np.random.default_rng(4)
    n = 60
    table = np.array([[min(q + 1, n - 1) for q in range(n)],            # slide right, stop at the wall
                      [max(q - 1, 0) for q in range(n)],
                      list(rng.integers(0, n, size=n))])
    aut = SyncAutomaton.from_table(table)
    word = greedy_synchronizing_word(aut, np.arange(n), stages=("pairs",))
    assert word is not None and is_synchronizing_word(aut, word, np.arange(n))
    assert greedy_synchronizing_word(aut, memory_budget_mb=1e-6) is not None
    # a start state n with set-valued rows (to every state) in front of the deterministic part
    mats = [sp.csr_matrix((np.ones(n), (np.arange(n), t)), shape=(n + 1, n + 1)) for t in table]
    mats = [m + sp.csr_matrix((np.full(n, 1.0 / n), (np.full(n, n), np.arange(n))), shape=(n + 1, n + 1))
            for m in mats]
    model = TransitionModel(["a", "b", "c"], mats, initial=np.eye(n + 1)[n])
    set_valued = support_automaton(model, 0.0)
    assert not set_valued.deterministic
    word = greedy_synchronizing_word(set_valued, np.array([n]), stages=("pairs",))
    assert word is not None and is_synchronizing_word(set_valued, word, np.array([n]))


def test_pair_by_pair_greedy_through_rows_spread_under_one_letter():
    """Rows that member probes spread (set-valued under one letter, single under the others) do
    not stop the pair merging: the pair searches go around them and the word synchronizes."""
    n = 40
    table = np.array([[min(q + 1, n - 1) for q in range(n)],            # slide right, stop at the wall
                      [max(q - 1, 0) for q in range(n)]])
    mats = [sp.csr_matrix((np.ones(n), (np.arange(n), t)), shape=(n, n)).tolil() for t in table]
    for q in range(0, n, 5):                                             # every fifth state spreads under "left"
        mats[1][q, max(q - 1, 0)] = 0.5
        mats[1][q, min(q + 1, n - 1)] = 0.5
    model = TransitionModel(["right", "left"], [m.tocsr() for m in mats], initial=np.full(n, 1.0 / n))
    aut = support_automaton(model, 0.0)
    assert not aut.deterministic
    word = greedy_synchronizing_word(aut, np.arange(n), stages=("pairs",))
    assert word is not None and is_synchronizing_word(aut, word, np.arange(n))


# ----------------------------------------------------------------------------- values against brute force
def brute_pair_distance(table, p, q):
    """Shortest word merging states p and q: plain BFS over (unordered) pairs; -1 when none."""
    start = (min(p, q), max(p, q))
    seen = {start}
    queue = deque([(start, 0)])
    while queue:
        (x, y), d = queue.popleft()
        for a in range(len(table)):
            u, v = int(table[a][x]), int(table[a][y])
            if u == v:
                return d + 1
            nxt = (min(u, v), max(u, v))
            if nxt not in seen:
                seen.add(nxt)
                queue.append((nxt, d + 1))
    return -1


def test_pair_distances_cerny4_match_brute_force():
    """Cerny C_4, pairs in row order (0,1), (0,2), (0,3), (1,2), (1,3), (2,3)."""
    table = cerny(4)
    brute = [brute_pair_distance(table, p, q) for p, q in itertools.combinations(range(4), 2)]
    assert brute == [4, 6, 1, 3, 5, 2]
    dist, first = SyncAutomaton.from_table(table).pair_distances()
    assert dist.tolist() == brute
    # the first letter starts a shortest merging word: one step with it leaves a pair one closer
    for (p, q), d, a in zip(itertools.combinations(range(4), 2), dist, first):
        u, v = int(table[a][p]), int(table[a][q])
        assert (u == v) if d == 1 else brute_pair_distance(table, u, v) == d - 1


def test_pair_distances_random_match_brute_force():
    never = 0
    for rng, n, table in random_tables(4242, 150, (2, 12), k=(1, 4)):
        dist, first = SyncAutomaton.from_table(table).pair_distances()
        brute = [brute_pair_distance(table, p, q) for p, q in itertools.combinations(range(n), 2)]
        assert dist.tolist() == brute
        never += brute.count(-1)
        for (p, q), d, a in zip(itertools.combinations(range(n), 2), dist, first):
            if d > 0:
                u, v = int(table[a][p]), int(table[a][q])
                assert (u == v) if d == 1 else brute_pair_distance(table, u, v) == d - 1
    assert never > 0      # some pairs never merge: the -1 branch is exercised


def test_lower_bound_never_above_brute_force_and_exact_means_shortest():
    """Stopped by a small budget of work, the proven lower bound never exceeds the true shortest
    length (brute force), the word is never shorter than it, and ``exact`` holds only at equality."""
    stopped = exact_by_bound = 0
    for rng, n, table in random_tables(777, 300, (4, 11)):
        truth = brute_det(table)
        if truth is None:
            continue
        res = shortest_synchronizing_word(SyncAutomaton.from_table(table), node_budget=int(rng.integers(n, 3 * n)))
        assert len(plain_image(table, range(n), res.word)) == 1
        assert res.length >= truth
        if res.method.startswith("greedy"):
            stopped += 1
            assert 1 <= res.lower_bound <= truth
            assert res.exact == (res.length == res.lower_bound)
            exact_by_bound += res.exact
        if res.exact:
            assert res.length == truth
    assert stopped > 50 and exact_by_bound > 0   # both budget outcomes were exercised
    # Cerny automata stopped early: the bound is below the known (n - 1)^2, the greedy word above it
    for n in (6, 8, 10):
        res = shortest_synchronizing_word(SyncAutomaton.from_table(cerny(n)), node_budget=2 * n)
        assert res.exact is False and res.lower_bound <= (n - 1) ** 2 < res.length


def test_lower_bound_after_a_time_budget_stop_never_above_brute_force():
    """The time-budget branches of the exact search, made deterministic by a fake clock that
    advances one 'second' per reading: stopped at every point a budget can stop it, the proven
    lower bound never exceeds the true shortest length and ``exact`` holds only at equality."""
    clock = {"t": 0.0}

    def tick():
        clock["t"] += 1.0
        return clock["t"]
    stopped = 0
    for rng, n, table in random_tables(99, 120, (4, 11)):
        truth = brute_det(table)
        if truth is None:
            continue
        res = shortest_synchronizing_word(SyncAutomaton.from_table(table), time_budget=float(rng.integers(2, 40)),
                                          clock=tick)
        if res.word is not None:
            assert len(plain_image(table, range(n), res.word)) == 1 and res.length >= truth
        if res.lower_bound is not None:
            assert res.lower_bound <= truth
        if res.exact:
            assert res.length == truth
        stopped += res.method.startswith("greedy")
    assert stopped > 20


# ----------------------------------------------------------------------------- the pair test: every answer, whole
def _brute_reachable(table, start):
    seen, todo = set(int(s) for s in start), list(int(s) for s in start)
    while todo:
        q = todo.pop()
        for row in table:
            r = int(row[q])
            if r not in seen:
                seen.add(r)
                todo.append(r)
    return sorted(seen)


def test_synchronizability_of_start_subsets_follows_its_definition():
    """For a start subset of a deterministic automaton: False (with the first non-merging start pair)
    when some start pair never merges; True when every pair of the states reachable from the start
    merges (then greedy merging synchronizes it: checked by brute force); None otherwise."""
    from kruskal_markov.sync.pairs import _reachable_states

    rng = np.random.default_rng(2024)
    seen = {True: 0, False: 0, None: 0}
    for _ in range(400):
        n, k = int(rng.integers(3, 9)), int(rng.integers(1, 3))
        table = random_table(rng, n, k)
        start = sorted(int(x) for x in rng.choice(n, size=int(rng.integers(2, n)), replace=False))
        aut = SyncAutomaton.from_table(table)
        reach = _brute_reachable(table, start)
        assert _reachable_states(aut, np.array(start)).tolist() == reach
        bad = [(p, q) for p, q in itertools.combinations(start, 2) if not brute_pair_mergeable(table, p, q)]
        got = synchronizability(aut, start)
        if bad:
            p, q = bad[0]
            want = {"synchronizing": False, "witness": {"kind": "pair", "states": [p, q],
                                                        "reason": f"no word merges states {p} and {q}"}}
        elif all(brute_pair_mergeable(table, p, q) for p, q in itertools.combinations(reach, 2)):
            want = {"synchronizing": True, "witness": None}
            assert brute_det(table, start) is not None
        else:
            want = {"synchronizing": None, "witness": None}
        assert got == want
        seen[want["synchronizing"]] += 1
    assert min(seen.values()) >= 10, seen


def test_synchronizability_whole_answers():
    cerny4 = SyncAutomaton.from_table(cerny(4))
    assert synchronizability(cerny4) == {"synchronizing": True, "witness": None}
    assert synchronizability(cerny4, [2]) == {"synchronizing": True, "witness": None}
    # 0 <-> 1 swapped by every letter, 2 and 3 absorbing into 2: the pair {0, 1} never merges
    table = [[1, 0, 2, 2], [1, 0, 2, 2]]
    assert synchronizability(SyncAutomaton.from_table(table)) == {
        "synchronizing": False,
        "witness": {"kind": "pair", "states": [0, 1], "reason": "no word merges states 0 and 1"}}
    assert synchronizability(SyncAutomaton.from_table(table), [2, 3]) == {"synchronizing": True, "witness": None}
    # set-valued, every pair merges: the pair test cannot decide
    sup = [[frozenset({0, 1}), frozenset({1}), frozenset({2})], [frozenset({1}), frozenset({2}), frozenset({0})]]
    aut = support_automaton(model_from_support(sup))
    assert not aut.deterministic
    assert synchronizability(aut) == {"synchronizing": None, "witness": None}


def test_the_start_subset_path_checks_pairs_among_reachable_states_only():
    """Start {0, 1} of a 5-state automaton: both go to 1 under ``a``, and 1 only reaches itself; the
    pair {0, 4}, of a state that is neither, never merges (4 is fixed, 0 goes to 1 and 1 stays).
    Reachable states {0, 1}: their only pair merges, so True."""
    table = [[1, 1, 3, 2, 4], [0, 1, 3, 2, 4]]
    aut = SyncAutomaton.from_table(table)
    assert not brute_pair_mergeable(table, 0, 4) and not brute_pair_mergeable(table, 2, 3)
    assert synchronizability(aut, [0, 1]) == {"synchronizing": True, "witness": None}


def test_pair_table_memory_by_hand():
    from kruskal_markov.sync.pairs import PAIR_CHECK_BYTES, _eppstein_fits, eppstein_memory_mb, pair_check_memory_mb

    assert PAIR_CHECK_BYTES == 40
    for n in (2, 1000):
        pairs = n * (n - 1) // 2
        assert pair_check_memory_mb(n) == pytest.approx(pairs * 40 / 2 ** 20, rel=1e-12)
        assert eppstein_memory_mb(n) == pytest.approx((pairs * 40 + 16 * n * n) / 2 ** 20, rel=1e-12)
    aut = SyncAutomaton.from_table(cerny(5))
    need = eppstein_memory_mb(5)
    assert _eppstein_fits(aut, need) and _eppstein_fits(aut, None)
    assert not _eppstein_fits(aut, need * (1 - 1e-12))
    sup = [[frozenset({0, 1}), frozenset({1})]]
    assert not _eppstein_fits(support_automaton(model_from_support(sup)), None)


# ----------------------------------------------------------------------------- the exact search: budgets and answers, whole
def _fake_clock(start=10.0 ** 6):
    """A clock far from zero (like a real monotonic one) that advances one second per reading."""
    clock = itertools.count(start)
    return lambda: float(next(clock))


def test_every_result_kind_reports_its_seconds_and_work():
    """Trivial, pair-graph, found, exhaustive none, upper (the greedy word proven shortest) and
    budget answers, whole where they are fixed, on a fake clock (seconds: a few readings, never
    the clock's own value)."""
    clock = _fake_clock()
    beam_first = ExactSearchOptions(fast_nodes=None)        # the beam first, as the methods below say

    def run(table, options=beam_first, **kw):
        return shortest_synchronizing_word(SyncAutomaton.from_table(table), time_budget=None, options=options,
                                           clock=clock, **kw)

    trivial = run(cerny(3), start=[1])
    assert (trivial.word, trivial.length, trivial.exact, trivial.method) == ([], 0, True, "trivial")
    swaps = [[1, 0, 3, 2], [0, 1, 2, 3]]                     # {0, 1} and {2, 3} swapped or fixed
    never = run(swaps)
    assert (never.word, never.exact, never.method) == (None, True, "pair-graph")
    assert never.witness == {"kind": "pair", "states": [0, 1], "reason": "no word merges states 0 and 1"}
    assert run(swaps, start=[2, 3]).witness["states"] == [2, 3]          # the start's own pair
    found = run(cerny(5))                                   # the beam's word (16 letters) proven shortest
    assert (found.length, found.exact, found.method, found.lower_bound) == (16, True, "beam+lower-bound", 16)
    no_beam = ExactSearchOptions(fast_nodes=None, use_beam=False)
    found = run(cerny(5), no_beam)
    assert (found.length, found.exact, found.method, found.lower_bound) == (16, True, "bidirectional-bfs", 16)
    upper = run(cerny(3), no_beam)                                    # Eppstein's word (4 letters) is shortest
    assert (upper.length, upper.exact, upper.method, upper.lower_bound, upper.greedy_length, upper.notes) == \
        (4, True, "greedy-eppstein+lower-bound", 4, 4, ())
    assert upper.states_explored > 0
    budget = run(cerny(6), no_beam, node_budget=5)
    assert not budget.exact and budget.method == "greedy-eppstein"
    assert budget.greedy_length == len(budget.word) == budget.length
    assert budget.notes[0] == f"exact search stopped by its budget; no synchronizing word is shorter than " \
                              f"{budget.lower_bound}"
    for r in (trivial, never, found, upper, budget):
        assert 0 < r.seconds < 1000


def test_exhaustive_none_when_the_pair_check_does_not_fit():
    """Two swapped pairs on 20 states: the pair table (190 pairs, 0.0072 MB) needs more than half of
    a 0.01 MB budget, so the pair check is skipped and the exhaustive search answers; with room
    for it the pair check does."""
    clock = _fake_clock()
    n = 20
    table = [[(q + 1) % 10 + 10 * (q >= 10) for q in range(n)], list(range(n))]     # two 10-cycles
    aut = SyncAutomaton.from_table(table)
    r = shortest_synchronizing_word(aut, time_budget=None, memory_budget_mb=0.01, clock=clock)
    assert (r.word, r.length, r.exact, r.method) == (None, None, True, "bidirectional-bfs")
    assert r.witness == {"kind": "exhaustive", "subsets_explored": r.states_explored,
                         "reason": "exhaustive subset search: no image of the start set is a single state"}
    assert r.states_explored > 0 and 0 < r.seconds < 1000
    assert shortest_synchronizing_word(aut, time_budget=None, memory_budget_mb=0.015).method == "pair-graph"


def test_without_room_for_eppsteins_tables_the_method_and_notes_say_so():
    aut = SyncAutomaton.from_table(cerny(5))
    r = shortest_synchronizing_word(aut, time_budget=None, memory_budget_mb=0.0007, node_budget=1)
    assert r.method == "greedy" and not r.exact and r.lower_bound == 1 and r.greedy_length == r.length == len(r.word)
    assert r.notes == ("exact search stopped by its budget; no synchronizing word is shorter than 1",
                       "greedy by merging one pair at a time (pair graph searched from each pair): Eppstein's "
                       "tables would need about 0 MB (over the memory budget)")


def test_greedy_gets_forty_percent_of_the_time_budget():
    """Set-valued rows: the greedy word comes from pair merging, which checks its deadline (t0 + 40%
    of the budget) on every step; on a fake clock with 1,000 readings of budget it finishes."""
    sup = [[frozenset({1}), frozenset({2}), frozenset({0, 3}), frozenset({3})],
           [frozenset({0}), frozenset({1}), frozenset({3}), frozenset({0})]]
    aut = support_automaton(model_from_support(sup))
    assert not aut.deterministic
    r = shortest_synchronizing_word(aut, time_budget=1000.0, node_budget=1, clock=_fake_clock())
    assert r.word is not None and r.greedy_length == len(r.word)
    assert not any("greedy word not found" in note for note in r.notes)


def test_stores_follow_the_memory_budget():
    """Three eighths of the budget per direction, 8 W + 44 bytes a row (bitset, parent, letter, hash
    slots), at least 1,024 rows; an automaton whose n backward roots do not fit gets no exact search
    (every singleton a root: the restriction to merging states switched off)."""
    from kruskal_markov.sync.exact import _exact_search

    every_root = ExactSearchOptions(restrict_roots=False)

    n = 2000
    aut = SyncAutomaton.from_table(np.random.default_rng(0).integers(0, n, size=(2, n)))
    row = 8 * 32 + 44

    def mb_for(rows):           # the budget whose three eighths hold ``rows`` rows (and a half)
        return (rows + 0.5) * row * 8 / 3 / 2 ** 20

    s = np.arange(n)
    assert _exact_search(aut, s, None, mb_for(n), node_budget=1, options=every_root) == (None, "budget", 0, 1)
    word, status, explored, lower = _exact_search(aut, s, None, mb_for(n + 1), node_budget=1, options=every_root)
    assert (word, status, lower) == (None, "budget", 1) and explored == n + 1      # one root each way
    small = SyncAutomaton.from_table(np.random.default_rng(0).integers(0, 1024, size=(2, 1024)))
    assert _exact_search(small, np.arange(1024), None, 1e-3, node_budget=1, options=every_root) == \
        (None, "budget", 0, 1)


def test_depth_first_phase_stops_at_its_node_budget():
    """Past the breadth-first stores (a 0.05 MB budget), the depth-first phase counts the subsets it
    generates against the node budget: a budget between what the breadth-first phase used and what
    the whole search needs stops it there, with a proven lower bound at most the shortest length."""
    no_beam = ExactSearchOptions(use_beam=False)      # the beam's word would be proven shortest first
    rng = np.random.default_rng(1)
    n = 60
    table = rng.integers(0, n, size=(2, n))
    aut = SyncAutomaton.from_table(table)
    full = shortest_synchronizing_word(aut, time_budget=None, memory_budget_mb=0.05, node_budget=10**8, options=no_beam)
    assert full.method == "bidirectional-bfs+dfs" and full.exact
    stops = 0
    for budget in (2100, 2500, 4000, (2048 + full.states_explored) // 2, full.states_explored - 1):
        r = shortest_synchronizing_word(aut, time_budget=None, memory_budget_mb=0.05, node_budget=budget,
                                        options=no_beam)
        assert r.lower_bound <= full.length and r.length >= full.length
        assert r.exact == (r.length == full.length == r.lower_bound)
        if not r.exact:
            stops += 1
            assert r.states_explored >= budget
    assert stops >= 3


def test_levels_of_more_than_ten_thousand_subsets():
    """The search re-measures its cost per subset on levels over 10,000 (n = 64, k = 4 reaches 12,316).
    13 letters: the plain breadth-first search's answer (``brute_bitmask``, 10 s, run once)."""
    table = np.random.default_rng(0).integers(0, 64, size=(4, 64))
    r = shortest_synchronizing_word(SyncAutomaton.from_table(table), time_budget=None)
    assert r.exact and r.length == 13 and len(plain_image(table, range(64), r.word)) == 1


# ----------------------------------------------------------------------------- greedy words: which method, and its edge cases
def test_greedy_word_is_eppsteins_when_its_tables_fit_else_pair_merging():
    """The documented order: Eppstein's word when his tables fit the memory budget, else the word of
    merging one pair at a time."""
    from kruskal_markov import _sync_kernels as _k
    from kruskal_markov.sync.pairs import eppstein_memory_mb

    rng = np.random.default_rng(17)
    pair_merged = 0
    for table in [cerny(6), cerny(7)] + [random_table(rng, 12, 2) for _ in range(6)]:
        aut = SyncAutomaton.from_table(table)
        n = aut.n
        if brute_det(table) is None:
            continue
        dist, nxt = aut.pair_distances()
        out = np.empty(max(16, n ** 3 // 6 + n), dtype=np.int32)
        length = _k.eppstein_greedy(aut.delta, np.arange(n, dtype=np.int64), dist, nxt, out)
        assert greedy_synchronizing_word(aut) == [int(x) for x in out[:length]]
        tight = eppstein_memory_mb(n) * 0.99
        merged = greedy_synchronizing_word(aut, stages=("pairs",))      # None past 4 n letters (C_6 needs 25)
        if merged is not None:
            assert greedy_synchronizing_word(aut, memory_budget_mb=tight) == merged
            pair_merged += 1
    assert pair_merged >= 4


def test_pair_merging_on_deterministic_rows_and_merges_into_state_zero():
    """Deterministic rows are single-valued rows: pair merging follows them (Cerny C_3 and C_4: the
    smallest-image rule of set-valued starts would cycle through the rotation). A pair that merges
    only into state 0 is merged."""
    for n in (3, 4):
        aut = SyncAutomaton.from_table(cerny(n))
        word = greedy_synchronizing_word(aut, stages=("pairs",))
        assert word is not None and is_synchronizing_word(aut, word)
    into_zero = SyncAutomaton.from_table([[1, 2, 3, 0], [0, 0, 0, 0]])
    assert greedy_synchronizing_word(into_zero, stages=("pairs",)) == [1]


def test_greedy_descent_searches_on_when_no_letter_shrinks_the_set():
    """Cerny C_5: after b, no single letter shrinks {1, 2, 3, 4}; the descent goes on breadth-first."""
    aut = SyncAutomaton.from_table(cerny(5))
    word = greedy_synchronizing_word(aut, node_budget=10 ** 5, stages=("descent",))
    assert word is not None and is_synchronizing_word(aut, word)


# ----------------------------------------------------------------------------- the support automaton, whole
def test_automaton_messages_and_default_names():
    import re

    for table, message in (([[]], "a transition table must have shape (letters, states) with both > 0"),
                           ([[0.5, 1.0]], "a transition table must hold integer state indices"),
                           ([[0, 2]], "transition table entries must lie in [0, 2)")):
        with pytest.raises(ValueError, match="^" + re.escape(message) + "$"):
            SyncAutomaton.from_table(table)
    aut = SyncAutomaton.from_table([[1, 0], [0, 0]])
    assert aut.actions == ("0", "1")
    for word in ([2], [-1], [0, 2]):
        with pytest.raises(ValueError, match=r"^letters must lie in \[0, 2\)$"):
            aut.image([0, 1], word)


def test_support_threshold_keeps_entries_equal_to_it_and_reports_mean_mass_dropped():
    """Entries >= threshold are kept (0.25 at threshold 0.25 stays); mass_dropped is the largest mass
    removed from one row, mass_dropped_mean the mass removed per (state, action)."""
    a = np.array([[0.5, 0.25, 0.25], [0.0, 1.0, 0.0], [0.1, 0.0, 0.9]])
    b = np.eye(3)
    model = TransitionModel(["a", "b"], [a, b])
    at = support_automaton(model, 0.25)
    assert at.image([0], [0]) == [0, 1, 2]
    assert (at.mass_dropped, at.mass_dropped_mean) == (0.1, pytest.approx(0.1 / 6, rel=1e-12))
    above = support_automaton(model, 0.3)
    assert above.image([0], [0]) == [0]
    assert above.mass_dropped == 0.5 and above.mass_dropped_mean == pytest.approx(0.6 / 6, rel=1e-12)
    none = support_automaton(model)
    assert (none.mass_dropped, none.mass_dropped_mean) == (0.0, 0.0)


def test_as_automaton_takes_models_with_their_start_or_a_given_one():
    import types

    from kruskal_markov.sync import as_automaton

    model = TransitionModel(["a", "b"], [np.eye(3)[[1, 2, 0]], np.eye(3)[[0, 0, 2]]], initial=[0.5, 0.5, 0.0])
    aut, start = as_automaton(model)
    assert aut.deterministic and list(start) == [0, 1, 2]        # deterministic: every state
    # cached on the model under the key plan.py uses for threshold 0 (one support automaton per threshold)
    assert model.memo(("support_automaton", 0.0), lambda: pytest.fail("not cached")) is aut
    assert as_automaton(model, [1, 2])[1] == [1, 2]
    with pytest.raises(TypeError, match="^expected a SyncAutomaton or a TransitionModel, got int$"):
        as_automaton(3)
    with pytest.raises(TypeError, match="got SimpleNamespace$"):
        as_automaton(types.SimpleNamespace(matrices=[]))


# ----------------------------------------------------------------------------- epsilon words: every answer, whole
def _det_model(table, **kw):
    n = len(table[0])
    mats = [sp.csr_matrix((np.ones(n), (np.arange(n), np.asarray(t))), shape=(n, n)) for t in table]
    return TransitionModel([f"a{i}" for i in range(len(table))], mats, **kw)


def test_epsilon_word_answers_whole():
    """On a fake clock: already within epsilon (the empty word), found (with the entropy reached),
    stopped by the node budget (the lowest-entropy word seen), proven impossible (every reachable
    distribution expanded), and none up to max_length (default 30)."""
    from kruskal_markov.sync import epsilon_synchronizing_word as _epsilon_word

    ticks = itertools.count(10.0 ** 6)

    def epsilon_synchronizing_word(*args, **kwargs):
        return _epsilon_word(*args, clock=lambda: float(next(ticks)), **kwargs)

    cerny3 = _det_model(cerny(3))
    at_start = epsilon_synchronizing_word(cerny3, math.log2(3))
    assert (at_start.word, at_start.length, at_start.exact, at_start.method) == ([], 0, True, "distribution-bfs")
    assert at_start.seconds == 1.0
    found = epsilon_synchronizing_word(cerny3, 0.0)
    assert (found.word, found.length, found.exact, found.method, found.lower_bound) == \
        (plain_shortest_word(cerny(3)), 4, True, "distribution-bfs", 4)
    assert found.notes == ("entropy 0 bits",) and found.states_explored > 4 and 0 < found.seconds < 1000
    assert epsilon_synchronizing_word(cerny3, 0.0, max_length=4).length == 4        # max_length is inclusive
    cerny5 = _det_model(cerny(5))
    stop = epsilon_synchronizing_word(cerny5, 0.0, node_budget=3)
    assert (stop.word, stop.length, stop.exact, stop.method) == (None, None, False, "distribution-bfs")
    # b sends state 4 to 0: (2/5, 1/5, 1/5, 1/5); the next distinct ones (a b, then depth 3) pass 3 nodes
    h = -(0.4 * math.log2(0.4) + 3 * 0.2 * math.log2(0.2))
    assert stop.lower_bound == 3 and stop.best_word == [1] and stop.greedy_length == 1
    assert stop.notes == (f"budget reached at depth 3; lowest entropy seen {h:.6g} bits by a word of length 1",)
    assert 0 < stop.seconds < 1000
    swaps = _det_model([[1, 0, 3, 2], [0, 1, 2, 3]])
    never = epsilon_synchronizing_word(swaps, 0.5)
    assert (never.word, never.exact, never.method, never.lower_bound) == (None, True, "distribution-bfs", None)
    assert never.witness == {"kind": "exhaustive", "reason": "all 1 reachable distributions have entropy > 0.5"}
    assert 0 < never.seconds < 1000
    cerny7 = _det_model(cerny(7))                    # 36 letters: beyond the default 30
    long = epsilon_synchronizing_word(cerny7, 0.0, time_budget=math.inf)
    assert (long.word, long.exact, long.lower_bound) == (None, False, 31)
    assert long.notes == ("no word of length <= 30 reaches entropy <= 0.0",) and long.method == "distribution-bfs"
    assert 0 < long.seconds < 10 ** 5
    unlimited = epsilon_synchronizing_word(cerny7, 0.0, time_budget=None)   # None: no time limit, as its siblings
    assert (unlimited.word, unlimited.exact, unlimited.lower_bound, unlimited.notes) == \
        (None, False, 31, long.notes)


def plain_shortest_word(table):
    """The first shortest synchronizing word in breadth-first order, letters in index order."""
    n = len(table[0])
    seen, level = {frozenset(range(n)): []}, [(frozenset(range(n)), [])]
    while level:
        nxt = []
        for s, w in level:
            for a in range(len(table)):
                t = frozenset(int(table[a][q]) for q in s)
                if len(t) == 1:
                    return w + [a]
                if t not in seen:
                    seen[t] = w + [a]
                    nxt.append((t, w + [a]))
        level = nxt
    return None


def test_sync_result_as_dict_whole():
    """The ``kruskal sync`` JSON keys; letters named when the actions are given; notes a tuple."""
    from kruskal_markov.sync import SyncResult

    r = SyncResult([1, 0, 1], 3, False, "greedy", witness={"kind": "x"}, lower_bound=2, greedy_length=3,
                   states_explored=17, seconds=0.5, notes=["a note"])
    assert r.notes == ("a note",)
    want = {"word": [1, 0, 1], "length": 3, "exact": False, "method": "greedy", "witness": {"kind": "x"},
            "lower_bound": 2, "greedy_length": 3, "states_explored": 17, "notes": ["a note"], "threads": 1}
    assert r.as_dict() == want
    assert r.as_dict(("N", "E")) == {**want, "word": ["E", "N", "E"]}
    none = SyncResult(None, None, True, "pair-graph")
    assert none.as_dict(("N", "E"))["word"] is None and none.notes == ()


def test_depth_first_phase_budget_status():
    """_exact_search's contract: a node budget that stops the depth-first phase (past the 2,048 rows
    of the breadth-first stores of a 0.05 MB budget) returns status 'budget' with the subsets counted."""
    from kruskal_markov.sync.exact import _exact_search

    n = 60
    aut = SyncAutomaton.from_table(np.random.default_rng(1).integers(0, n, size=(2, n)))
    word, status, explored, lower = _exact_search(aut, np.arange(n), None, 0.05, node_budget=2500)
    assert (word, status) == (None, "budget") and explored >= 2500 and lower >= 1


def _predicted_stops(table, budget, max_levels=None):
    """A plain-Python model of the breadth-first search's time prediction on a clock that never
    moves: forward levels (new images of all states), backward levels (new non-empty preimages
    of the singletons), a meet test on each new total, the side with the smaller newest level
    expanded (forward on a tie); before it, the predicted cost ``new_rows * rate_row + new_rows
    * other * rate_pair`` with ``new_rows`` the newest level times its growth over the level
    before (at least 1, at most k; k for a root level), ``other`` the other side's newest level,
    the first guesses ``rate_row = 2e-7 max(1, W/16)`` and ``rate_pair = 5e-11 max(1, W/4)``
    s. Returns ``(status, subsets, lower bound, [predicted costs])`` of a search with ``budget``
    seconds (``max_levels``: the model stops after that many expansions, status None)."""
    k, n = len(table), len(table[0])
    W = (n + 63) // 64
    rate_row, rate_pair = 2e-7 * max(1.0, W / 16), 5e-11 * max(1.0, W / 4)
    inv = [[[q for q in range(n) if table[a][q] == r] for r in range(n)] for a in range(k)]
    fwd, bwd = [[frozenset(range(n))]], [[frozenset([q]) for q in range(n)]]
    seen = {True: set(fwd[0]), False: set(bwd[0])}
    total, costs = 0, []
    while True:
        if any(f <= b for f in fwd[-1] for b in bwd[-1]):
            return "found", len(seen[True]) + len(seen[False]), total, costs
        forward = len(fwd[-1]) <= len(bwd[-1])
        levels, other = (fwd, bwd) if forward else (bwd, fwd)
        growth = k if len(levels) < 2 else max(1.0, len(levels[-1]) / max(1, len(levels[-2])))
        new_rows = len(levels[-1]) * min(growth, k)
        cost = new_rows * rate_row + new_rows * len(other[-1]) * rate_pair
        costs.append(cost)
        if cost > budget:
            return "budget", len(seen[True]) + len(seen[False]), total + 1, costs
        new = []
        for x in levels[-1]:
            for a in range(k):
                y = frozenset(table[a][q] for q in x) if forward else \
                    frozenset(p for r in x for p in inv[a][r])
                if y and y not in seen[forward]:
                    seen[forward].add(y)
                    new.append(y)
        if not new:
            return "none", len(seen[True]) + len(seen[False]), total, costs
        levels.append(new)
        total += 1
        if total == max_levels:
            return None, None, None, costs


def test_the_time_prediction_stops_before_the_first_level_that_would_not_fit():
    """On a clock that never moves, the breadth-first search stops exactly before the first
    expansion whose predicted cost exceeds the time budget and hands that level over to the
    streaming (depth-first) phase, which there completes with the shortest word: budgets just below and just above each predicted cost of a plain
    model (:func:`_predicted_stops`), on small random automata (growth, shrinking levels, both
    sides) and on 300 states (bitsets of 5 words, where the meet-test guess grows with W)."""
    from kruskal_markov.sync.exact import _exact_search

    every_root = ExactSearchOptions(restrict_roots=False)  # the model below is the plain search's, from every singleton
    cases = [(n, [list(map(int, r)) for r in table]) for _, n, table in random_tables(5, 12, (5, 10), k=(2, 4))]
    cases.append((300, [list(map(int, r)) for r in random_table(np.random.default_rng(3), 300, 2)]))
    stops = set()
    for n, table in cases:
        aut = SyncAutomaton.from_table(table)
        costs = _predicted_stops(table, math.inf, 3 if n == 300 else None)[3]
        for cost in costs:
            for budget in (cost * (1 - 1e-9), cost * (1 + 1e-9)):
                status, explored, lower, _ = _predicted_stops(table, budget)
                # 300 states: a node budget stops the streaming phase (on this clock it would not stop)
                nodes = explored + 20_000 if (status == "budget" and n == 300) else None
                word, *got = _exact_search(aut, np.arange(n), budget, 64.0, node_budget=nodes, options=every_root,
                                           clock=lambda: 0.0)
                if nodes is not None:
                    assert got[0] == "budget" and got[1] >= nodes and got[2] >= lower
                    stops.add((True, "budget"))
                    continue
                if status == "budget":  # the level predicted to overrun is tested streaming (issue 43):
                    # on a clock that never moves that phase completes, with the shortest word
                    assert got[0] in ("found-dfs", "none"), (n, budget)
                    if got[0] == "none":
                        assert brute_det(table) is None
                    else:
                        assert len(word) == got[2] == brute_det(table)
                    stops.add((n == 300, "budget"))
                    continue
                assert got == [status, explored, lower], (n, budget)
                if status == "found":
                    assert len(word) == lower == brute_det(table)
                stops.add((n == 300, status))
    assert stops >= {(False, "budget"), (False, "found"), (True, "budget")}


def test_the_meet_test_runs_when_the_clock_reads_the_deadline_exactly():
    """The budget is past only after its deadline. On a clock ticking one second per reading,
    Cerny C_4 (shortest word 9) and a budget of 5 s: readings t0, the meet test at total 0, the
    prediction (t0 + 2), the expansion, the meet test at total 1 (t0 + 4), the check before its
    first slice (t0 + 5: at the deadline, not past it: the slice runs and finds nothing), the
    prediction (t0 + 6: past it): stopped with lower bound 2. With 4 s the check before the slice
    is past the deadline: stopped with lower bound 1."""
    from kruskal_markov.sync.exact import _exact_search

    aut = SyncAutomaton.from_table(cerny(4))
    assert brute_det(cerny(4)) == 9
    for budget, lower in ((5.0, 2), (4.0, 1)):
        word, status, _, bound = _exact_search(aut, np.arange(4), budget, 64.0, clock=_fake_clock())
        assert (word, status, bound) == (None, "budget", lower)


def test_the_greedy_descent_gets_the_subsets_the_memory_budget_holds():
    """When the greedy word comes from the descent (the only stage asked for), its breadth-first
    searches hold at most ``memory_budget_mb`` of 8 W + 44-byte rows (bitset, parent, letter, hash
    slots): on Cerny C_18, whose descent needs more than 1,024 rows (the floor), a budget of exactly
    the rows it needs gives the descent's word and one row less gives None, as the descent with
    those node budgets does."""
    aut = SyncAutomaton.from_table(cerny(18))

    def descent(**kw):
        return greedy_synchronizing_word(aut, stages=("descent",), **kw)
    lo, hi = 1024, 1 << 14                          # the fewest rows the descent needs
    assert descent(node_budget=lo) is None and descent(node_budget=hi) is not None
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if descent(node_budget=mid) is not None else (mid, hi)
    word = descent(node_budget=hi)
    assert len(plain_image(cerny(18), range(18), word)) == 1
    row = 8 * 1 + 44
    assert descent(memory_budget_mb=(hi + 0.5) * row / 2 ** 20) == word
    assert descent(memory_budget_mb=(hi - 0.5) * row / 2 ** 20) is None


def test_the_greedy_descent_returns_its_word_once_a_single_state_is_reached():
    """The descent checks its deadline before each step only: letter 0 maps q to max(q - 1, 0),
    letter 1 fixes every state; from four states three steps of letter 0 reach state 0. On a clock
    ticking one second per reading (t0, t0 + 1, t0 + 2 before the steps) a deadline of t0 + 2
    gives the word, t0 + 1 gives None (passed before the third step)."""
    start = 10.0 ** 6
    table = [[0, 0, 1, 2], [0, 1, 2, 3]]
    aut = SyncAutomaton.from_table(table)
    assert plain_image(table, range(4), [0, 0, 0]) == {0} and plain_image(table, range(4), [0, 0]) == {0, 1}
    for deadline, want in ((start + 2, [0, 0, 0]), (start + 1, None)):
        assert greedy_synchronizing_word(aut, node_budget=1024, deadline=deadline, stages=("descent",),
                                         clock=_fake_clock(start)) == want


@pytest.mark.parametrize("chunk", [2, 3])
def test_depth_first_chunks_of_a_few_frontier_sets_cover_the_frontier(chunk):
    """The depth-first phase extends every set of the newest forward level, chunk by chunk: with
    chunks of 2 or 3 sets (the module's constant patched; 4,096 in use) on 60-state random
    automata too large for the breadth-first stores of 0.05 MB, the shortest length is still
    the brute-force one."""
    options = ExactSearchOptions(dfs_chunk=chunk, use_beam=False)   # the beam's word would be proven shortest first
    for seed in (1, 2, 4, 7):
        table = np.random.default_rng(seed).integers(0, 60, size=(2, 60))
        r = shortest_synchronizing_word(SyncAutomaton.from_table(table), time_budget=None, memory_budget_mb=0.05,
                                        node_budget=10 ** 8, options=options)
        assert r.method == "bidirectional-bfs+dfs" and r.exact
        assert r.length == brute_bitmask(table) and len(plain_image(table, range(60), r.word)) == 1


@pytest.mark.parametrize("bytes_48, chunk, whole", [(1050, 10, True), (1050, 11, False), (208, 4, True)])
def test_depth_first_chunks_stay_within_their_memory_cap_and_are_split_only_above_it(bytes_48, chunk, whole):
    """The depth-first phase gets a quarter of the memory budget and expands at most ``cap / k``
    sets at a time, ``cap = max(4 k, quarter / (8 W + 44) / 12)`` bytes-per-row; a larger batch
    is halved, a batch within the cap is expanded whole. Budgets of 48 x 1,050 and 48 x 208 bytes
    (a quarter of them is 12 x 1,050 and 12 x 208) give caps of 20 (1,050 / 52) and 8 (the 4 k
    floor over 208 / 52); frontier chunks (``dfs_chunk``) of 10 and 4 sets fit and are seen
    expanded whole, chunks of 11 never are. Every batch expanded is observed (the ``dfs-batch``
    event); the answers are the brute-force ones."""
    sizes = []

    def observe(event, value):
        if event == "dfs-batch":
            sizes.append(value)
    options = ExactSearchOptions(dfs_chunk=chunk, use_beam=False, observe=observe)   # the beam off: see above
    memory_mb = bytes_48 * 48 / 2 ** 20
    cap = max(4 * 2, int(memory_mb / 4 * 2 ** 20 / (8 + 44) / 12))
    assert cap == (20 if bytes_48 == 1050 else 8)
    for seed in (2, 7):
        sizes.clear()
        table = np.random.default_rng(seed).integers(0, 60, size=(2, 60))
        r = shortest_synchronizing_word(SyncAutomaton.from_table(table), time_budget=None, memory_budget_mb=memory_mb,
                                        node_budget=10 ** 8, options=options)
        assert r.method == "bidirectional-bfs+dfs" and r.length == brute_bitmask(table)
        assert sizes and max(sizes) * 2 <= cap
        assert (chunk in sizes) == whole


def test_pair_merging_searches_at_most_the_pairs_the_memory_budget_holds():
    """Pair merging's breadth-first search in the pair graph keeps at most ``memory_budget_mb /
    64 bytes`` pairs (at least 65,536): 600 states, two random permutations and a letter merging
    only 0 and 1, start {10, 500}. A plain pair-graph search finds the merging depth and the
    pairs within one letter less, more than 65,536; a budget holding exactly those pairs gives
    the merging word, one pair less gives None (Eppstein's tables and the descent planted as
    failing)."""
    n = 600
    rng = np.random.default_rng(0)
    c = np.arange(n)
    c[0] = 1
    table = [rng.permutation(n).tolist(), rng.permutation(n).tolist(), c.tolist()]
    level, seen, depth = [(10, 500)], {(10, 500)}, 0
    while True:                                        # pairs within ``depth`` letters: ``seen``
        within, nxt, merged = len(seen), [], False
        for x, y in level:
            for t in table:
                u, v = t[x], t[y]
                merged |= u == v
                if u != v and (min(u, v), max(u, v)) not in seen:
                    seen.add((min(u, v), max(u, v)))
                    nxt.append((min(u, v), max(u, v)))
        if merged:
            break
        level, depth = nxt, depth + 1
    assert within > 1 << 16
    aut = SyncAutomaton.from_table(table)
    word = greedy_synchronizing_word(aut, [10, 500], memory_budget_mb=(within + 0.5) * 64 / 2 ** 20, stages=("pairs",))
    assert len(word) == depth + 1 and len(plain_image(table, [10, 500], word)) == 1
    assert greedy_synchronizing_word(aut, [10, 500], memory_budget_mb=(within - 0.5) * 64 / 2 ** 20,
                                     stages=("pairs",)) is None
