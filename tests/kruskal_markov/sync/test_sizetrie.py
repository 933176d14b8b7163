"""The size-bucketed subset tries (sync/_sizetrie) answer exactly as a plain scan."""
import numpy as np
import pytest

from kruskal_markov.sync import _sizetrie, _trie


def _random_rows(rng, m, n, lo, hi):
    W = (n + 63) // 64
    rows = np.zeros((m, W), dtype=np.uint64)
    for i in range(m):
        for q in rng.choice(n, size=int(rng.integers(lo, hi + 1)), replace=False):
            rows[i, q >> 6] |= np.uint64(1) << np.uint64(q & 63)
    return rows


def _scan(stored, query):
    return np.array([bool(np.any(~np.any(stored & ~q, axis=1))) for q in query])


@pytest.mark.parametrize("n,first,growth", [(70, 4, 1.0), (130, 16, 4.0), (40, 1, 0.5), (200, 1 << 16, 4.0)])
def test_answers_equal_a_scan(n, first, growth):
    rng = np.random.default_rng(n)
    stored = _random_rows(rng, 400, n, 2, n // 3)
    query = np.concatenate([_random_rows(rng, 300, n, 1, n - 1), stored[:20]])
    sb = _sizetrie.SizeBuckets.build(stored, first=first, growth=growth)
    want = _scan(stored, query)
    assert want.any() and not want.all()
    assert np.array_equal(sb.superset_mask(query), want)
    assert np.array_equal(sb.superset_mask(query, tasks=4), want)
    assert np.array_equal(_trie.superset_mask(stored, query), want)


def test_buckets_ordered_and_grow():
    rng = np.random.default_rng(1)
    stored = _random_rows(rng, 2000, 100, 3, 60)
    sb = _sizetrie.SizeBuckets.build(stored, first=50, growth=2.0)
    sizes = _trie._row_sizes(sb.rows)
    assert np.all(np.diff(sb.starts) >= 0) and sb.starts[-1] == stored.shape[0]
    for b in range(sb.edges.size - 1):
        part = sb.rows[sb.starts[b]:sb.starts[b + 1]]
        assert np.all((sizes[sb.starts[b]:sb.starts[b + 1]] >= sb.edges[b]) &
                      (sizes[sb.starts[b]:sb.starts[b + 1]] < sb.edges[b + 1]))
        assert np.array_equal(part, part[_trie.lex_order(part)])
    counts = np.diff(sb.starts)
    assert counts[0] >= 50 and sb.edges.size >= 3


def test_bad_input():
    rows = np.array([[0b11], [0b1]], dtype=np.uint64)
    with pytest.raises(ValueError):
        _sizetrie.SizeBuckets(rows, np.array([1, 2, 3]))    # not ordered by bucket: sizes 2 then 1
    with pytest.raises(ValueError):
        _sizetrie.SizeBuckets(rows[::-1].copy(), np.array([2, 3]))   # a size below the first edge
    sb = _sizetrie.SizeBuckets.build(rows)
    with pytest.raises(ValueError):
        sb.superset_mask(np.zeros((2, 2), dtype=np.uint64))
    assert sb.superset_mask(np.zeros((0, 1), dtype=np.uint64)).shape == (0,)
    empty = _sizetrie.SizeBuckets.build(np.zeros((0, 1), dtype=np.uint64))
    assert not empty.superset_mask(rows).any()
