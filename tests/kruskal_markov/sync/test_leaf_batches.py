"""The deepest level's batched test (sync/_leaves.first_leaf_hit_batched), the row-moving trie walk
(sync/_rowtrie) and the per-block count filter (sync/_countfilter): the same answers as a scan and,
in the search, as brute force."""
from __future__ import annotations

import numpy as np
import pytest

from kruskal_markov.sync import ExactSearchOptions, _countfilter, _leaves, _rowtrie, _trie
from tests.kruskal_markov.sync.test_dfs_speedups import random_leaf_case
from tests.kruskal_markov.sync.test_trie import assert_shortest_on_small_automata, pack, random_family


def _scan(stored, query):
    return np.array([bool((~np.any(stored & ~q, axis=1)).any()) for q in query], dtype=bool)


def test_row_walk_answers_as_a_scan():
    """On random families of 1 to 150 states (one to three words) the row-moving walk answers as a
    plain scan, on one thread and split in slices, and leaves the queries unchanged."""
    rng = np.random.default_rng(4390)
    for _ in range(30):
        n = int(rng.integers(1, 150))
        S, Q = pack(random_family(rng, int(rng.integers(1, 300)), n)), pack(random_family(rng, 400, n))
        Q = np.concatenate([Q, S[:5]])
        Ss = S[_trie.lex_order(S)]
        keep = Q.copy()
        want = _scan(S, Q)
        for tasks, min_par in ((1, 4096), (4, 8)):
            got = _rowtrie.superset_mask_rows(Ss, Q, _trie.SizeSplit(Ss, max_small=int(rng.integers(0, 20))),
                                              tasks=tasks, min_parallel=min_par)
            assert (got == want).all()
        assert (Q == keep).all()
    with pytest.raises(ValueError, match="same width"):
        _rowtrie.superset_mask_rows(Ss, np.zeros((1, Ss.shape[1] + 1), dtype=np.uint64), _trie.SizeSplit(Ss))


def test_count_filter_never_drops_a_query_holding_a_stored_set_and_drops_some():
    """Whatever the blocks, every query containing a stored set is kept; queries smaller than every
    stored set are dropped; with several blocks some queries of enough states are dropped too."""
    rng = np.random.default_rng(4391)
    dropped_by_blocks = 0
    for _ in range(30):
        n = int(rng.integers(1, 200))
        S, Q = pack(random_family(rng, int(rng.integers(1, 200)), n)), pack(random_family(rng, 500, n))
        want = _scan(S, Q)
        sizes = _trie._row_sizes(Q)
        for blocks in (1, 3, 6):
            cf = _countfilter.CountFilter(S, n, blocks)
            keep = cf.keep(Q)
            assert not (want & ~keep).any()
            assert not keep[sizes < _trie._row_sizes(S).min()].any()
            if blocks > 1:
                dropped_by_blocks += int((~keep & (sizes >= cf.min_size)).sum())
    assert dropped_by_blocks > 0
    empty = _countfilter.CountFilter(np.zeros((0, 1), dtype=np.uint64), 5)
    assert not empty.keep(np.ones((3, 1), dtype=np.uint64)).any()
    with pytest.raises(ValueError):
        _countfilter.CountFilter(np.zeros((2, 1), dtype=np.uint64), 65)
    with pytest.raises(ValueError):
        _countfilter.CountFilter(np.zeros((2, 1), dtype=np.uint64), 5).keep(np.zeros((2, 2), dtype=np.uint64))


def test_batched_leaves_find_a_preimage_inside_the_trie_exactly_when_one_exists():
    """``first_leaf_hit_batched`` returns a (row, letter) whose preimage contains a stored set
    exactly when one exists, whatever the slice and batch sizes and with or without the count
    filter; every preimage is counted when none does; a budget stops it."""
    rng = np.random.default_rng(4392)
    for _ in range(40):
        aut, rows, fs, _, inside = random_leaf_case(rng)
        n, k = aut.n, aut.k
        exists = any(any(x) for x in inside)
        for slice_rows, batch, blocks in ((1, 1, None), (7, 5, 3), (1 << 20, 1 << 19, 6), (3, 1 << 19, 1)):
            used = [0]
            cf = None if blocks is None else _countfilter.CountFilter(fs, n, blocks)
            got = _leaves.first_leaf_hit_batched(aut, rows, fs, _trie.SizeSplit(fs), batch, cf,
                                                 slice_rows=slice_rows, used=used)
            if not exists:
                assert got is None and used[0] == k * len(rows)
            else:
                assert got is not None and inside[got[0]][got[1]]
    assert _leaves.first_leaf_hit_batched(aut, rows, fs, _trie.SizeSplit(fs), 4, over_budget=lambda: True) == \
        "budget"


@pytest.mark.parametrize("count_blocks", [None, 4])
@pytest.mark.parametrize("deepen", [True, False])
def test_inverse_phase_with_batched_leaves_keeps_every_shortest_length(deepen, count_blocks):
    """The inverse depth-first phase entered early (levels over 40 sets, chunks of 3), relabelled,
    its deepest level in batches of 5 rows with and without the count filter: on 60 small random
    automata and Cerny C_5..C_7 the brute-force length, exact, with a word that synchronizes;
    some answers come from the inverse phase."""
    found = []
    options = ExactSearchOptions(use_beam=False, dfs_switch_rows=40, dfs_chunk=3, deepen=deepen, relabel_rows=1,
                                 leaf_batch=5, leaf_batch_rows=1, count_blocks=count_blocks,
                                 observe=lambda e, v: found.append(v) if e == "inverse-dfs" else None)
    assert_shortest_on_small_automata(options)
    assert any(v == 1 for v in found)


def test_options_refuse_bad_batches():
    for bad in ({"leaf_batch": 0}, {"count_blocks": 0}, {"leaf_batch": 2.5}, {"leaf_batch_rows": -1}):
        with pytest.raises(ValueError):
            ExactSearchOptions(**bad)
