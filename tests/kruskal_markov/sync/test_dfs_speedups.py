"""The inverse depth-first phase's relabelling by frequency (``sync/_relabel``) and its unstored
deepest level (``sync/_leaves``): the same answers as brute force, with words that synchronize, and
the relabelling a renaming of the states."""
from __future__ import annotations

import numpy as np
import pytest

from kruskal_markov import generators
from kruskal_markov.sync import (
    ExactSearchOptions,
    SyncAutomaton,
    _forked,
    _leaves,
    _relabel,
    _trie,
    is_synchronizing_word,
    shortest_synchronizing_word,
)
from tests.kruskal_markov.sync.test_exact import brute
from tests.kruskal_markov.sync.test_trie import assert_shortest_on_small_automata, pack, random_family


def test_frequency_order_puts_the_most_held_states_on_the_first_trie_bits():
    """The state most rows hold gets bit 63 of word 0 (the trie's first branch), the next one bit
    62, ...; labels are a permutation of the states, also past one word (130 states)."""
    rng = np.random.default_rng(4380)
    n = 130
    M = rng.random((400, n)) < np.linspace(0.05, 0.6, n)[rng.permutation(n)]
    perm = _relabel.frequency_order(pack(M), n)
    assert sorted(perm.tolist()) == list(range(n))
    counts = M.sum(axis=0)
    first_bits = [63 - j for j in range(64)] + [127 - j for j in range(64)] + [129, 128]
    by_count = [first_bits.index(int(p)) for p in perm]      # each state's place in the trie's order
    ranked = np.argsort(by_count)
    assert all(counts[ranked[i]] >= counts[ranked[i + 1]] for i in range(n - 1))


def test_permuted_rows_and_relabelled_automata_are_renamings():
    """Rows permuted and back are the rows; a relabelled trie is the permuted rows sorted; the
    relabelled automaton maps renamed sets to renamed images under every word tried; superset
    answers do not change."""
    rng = np.random.default_rng(4381)
    for _ in range(20):
        n = int(rng.integers(2, 150))
        S, Q = random_family(rng, 200, n), random_family(rng, 100, n)
        Sb, Qb = pack(S), pack(Q)
        perm = _relabel.frequency_order(Sb, n)
        Sp = _relabel.permute_rows(Sb, perm)
        assert (_relabel.permute_rows(Sp, np.argsort(perm)) == Sb).all()
        sorted_p = _relabel.relabel_sorted(Sb[_trie.lex_order(Sb)].copy(), perm)
        assert (sorted_p == Sp[_trie.lex_order(Sp)]).all()
        want = _trie.superset_mask(Sb, Qb, tasks=1)
        got = _trie.superset_mask(sorted_p, _relabel.permute_rows(Qb, perm), sorted_stored=True, tasks=1)
        assert (got == want).all()
        aut = SyncAutomaton.from_table(generators.random_table(n, 3, rng))
        rel = _relabel.relabelled(aut, perm)
        for _ in range(5):
            states = rng.choice(n, int(rng.integers(1, n + 1)), replace=False)
            word = rng.integers(0, 3, int(rng.integers(0, 6))).tolist()
            assert sorted(perm[aut.image(states, word)]) == sorted(rel.image(perm[states].tolist(), word))


def test_relabelling_refuses_what_is_not_a_renaming():
    aut = SyncAutomaton.from_table([[1, 2, 0], [0, 0, 2]])
    with pytest.raises(ValueError, match="permutation"):
        _relabel.relabelled(aut, [0, 0, 1])
    with pytest.raises(ValueError, match="bitset"):
        _relabel.frequency_order(np.zeros((2, 1), dtype=np.uint64), 65)
    with pytest.raises(ValueError, match="relabel_rows"):
        ExactSearchOptions(relabel_rows=0)


def random_leaf_case(rng):
    """A random automaton (3-69 states, 1-4 letters), bitset rows, a lexicographically sorted
    family of stored sets, the preimages ``pre[i][a]`` of row ``i`` under letter ``a`` as bitsets,
    and by brute force ``inside[i][a]``: whether ``pre[i][a]`` contains a stored set (the leaf
    tests' instance and expected answer)."""
    n = int(rng.integers(3, 70))
    k = int(rng.integers(1, 5))
    aut = SyncAutomaton.from_table(generators.random_table(n, k, rng))
    rows = pack(random_family(rng, int(rng.integers(1, 40)), n))
    stored = pack(random_family(rng, int(rng.integers(1, 60)), n))
    fs = stored[_trie.lex_order(stored)]
    pre = [[aut.bits(sorted({q for q in range(n) if aut.delta[a, q] in set(aut.states_of(r))}))
            for a in range(k)] for r in rows]
    inside = [[bool((~np.any(fs & ~p, axis=1)).any()) for p in ps] for ps in pre]
    return aut, rows, fs, pre, inside


def test_the_unstored_deepest_level_finds_the_first_preimage_inside_a_trie():
    """``first_leaf_hit`` names a (row, letter) whose preimage contains a stored set exactly when
    one exists, the first in row-major order, whatever the slice size; the preimages are counted."""
    rng = np.random.default_rng(4382)
    for _ in range(40):
        aut, rows, fs, pre, inside = random_leaf_case(rng)
        k = aut.k
        want = next(((i, a) for i in range(len(rows)) for a in range(k) if inside[i][a]), None)
        for slice_rows in (1, 7, 1 << 20):
            used = [0]
            got = _leaves.first_leaf_hit(aut, rows, fs, _trie.SizeSplit(fs), slice_rows=slice_rows, used=used)
            assert got == want
            if got is None:
                assert used[0] == k * len(rows)
            else:
                assert (_leaves.preimage(aut, rows[got[0]], got[1]) == pre[got[0]][got[1]]).all()
    assert _leaves.first_leaf_hit(aut, rows, fs, _trie.SizeSplit(fs), over_budget=lambda: True) == "budget"


@pytest.mark.parametrize("leaf_images", [True, False])
@pytest.mark.parametrize("deepen", [True, False])
def test_inverse_phase_relabelled_with_unstored_leaves_keeps_every_shortest_length(leaf_images, deepen):
    """The inverse depth-first phase entered early (levels over 40 sets, chunks of 3), relabelled
    whatever the forward level's size (``relabel_rows=1``), with and without the unstored deepest
    level: on 60 small random automata and Cerny C_5..C_7 the answer is the brute-force length,
    exact, with a word that synchronizes; some come from the inverse phase."""
    found = []
    options = ExactSearchOptions(use_beam=False, dfs_switch_rows=40, dfs_chunk=3, deepen=deepen, relabel_rows=1,
                                 leaf_images=leaf_images,
                                 observe=lambda e, v: found.append(v) if e == "inverse-dfs" else None)
    assert_shortest_on_small_automata(options)
    assert any(v == 1 for v in found)


def test_bounds_under_node_budgets_with_the_new_phase_never_pass_brute_force():
    """Stopped by node budgets (1 to 3,000 sets in steps of 37) in the relabelled phase with
    unstored leaves: the lower bound never exceeds the brute-force length, an exact answer has it,
    and the same budget gives the same answer twice (budgets in sets, not seconds)."""
    rng = np.random.default_rng(4384)
    for _ in range(6):
        table = generators.random_table(int(rng.integers(20, 30)), 4, rng)
        aut = SyncAutomaton.from_table(table)
        want = brute(table)
        options = ExactSearchOptions(use_beam=False, dfs_switch_rows=30, dfs_chunk=3, relabel_rows=1)
        for budget in range(1, 3000, 37):
            r = shortest_synchronizing_word(aut, time_budget=None, node_budget=budget, options=options)
            assert r.lower_bound <= want
            if r.exact:
                assert r.length == want and is_synchronizing_word(aut, r.word)
            again = shortest_synchronizing_word(aut, time_budget=None, node_budget=budget, options=options)
            assert (again.length, again.lower_bound, again.states_explored) == (r.length, r.lower_bound,
                                                                               r.states_explored)


def test_inverse_phase_on_two_processes_keeps_every_shortest_length(monkeypatch):
    """The deepening phase's chunks dealt to two processes (``parallel=True``, ``fork_rows=1``, no node budget, so no fast path:
    forked whatever the level's size), relabelled, leaves unstored: on the 60 small random automata
    and Cerny C_5..C_7 of the test above, the brute-force length, exact, with a synchronizing word."""
    splits = []
    split_two = _forked.split_two
    monkeypatch.setattr(_forked, "split_two", lambda task: splits.append(1) or split_two(task))
    options = ExactSearchOptions(use_beam=False, dfs_switch_rows=40, dfs_chunk=3, relabel_rows=1, parallel=True, fast_nodes=None,
                                 fork_rows=1)
    assert_shortest_on_small_automata(options)
    assert len(splits) > 10         # the phase did run on two processes


@pytest.mark.parametrize("hit_part", [None, 0, 1])
def test_split_two_runs_both_parts_and_stops_at_the_first_hit(hit_part):
    """Both parts run (the child's answer comes back through the pipe); a hit in the child stops
    the parent between its steps; a hit in the parent ends the child."""
    import time

    def task(part, stop):
        steps = 5000 if hit_part is not None and part != hit_part else 200    # the other part outlasts the hit
        for step in range(steps):
            if stop():
                return "stopped", step
            if part == hit_part and step == (3 if part == 1 else 150):
                return "hit", (part, step)
            time.sleep(0.002)
        return None, (part, 200)

    mine, child = _forked.split_two(task)
    if hit_part is None:
        assert mine == (None, (0, 200)) and child == (None, (1, 200))
    elif hit_part == 1:
        assert child == ("hit", (1, 3)) and mine[0] == "stopped"
    else:
        assert mine == ("hit", (0, 150)) and child == ("killed", None)


def test_split_two_says_when_the_child_failed():
    def task(part, stop):
        if part == 1:
            raise ValueError("boom")
        return None, 0

    with pytest.raises(RuntimeError, match="second process failed"):
        _forked.split_two(task)
