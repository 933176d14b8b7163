"""The one tilt engine (transition_builder.tilting): its status check, chunker and context."""
from __future__ import annotations

import numpy as np
import pytest

from transition_builder.executors import SerialExecutor
from transition_builder.status import ESCAPED, INVALID, OK
from transition_builder.tilting import TiltEngine, checked_tilt, chunk_bounds, trial_chunk_size


class _Sim:
    """A stand-in simulator returning fixed rest poses and codes."""

    def __init__(self, rest, status):
        self.rest, self.status = rest, status

    def tilt(self, poses, action):
        return self.rest, self.status


def test_checked_tilt_never_returns_a_fault_as_a_pose():
    rest = np.array([[1.0, 2.0, 0.1], [np.nan, 2.0, 0.1], [5.0, 5.0, 0.0]])
    out, status = checked_tilt(_Sim(rest, np.array([OK, OK, ESCAPED])), np.zeros((3, 3)), "E")
    assert status.tolist() == [OK, INVALID, ESCAPED] and status.dtype == np.int8
    assert out[0].tolist() == [1.0, 2.0, 0.1] and np.isnan(out[1:]).all()


def test_checked_tilt_rejects_unknown_status_codes():
    with pytest.raises(RuntimeError, match="unknown status codes"):
        checked_tilt(_Sim(np.zeros((1, 3)), np.array([99])), np.zeros((1, 3)), "E")


def test_chunks_cover_the_work_in_order_and_depend_on_it_alone():
    assert chunk_bounds(100, 48) == [(0, 48), (48, 96), (96, 100)]
    assert chunk_bounds(0, 48) == []
    assert [trial_chunk_size(m) for m in (10, 2000, 100000)] == [16, 32, 256]


def test_engine_borrows_a_given_executor_and_counts_progress():
    ex = SerialExecutor()
    with TiltEngine(ex, progress=False) as eng:
        assert eng.executor is ex and eng.workers == 1
        assert [r for _, r in eng.map(abs, [(-3,), (4,)])] == [3, 4]
    with pytest.raises(ValueError, match="executor"):
        TiltEngine(object())
