"""Two processes over the chunks of one length of the inverse depth-first phase (both cores).

The deepening phase (:class:`~kruskal_markov.sync.exact._InverseDepthFirst`) tests one length at a
time, chunk by chunk of the newest backward level, against one read-only forward trie; chunks are
independent, and any hit at the length is a shortest word (every shorter length is ruled out). So
the chunks are dealt out alternately to this process and one forked child (the trie and the stores
are shared copy-on-write, never written), each running its kernels on one thread: coarse-grained
work on both cores, where splitting each trie walk over two threads cost about 1.45 times the CPU
of one walk (docs/plans.md, issue 43). The first hit ends both (the parent kills the child; the
child's hit is read between the parent's chunks). synchrowords runs its depth-first phase's trie
queries on its thread pool instead (M. Szykula and A. Zyzik, ESA 2022); our own code. POSIX
``fork`` only; where it is missing the caller runs the chunks itself.
"""
from __future__ import annotations

import os
import pickle
import select
import signal

__all__ = ["can_fork", "split_two"]


def can_fork() -> bool:
    """Whether this platform has ``os.fork``."""
    return hasattr(os, "fork")


def _read_all(fd) -> bytes:
    parts = []
    while True:
        b = os.read(fd, 1 << 16)
        if not b:
            return b"".join(parts)
        parts.append(b)


def split_two(task):
    """``[task(0, stop), task(1, stop)]``, the second run in a forked child. ``task(part, stop)``
    returns a picklable ``(kind, payload)``; ``kind == "hit"`` ends the other part: the parent's
    ``stop()`` turns true once the child has reported a hit (the child's ``stop`` never does; the
    parent kills the child after its own hit, whose entry is then ``("killed", None)``)."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:                # the child: run part 1, report, leave without cleanup handlers
        code = 0
        try:
            os.close(r)
            data = pickle.dumps(task(1, lambda: False))
            view = memoryview(data)
            while view:
                view = view[os.write(w, view):]
        except BaseException:       # noqa: BLE001 -- any failure is reported as an empty message
            code = 1
        finally:
            os._exit(code)
    os.close(w)
    child = [None]

    def child_report():
        if child[0] is None and select.select([r], [], [], 0)[0]:
            data = _read_all(r)
            child[0] = pickle.loads(data) if data else ("failed", None)
        return child[0]

    def stop():
        rep = child_report()
        return rep is not None and rep[0] == "hit"

    try:
        mine = task(0, stop)
        if child[0] is None and mine[0] == "hit":
            os.kill(pid, signal.SIGKILL)
            child[0] = ("killed", None)
        elif child[0] is None:
            data = _read_all(r)
            child[0] = pickle.loads(data) if data else ("failed", None)
    finally:
        if child[0] is None:        # this part failed: do not wait for the other
            os.kill(pid, signal.SIGKILL)
        os.close(r)
        os.waitpid(pid, 0)
    if child[0][0] == "failed":
        raise RuntimeError("the depth-first phase's second process failed")
    return [mine, child[0]]
