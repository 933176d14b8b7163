"""The two processes of the deepening phase (``sync/_forked.split_two``) by their documented rules:
the child's answer comes back whole however long it is, a child that failed is said so in one
message even while the parent is asking it for a hit, and a part that fails in the parent keeps
its own error (the child is ended, not waited for)."""
from __future__ import annotations

import time

import pytest

from kruskal_markov.sync import _forked

FAILED = r"^the depth-first phase's second process failed$"


def test_a_long_answer_from_the_child_comes_back_whole():
    """300,000 bytes (several reads of the pipe) from the child, byte for byte."""
    payload = bytes(range(256)) * 1200

    def task(part, stop):
        return ("done", payload) if part == 1 else (None, 0)

    mine, child = _forked.split_two(task)
    assert mine == (None, 0) and child == ("done", payload)


def test_a_child_that_failed_is_said_so_while_the_parent_asks_for_its_hit(tmp_path):
    """The parent keeps asking ``stop()`` (no hit: the child failed) after the child has failed
    (it leaves a mark first), then its part ends: the one-line error."""
    mark = tmp_path / "child-failing"

    def task(part, stop):
        if part == 1:
            mark.touch()
            raise ValueError("boom")
        for _ in range(2000):               # at most 2 s for the child to start
            if mark.exists():
                break
            time.sleep(0.001)
        for _ in range(40):
            assert stop() is False
            time.sleep(0.005)
        return None, 0

    with pytest.raises(RuntimeError, match=FAILED):
        _forked.split_two(task)


def test_the_child_failing_after_the_parent_is_done_is_said_so_too():
    def task(part, stop):
        if part == 1:
            raise ValueError("boom")
        return None, 0

    with pytest.raises(RuntimeError, match=FAILED):
        _forked.split_two(task)


def test_a_part_that_fails_in_the_parent_keeps_its_error(tmp_path):
    """The parent's part raises while the child's would run for seconds: the parent's error comes
    out, not another, and the child is ended rather than waited for (it never gets to leave the
    mark it would leave at its end)."""
    mark = tmp_path / "child-finished"

    def task(part, stop):
        if part == 0:
            raise ValueError("the parent's part failed")
        for _ in range(300):
            time.sleep(0.01)
        mark.touch()
        return None, 0

    with pytest.raises(ValueError, match=r"^the parent's part failed$"):
        _forked.split_two(task)
    assert not mark.exists()
