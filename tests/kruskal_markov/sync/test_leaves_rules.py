"""The inverse depth-first phase's unstored deepest level (``sync/_leaves``) by its documented
rules: preimages of a set-valued automaton's sets (the states whose every successor lies in the
set), the preimages counted up to the end of the slice that hit, and a slice of over 8,192
preimages (where the subset trie may split its queries) answered like a small one."""
from __future__ import annotations

import numpy as np

from kruskal_markov import generators
from kruskal_markov.sync import SyncAutomaton, _leaves, _trie, support_automaton
from tests.kruskal_markov.sync.test_trie import pack, random_family


def _preimages(aut, rows):
    """Plain Python: ``pre[i][a]`` = the states ``p`` whose successors under ``a`` all lie in row ``i``."""
    succ = [[set(aut.indices[aut.indptr[a, p]:aut.indptr[a, p + 1]].tolist()) for p in range(aut.n)]
            for a in range(aut.k)]
    sets = [set(aut.states_of(r)) for r in rows]
    return [[{p for p in range(aut.n) if succ[a][p] <= s} for a in range(aut.k)] for s in sets]


def _first_hit(aut, rows, stored, pre):
    inside = [[any(t <= p for t in stored) for p in ps] for ps in pre]
    return next(((i, a) for i in range(len(rows)) for a in range(aut.k) if inside[i][a]), None)


def test_preimages_of_a_set_valued_automaton_and_the_first_hit():
    """A set-valued tray-like support automaton (40 states, 3 letters; byte tables are for
    deterministic automata only): every preimage ``preimage`` gives and the first (row, letter)
    ``first_leaf_hit`` names are the plain ones."""
    rng = np.random.default_rng(4391)
    aut = support_automaton(generators.set_valued_tray_model(40, 3, 8, 0.05, rng))
    assert not aut.deterministic
    rows = pack(random_family(rng, 30, aut.n))
    pre = _preimages(aut, rows)
    for i, r in enumerate(rows):
        for a in range(aut.k):
            assert set(aut.states_of(_leaves.preimage(aut, r, a))) == pre[i][a]
    stored_sets = random_family(rng, 60, aut.n)
    stored = pack(stored_sets)
    fs = stored[_trie.lex_order(stored)]
    want = _first_hit(aut, rows, [set(np.flatnonzero(s).tolist()) for s in stored_sets], pre)
    assert want is not None
    assert _leaves.first_leaf_hit(aut, rows, fs, _trie.SizeSplit(fs), slice_rows=7) == want


def test_the_preimages_are_counted_to_the_end_of_the_slice_that_hit():
    """Slices of ``max(1, slice_rows // k)`` rows, each generated whole before it is tested: a hit at
    row ``i`` has counted ``k`` preimages for every row up to the end of its slice."""
    rng = np.random.default_rng(4392)
    checked = 0
    for _ in range(30):
        n, k = int(rng.integers(5, 40)), int(rng.integers(2, 4))
        aut = SyncAutomaton.from_table(generators.random_table(n, k, rng))
        rows = pack(random_family(rng, int(rng.integers(2, 30)), n))
        stored = pack(random_family(rng, int(rng.integers(1, 20)), n))
        fs = stored[_trie.lex_order(stored)]
        for slice_rows in (1, k, 3 * k + 1):
            used = [0]
            hit = _leaves.first_leaf_hit(aut, rows, fs, _trie.SizeSplit(fs), slice_rows=slice_rows, used=used)
            if hit is None:
                continue
            step = max(1, slice_rows // k)
            assert used[0] == k * min(len(rows), (hit[0] // step + 1) * step)
            checked += 1
    assert checked > 20


def test_a_slice_of_over_8192_preimages_is_answered_like_small_ones():
    """5,000 rows of a 2-letter automaton: 10,000 preimages in one slice, generated whole, queried
    against three stored sets of about three states (so that the size filter leaves over 8,192 of
    them to the trie walk, which then may split its queries); the first hit is the one slices of
    4,096 preimages (under the split's threshold) find."""
    rng = np.random.default_rng(4394)
    aut = SyncAutomaton.from_table(generators.random_table(60, 2, rng))
    rows = pack(random_family(rng, 5000, 60))
    stored = pack(rng.random((3, 60)) < 0.05)
    fs = stored[_trie.lex_order(stored)]
    want = _leaves.first_leaf_hit(aut, rows, fs, _trie.SizeSplit(fs), tasks=1, slice_rows=4096)
    used = [0]
    assert _leaves.first_leaf_hit(aut, rows, fs, _trie.SizeSplit(fs), tasks=1, used=used) == want
    assert used[0] == 10_000
