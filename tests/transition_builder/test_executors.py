"""Tests for transition_builder.executors: serial, local processes and Dask give the same results;
bad options are one-line ValueErrors; local workers die with their parent."""
from __future__ import annotations

import contextlib
import logging
import math
import os
import select
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import tests
from analysis.montecarlo import run_direct
from transition_builder.executors import (
    DaskExecutor,
    Executor,
    LocalExecutor,
    SerialExecutor,
    default_workers,
    make_executor,
)
from transition_builder.scene import scene_from_options
from transition_builder.simulators import simulator_for

ROOT = str(tests.ROOT)


@contextlib.contextmanager
def deadline(seconds: int):
    """Raise TimeoutError in the main thread after ``seconds`` (a hung cluster must not hang the suite)."""
    def expired(signum, frame):
        raise TimeoutError(f"timed out after {seconds} s")

    old = signal.signal(signal.SIGALRM, expired)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


@pytest.fixture(scope="module", params=["pybullet", "planar"])
def scene(request):
    """The key in either engine: the same results on every executor and worker count, for both."""
    return scene_from_options("allen-key", engine=request.param)


@pytest.fixture(scope="module")
def dask_address():
    distributed = pytest.importorskip("distributed")
    with deadline(90):
        cluster = distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                           dashboard_address=None, silence_logs=logging.ERROR)
    try:
        yield cluster.scheduler_address
    finally:
        with deadline(60):
            cluster.close()


@pytest.fixture(scope="module")
def serial_run(scene):
    return run_direct(scene, ["NE", "S"], 40, seed=6, noise="pose:0.5,1", executor=SerialExecutor())


def _same(a, b):
    assert np.array_equal(a.poses, b.poses, equal_nan=True)
    assert np.array_equal(a.status, b.status)
    assert np.array_equal(a.entropy_bits, b.entropy_bits)
    assert a.to_dict()["noise"] == b.to_dict()["noise"] == "pose:0.5,1"


def test_local_executor_same_result(scene, serial_run):
    with deadline(120), LocalExecutor(2) as ex:
        assert ex.workers == 2
        _same(serial_run, run_direct(scene, ["NE", "S"], 40, seed=6, noise="pose:0.5,1", executor=ex))


def test_dask_executor_same_result(scene, serial_run, dask_address):
    with deadline(120):
        with DaskExecutor(dask_address) as ex:
            assert ex.workers == 1
            _same(serial_run, run_direct(scene, ["NE", "S"], 40, seed=6, noise="pose:0.5,1", executor=ex))
        # run_direct makes (and closes) its own client for a scheduler address
        _same(serial_run, run_direct(scene, ["NE", "S"], 40, seed=6, noise="pose:0.5,1", scheduler=dask_address))


def test_map_yields_every_index_and_raises_task_errors(dask_address):
    tasks = [(float(i),) for i in range(7)]
    with deadline(120):
        for ex in (SerialExecutor(), LocalExecutor(2), DaskExecutor(dask_address)):
            with ex:
                got = dict(ex.map(math.sqrt, tasks))
                assert got == {i: math.sqrt(i) for i in range(7)}
                if isinstance(ex, SerialExecutor):
                    assert [i for i, _ in ex.map(math.sqrt, tasks)] == list(range(7))
                with pytest.raises(ValueError, match="math domain error"):
                    list(ex.map(math.sqrt, [(1.0,), (-1.0,)]))


def test_make_executor_choices_and_errors():
    assert isinstance(make_executor(1), SerialExecutor)
    ex = make_executor(2)
    assert isinstance(ex, LocalExecutor) and ex.workers == 2 and isinstance(ex, Executor)
    assert make_executor().workers == default_workers()
    assert default_workers() >= 1
    for bad in (0, -1, 1.5, True, "2"):
        with pytest.raises(ValueError, match="workers must be a positive integer"):
            make_executor(bad)


@pytest.mark.parametrize("address, needle", [
    ("nonsense://x", "unknown scheme"),
    ("localhost:1", "cannot reach"),
    ("tcp://127.0.0.1", "bad Dask scheduler address"),
    ("", "non-empty"),
])
def test_bad_scheduler_address(address, needle):
    t0 = time.perf_counter()
    with deadline(30), pytest.raises(ValueError, match=needle) as exc:
        make_executor(scheduler=address)
    assert len(str(exc.value).splitlines()) == 1
    assert time.perf_counter() - t0 < 15


def test_simulator_for_keeps_one_per_scene(scene):
    a = simulator_for(scene)
    assert simulator_for(scene) is a
    engine = scene.settings.engine
    assert simulator_for(scene_from_options("allen-key", engine=engine)) is a  # same content, same simulator
    assert simulator_for(scene_from_options("rectangle:40x20", engine=engine)) is not a
    other = "pybullet" if engine == "planar" else "planar"
    assert simulator_for(scene_from_options("allen-key", engine=other)) is not a  # never the other engine


_CHILD = textwrap.dedent("""
    import multiprocessing, os, sys, threading, time
    from transition_builder.executors import LocalExecutor

    def start():
        ex = LocalExecutor(2)
        list(ex.map(os.getpid, [()]))

    if __name__ == "__main__":
        if sys.argv[1] == "thread":   # the pool is made by a thread that then ends
            t = threading.Thread(target=start)
            t.start()
            t.join()
        else:
            start()
        print(" ".join(str(p.pid) for p in multiprocessing.active_children()), flush=True)
        time.sleep(600)
""")


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            state = fh.read().rsplit(")", 1)[1].split()[0]
        return state not in ("Z", "X")   # a zombie is dead (its new parent may not reap it)
    except FileNotFoundError:
        return False
    except OSError:  # pragma: no cover - no /proc
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        return True


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="needs /proc")
@pytest.mark.parametrize("made_by", ["main", "thread"])
def test_local_workers_die_with_a_killed_parent(made_by):
    proc = subprocess.Popen([sys.executable, "-c", _CHILD, made_by], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True)
    try:
        ready, _, _ = select.select([proc.stdout], [], [], 60)
        assert ready, "the child did not report its workers in 60 s"
        pids = [int(p) for p in proc.stdout.readline().split()]
        assert len(pids) == 2
        time.sleep(1.5)  # a worker made by an ended thread must survive that thread
        assert all(_alive(p) for p in pids)
    finally:
        proc.kill()
        proc.wait(10)
    end = time.monotonic() + 10
    while time.monotonic() < end and any(_alive(p) for p in pids):
        time.sleep(0.1)
    left = [p for p in pids if _alive(p)]
    for p in left:  # do not leave them behind if the test fails
        os.kill(p, signal.SIGKILL)
    assert not left, f"worker(s) {left} outlived their parent"


def _descendants(pid: int) -> list[int]:
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        try:
            kids = [int(c) for t in os.listdir(f"/proc/{p}/task")
                    for c in open(f"/proc/{p}/task/{t}/children").read().split()]
        except OSError:
            kids = []
        out += kids
        todo += kids
    return out


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="needs /proc")
@pytest.mark.parametrize("sig, status", [(signal.SIGTERM, 143), (signal.SIGKILL, -9)])
def test_killed_simulate_leaves_no_worker_behind(sig, status):
    """`kruskal simulate` killed mid-run (SIGTERM: a clean one-line exit; SIGKILL) leaves no process."""
    proc = subprocess.Popen([sys.executable, "-m", "analysis", "simulate", "--sequence", "random:50",
                             "--trials", "100000", "--workers", "2"], cwd=ROOT, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)
    workers = []
    try:
        end = time.monotonic() + 60
        while time.monotonic() < end and len(workers) < 2:
            time.sleep(0.2)
            workers = _descendants(proc.pid)
        assert len(workers) >= 2, "no workers started within 60 s"
        time.sleep(1.0)
        proc.send_signal(sig)
        assert proc.wait(15) == status
        if sig == signal.SIGTERM:
            err = proc.stderr.read()
            assert err.strip().splitlines()[-1] == "kruskal simulate: terminated" and "Traceback" not in err, err
    finally:
        if proc.poll() is None:
            proc.kill()
    end = time.monotonic() + 5
    while time.monotonic() < end and any(_alive(p) for p in workers):
        time.sleep(0.1)
    left = [p for p in workers if _alive(p)]
    for p in left:
        os.kill(p, signal.SIGKILL)
    assert not left, f"worker(s) {left} outlived `kruskal simulate`"
