"""SyncAutomaton's byte step tables (``step_table``): built exactly when they fit the documented
8 MB, and each row the image or preimage of its byte's states, judged by plain Python."""
from __future__ import annotations

import numpy as np
import pytest

from kruskal_markov.sync import SyncAutomaton

MB = 2 ** 20


@pytest.mark.parametrize("n, k, fits", [(1024, 2, True), (1024, 3, False), (1040, 2, False)])
def test_byte_step_tables_are_built_only_within_8_mb(n, k, fits):
    """1,024 states: 128 bytes x 256 values x 16 words of 8 bytes = 4 MB per letter, so two letters
    are exactly 8 MB (built) and three 12 MB (not); 1,040 states with two letters: 8.6 MB (not)."""
    rng = np.random.default_rng(4371)
    table = rng.integers(0, n, size=(k, n))
    aut = SyncAutomaton.from_table(table)
    size = k * ((n + 7) // 8) * 256 * aut.n_words * 8
    assert (size <= 8 * MB) == fits
    for forward in (True, False):
        tab = aut.step_table(forward)
        assert (tab is not aut.sup) == fits
        if not fits:
            continue
        assert tab.nbytes == size
        for a, j, v in ((0, 0, 1), (k - 1, 5, 0b10110001), (1, (n - 1) // 8, 255), (0, 77, 0b01000010)):
            states = {8 * j + b for b in range(8) if v >> b & 1}
            want = ({int(table[a, q]) for q in states} if forward
                    else {q for q in range(n) if int(table[a, q]) in states})
            assert set(aut.states_of(tab[a, 256 * j + v])) == want
