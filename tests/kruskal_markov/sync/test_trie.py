"""Issue 43: subset-dominance pruning with an implicit subset trie (``kruskal_markov.sync._trie``).
Judges: a plain scan over every pair of sets, and breadth-first search over subsets for the
search results. Budgets in nodes, never seconds."""
from __future__ import annotations

import numpy as np
import pytest

from kruskal_markov import generators
from kruskal_markov.sync import (
    ExactSearchOptions,
    SyncAutomaton,
    _trie,
    is_synchronizing_word,
    shortest_synchronizing_word,
)
from tests.kruskal_markov.sync.test_exact import brute


def pack(M: np.ndarray) -> np.ndarray:
    """Boolean rows -> uint64 bitset rows."""
    n = M.shape[1]
    out = np.zeros((M.shape[0], (n + 63) // 64), dtype=np.uint64)
    for i, row in enumerate(M):
        for q in np.flatnonzero(row):
            out[i, q >> 6] |= np.uint64(1) << np.uint64(q & 63)
    return out


def random_family(rng, count, n):
    """``count`` random subsets of ``n`` states (density drawn per family, duplicates likely)."""
    return rng.random((count, n)) < rng.uniform(0.02, 0.9)


@pytest.mark.parametrize("tasks", [1, 3])
def test_superset_and_subset_queries_agree_with_a_plain_scan(tasks):
    """300 random families (1-200 states, so 1-4 words; 0-300 stored sets, queries that include
    stored sets and duplicates): ``superset_mask`` flags a query exactly when some stored set lies
    inside it (a different one with ``proper``), ``subset_mask`` exactly when it lies inside one.
    The parallel split is forced on for ``tasks=3`` (its threshold ``min_parallel`` set to 1)."""
    rng = np.random.default_rng(4360)
    seen = set()
    for _ in range(300):
        n = int(rng.integers(1, 200))
        S = random_family(rng, int(rng.integers(0, 300)), n)
        Q = np.concatenate([random_family(rng, int(rng.integers(0, 120)), n), S[:int(rng.integers(0, 20))]])
        inside = (S[None, :, :] <= Q[:, None, :]).all(axis=2)      # [q, s]: stored s inside query q
        holds = (S[None, :, :] >= Q[:, None, :]).all(axis=2)       # [q, s]: query q inside stored s
        same = (S[None, :, :] == Q[:, None, :]).all(axis=2)
        Sb, Qb = pack(S), pack(Q)
        for proper in (False, True):
            want_sup = (inside & ~same).any(axis=1) if proper else inside.any(axis=1)
            want_sub = (holds & ~same).any(axis=1) if proper else holds.any(axis=1)
            got_sup = _trie.superset_mask(Sb, Qb, proper=proper, tasks=tasks, min_parallel=1)
            got_sub = _trie.subset_mask(Sb, Qb, n, proper=proper, tasks=tasks, min_parallel=1)
            assert got_sup.tolist() == want_sup.tolist()
            assert got_sub.tolist() == want_sub.tolist()
            seen.update((bool(x), "sup") for x in want_sup)
            seen.update((bool(x), "sub") for x in want_sub)
    assert seen == {(True, "sup"), (False, "sup"), (True, "sub"), (False, "sub")}


def test_first_superset_pair_is_a_real_pair_and_none_only_when_none_exists():
    """``first_superset_pair`` (the meet test): a returned pair is a stored set inside a query set;
    (-1, -1) exactly when no such pair exists (plain scan), on 200 random families."""
    rng = np.random.default_rng(4361)
    outcomes = set()
    for _ in range(200):
        n = int(rng.integers(2, 150))
        S = random_family(rng, int(rng.integers(1, 100)), n)
        Q = random_family(rng, int(rng.integers(1, 100)), n)
        s, q = _trie.first_superset_pair(pack(S), pack(Q))
        exists = bool((S[None, :, :] <= Q[:, None, :]).all(axis=2).any())
        assert (s >= 0) == exists
        if s >= 0:
            assert (S[s] <= Q[q]).all()
        outcomes.add(exists)
    assert outcomes == {True, False}


def test_bad_shapes_are_refused():
    with pytest.raises(ValueError, match="same width"):
        _trie.superset_mask(np.zeros((2, 1), dtype=np.uint64), np.zeros((2, 2), dtype=np.uint64))


@pytest.mark.parametrize("forward, backward, visited, trie_meet", [
    (True, True, True, False), (True, False, True, False), (False, True, True, False),
    (True, True, False, False), (True, True, True, True)])
def test_dominance_keeps_every_shortest_length(forward, backward, visited, trie_meet):
    """With either direction's dominance pruning, against the level only or every earlier level, and
    with the trie's meet test: on 50 small random automata (5-16 states, 2-4 letters, some not
    synchronizing) and Cerny C_5..C_8, the search (beam off, so it must find the word itself) gives
    exactly the brute-force length, a word that synchronizes, or no word when none exists."""
    options = ExactSearchOptions(use_beam=False, forward_dominance=forward, backward_dominance=backward,
                                 forward_visited=visited, trie_meet=trie_meet)
    rng = np.random.default_rng(4362)
    tables = [generators.random_table(int(rng.integers(5, 17)), int(rng.integers(2, 5)), rng) for _ in range(50)]
    tables += [generators.cerny_table(n) for n in range(5, 9)]
    nones = 0
    for table in tables:
        aut = SyncAutomaton.from_table(table)
        r = shortest_synchronizing_word(aut, time_budget=None, options=options)
        want = brute(table)
        assert r.length == want and r.exact
        if want is None:
            nones += 1
        else:
            assert is_synchronizing_word(aut, r.word)
    assert 0 < nones < len(tables)


def test_dominance_prunes_and_keeps_the_answer_on_a_larger_automaton():
    """On a random binary automaton of 60 states the pruning keeps fewer subsets than the plain
    search (counts of subsets, machine-independent) and the same shortest length, with a word."""
    aut = SyncAutomaton.from_table(generators.random_table(60, 2, 4363))
    got = {}
    for on in (False, True):
        options = ExactSearchOptions(use_beam=False, forward_dominance=on, backward_dominance=on)
        got[on] = shortest_synchronizing_word(aut, time_budget=None, options=options)
    assert got[True].length == got[False].length and got[True].exact and got[False].exact
    assert is_synchronizing_word(aut, got[True].word)
    assert got[True].states_explored < got[False].states_explored


def assert_shortest_on_small_automata(options, cerny=range(5, 8)) -> set:
    """On 60 small random automata (seed 4364) and the Cerny automata ``C_n``, ``n`` in ``cerny``:
    the brute-force length, exact, with a word that synchronizes. Returns the methods that answered."""
    rng = np.random.default_rng(4364)
    tables = [generators.random_table(int(rng.integers(5, 17)), int(rng.integers(2, 5)), rng) for _ in range(60)]
    tables += [generators.cerny_table(n) for n in cerny]
    methods = set()
    for table in tables:
        aut = SyncAutomaton.from_table(table)
        r = shortest_synchronizing_word(aut, time_budget=None, options=options)
        want = brute(table)
        assert r.length == want and r.exact
        if want is not None:
            assert is_synchronizing_word(aut, r.word)
        methods.add(r.method)
    return methods


@pytest.mark.parametrize("deepen", [True, False])
@pytest.mark.parametrize("switch_rows", [4, 40])
def test_inverse_depth_first_phase_keeps_every_shortest_length(switch_rows, deepen):
    """The depth-first phase from the backward side (entered early: once a breadth-first level
    would exceed ``switch_rows`` sets), its chunks (3 sets) and the trie's meet test, one length at
    a time (``deepen``) or in one descent: on 60 small random automata and Cerny C_5..C_8, with the
    greedy word as the bound (beam off, so the search has words to find below it), the answer is
    the brute-force length, exact, with a word that synchronizes; some answers come from the
    inverse phase (seen through ``ExactSearchOptions.observe``)."""
    inverse_found = []

    def observe(event, value):
        if event == "inverse-dfs":
            inverse_found.append(value == 1)
    options = ExactSearchOptions(use_beam=False, dfs_switch_rows=switch_rows, dfs_chunk=3, deepen=deepen,
                                 observe=observe)
    methods = assert_shortest_on_small_automata(options, cerny=range(5, 9))
    assert "bidirectional-bfs+dfs" in methods and any(inverse_found)


def test_the_deepening_phase_proves_each_length_it_finishes():
    """Stopped by node budgets (every budget from 1 to 3,000 sets in steps of 29) inside the
    deepening phase (entered once a level would exceed 30 sets, chunks of 3 sets, beam off), the
    lower bound is one more than the last length the phase reported ruled out (``deepened``), and
    never above the brute-force length; an exact answer has that length. On 8 random 4-letter
    automata of 20-29 states (where the phase runs from the backward side and stops in it)."""
    rng = np.random.default_rng(4375)
    checked = 0
    for _ in range(8):
        table = generators.random_table(int(rng.integers(20, 30)), 4, rng)
        aut = SyncAutomaton.from_table(table)
        want = brute(table)
        for budget in range(1, 3000, 29):
            events = []
            options = ExactSearchOptions(use_beam=False, dfs_switch_rows=30, dfs_chunk=3,
                                         observe=lambda e, v: events.append((e, v)))
            r = shortest_synchronizing_word(aut, time_budget=None, node_budget=budget, options=options)
            ruled_out = [v for e, v in events if e == "deepened"]
            if r.exact:
                assert r.length == want
                continue
            assert r.lower_bound <= want
            if ruled_out and not any(e == "inverse-dfs" and v == 1 for e, v in events):
                assert r.lower_bound == max(ruled_out) + 1
                checked += 1
    assert checked > 100


@pytest.mark.parametrize("max_small", [0, 3, 256])
def test_the_size_split_answers_as_the_walk(max_small):
    """``superset_mask`` with a :class:`~kruskal_markov.sync._trie.SizeSplit` of the stored rows
    (queries smaller than every stored row answered at once, those below the cut scanned against
    the few small stored rows, the rest walked) flags exactly the queries containing a stored set,
    on 200 random families (1-200 states, densities and sizes varied, duplicates included)."""
    rng = np.random.default_rng(4374)
    for _ in range(200):
        n = int(rng.integers(1, 200))
        S = random_family(rng, int(rng.integers(1, 300)), n)
        Q = np.concatenate([random_family(rng, int(rng.integers(0, 120)), n), S[:int(rng.integers(0, 20))]])
        want = (S[None, :, :] <= Q[:, None, :]).all(axis=2).any(axis=1)
        Sb, Qb = pack(S), pack(Q)
        Ss = Sb[_trie.lex_order(Sb)]
        split = _trie.SizeSplit(Ss, max_small=max_small)
        assert split.small.shape[0] <= max_small
        got = _trie.superset_mask(Ss, Qb, sorted_stored=True, split=split, tasks=1)
        assert got.tolist() == want.tolist()
