"""The inverse depth-first phase's relabelling (``sync/_relabel``) by its documented rules, value by
value: the order of the labels (most held first, ties by state index, in the trie's bit order), the
bitset width it accepts, a relabelled automaton keeping its letters, and its refusals' messages."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from kruskal_markov.sync import SyncAutomaton, _relabel
from tests.kruskal_markov.sync.test_trie import pack


def _trie_bits(n):
    """The trie's bit order: bit 63 of word 0 first, down to bit 0, then bit 63 of word 1, ..."""
    return [b for w in range((n + 63) // 64) for b in range(64 * w + 63, 64 * w - 1, -1) if b < n]


def test_labels_go_by_count_then_by_state_index_in_the_trie_s_bit_order():
    """100 states (two words) held by 0, 1 or 2 of the rows each, so most counts are tied: the
    labels are the trie's bits in the order of (count, highest first; then state index)."""
    rng = np.random.default_rng(4390)
    n = 100
    held = rng.integers(0, 3, n)
    M = np.zeros((2, n), dtype=bool)
    M[0, held >= 1] = True
    M[1, held >= 2] = True
    perm = _relabel.frequency_order(pack(M), n)
    ranked = sorted(range(n), key=lambda q: (-int(held[q]), q))
    want = np.empty(n, dtype=np.int64)
    want[ranked] = _trie_bits(n)
    assert perm.dtype == np.int64 and perm.tolist() == want.tolist()


def test_rows_must_hold_at_least_n_bits():
    """One 64-bit word holds 64 states (accepted); 65 states need two words."""
    rows = np.full((1, 1), np.uint64(2 ** 64 - 1))
    assert _relabel.frequency_order(rows, 64).tolist() == list(range(63, -1, -1))     # all tied: by index
    with pytest.raises(ValueError, match=r"^rows must be a 2-d bitset array of at least n bits$"):
        _relabel.frequency_order(rows, 65)


def test_a_relabelled_automaton_keeps_its_letters_and_refuses_by_name():
    aut = SyncAutomaton.from_table([[1, 2, 0], [0, 0, 2]], actions=("N", "E"))
    rel = _relabel.relabelled(aut, [2, 0, 1])
    assert rel.actions == ("N", "E")
    assert rel.image([2], [0]) == [0]           # state 0 -> 1 under N: renamed 2 -> 0
    with pytest.raises(ValueError, match=r"^perm must be a permutation of the states$"):
        _relabel.relabelled(aut, [0, 0, 1])
    with pytest.raises(ValueError, match=r"^only deterministic automata are relabelled$"):
        _relabel.relabelled(dataclasses.replace(aut, deterministic=False), [0, 1, 2])
