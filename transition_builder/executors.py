"""Executors: where chunks of simulation work run (this process, local worker processes, a Dask cluster).

One layer for direct Monte Carlo (:func:`analysis.montecarlo.run_direct`) and for model building.
A caller splits its work into tasks (tuples of arguments of one module-level, picklable function)
and :meth:`Executor.map` yields ``(index, result)`` pairs as the tasks complete. Results must not
depend on where a task ran: a task builds its simulator with
:func:`transition_builder.simulators.simulator_for` (one per scene, kept between tasks) and draws any
randomness from its own arguments.

- :class:`SerialExecutor` runs every task in this process, in order.
- :class:`LocalExecutor` runs them in worker processes on this machine. Workers are *spawned*
  (never forked: a forked PyBullet client is not safe) and kept between calls in one module-level
  pool, because starting them costs about a second; :func:`shutdown_workers` stops them (it also
  runs at exit). Workers ignore Ctrl-C (the parent handles it and cancels what has not started)
  and die with their parent, even when it is killed with SIGKILL (Linux ``PR_SET_PDEATHSIG``,
  elsewhere a watchdog thread that polls the parent pid). As with any spawned pool, a script that
  uses it must guard its top level with ``if __name__ == "__main__":``.
- :class:`DaskExecutor` submits the tasks to a Dask ``distributed`` scheduler (``pip install
  'kruskal[distributed]'``). Every worker thread keeps its own simulators.

:func:`make_executor` picks one from command-line style options (``--workers``, ``--scheduler``).
"""
from __future__ import annotations

import atexit
import contextlib
import multiprocessing as mp
import os
import signal
import socket
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool

from kruskal_markov.validation import check_int

__all__ = [
    "DaskExecutor",
    "Executor",
    "LocalExecutor",
    "SchedulerLost",
    "SerialExecutor",
    "default_workers",
    "make_executor",
    "shutdown_workers",
    "terminate_workers",
]

#: seconds to wait for a Dask scheduler to answer.
DASK_CONNECT_TIMEOUT_S = 10.0

_BROKEN_MESSAGE = ("a worker process died (BrokenProcessPool); workers are spawned, so a script calling "
                   "run_direct needs an `if __name__ == '__main__':` guard -- or pass workers=1")
_DASK_MISSING = "--scheduler needs the 'distributed' extra: pip install 'kruskal[distributed]'"
_PR_SET_PDEATHSIG = 1          # from <linux/prctl.h>
_WATCHDOG_INTERVAL_S = 1.0


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def default_workers() -> int:
    """Number of cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        return os.cpu_count() or 1


def _check_workers(workers) -> int:
    return check_int(workers, "workers", lo=1)


# ----------------------------------------------------------------------------------------------
# executors
# ----------------------------------------------------------------------------------------------

class Executor:
    """Runs tasks somewhere and yields their results as they complete.

    Attributes
    ----------
    workers : int
        How many tasks can run at the same time.
    """

    workers: int = 1

    def map(self, fn, tasks):
        """Run ``fn(*task)`` for every task; yield ``(index, result)`` as each completes.

        ``index`` is the task's position in ``tasks``; ``fn`` must be a module-level (picklable)
        function and every task a tuple of picklable arguments. An exception in a task is raised
        here; tasks that have not started are then cancelled (also when the caller stops iterating).
        """
        raise NotImplementedError

    def close(self) -> None:
        """Release what this executor holds (the local worker pool is shared and kept)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self):
        return f"{type(self).__name__}(workers={self.workers})"


class SerialExecutor(Executor):
    """Runs every task in this process, in order."""

    workers = 1

    def map(self, fn, tasks):
        for i, task in enumerate(tasks):
            yield i, fn(*task)


# The local worker pool: (size, pool), kept between calls; replaced when another size is asked for.
_POOL: tuple[int, ProcessPoolExecutor] | None = None
_POOL_LOCK = threading.RLock()


def _set_parent_death_signal() -> bool:
    """Ask Linux to send SIGTERM to this process when the thread that spawned it ends."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0) == 0
    except Exception:  # noqa: BLE001 - best effort; the watchdog covers the rest
        return False


def _watch_parent(parent_pid: int) -> None:
    while True:
        time.sleep(_WATCHDOG_INTERVAL_S)
        if os.getppid() != parent_pid:
            os._exit(1)


def _init_worker(parent_pid: int, spawned_by_main_thread: bool) -> None:
    """Worker initializer: ignore Ctrl-C, and die with the parent process."""
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    except (ValueError, OSError):  # pragma: no cover
        pass
    # PR_SET_PDEATHSIG fires when the spawning *thread* ends: only safe when that is the main thread
    armed = spawned_by_main_thread and _set_parent_death_signal()
    if os.getppid() != parent_pid:  # the parent died before the signal was armed
        os._exit(1)
    if not armed:
        threading.Thread(target=_watch_parent, args=(parent_pid,), name="parent-watchdog", daemon=True).start()


def _worker_pid() -> int:
    return os.getpid()


def _get_pool(n_workers: int) -> ProcessPoolExecutor:
    global _POOL
    with _POOL_LOCK:
        if _POOL is not None and _POOL[0] == n_workers and not getattr(_POOL[1], "_broken", False):
            return _POOL[1]
        shutdown_workers()
        ctx = mp.get_context("spawn")  # never fork a process that may hold a physics client
        pool = ProcessPoolExecutor(max_workers=n_workers, mp_context=ctx, initializer=_init_worker,
                                   initargs=(os.getpid(), threading.current_thread() is threading.main_thread()))
        # start every worker now, from this thread (workers are otherwise started on demand, from
        # whichever thread submits; the parent-death signal is tied to the spawning thread)
        for _ in range(n_workers):
            pool.submit(_worker_pid)
        _POOL = (n_workers, pool)
        return pool


def shutdown_workers() -> None:
    """Stop the local worker processes kept by :class:`LocalExecutor` (also done at interpreter exit)."""
    global _POOL
    with _POOL_LOCK:
        if _POOL is not None:
            pool, _POOL = _POOL[1], None
            pool.shutdown(wait=True, cancel_futures=True)


atexit.register(shutdown_workers)


def terminate_workers() -> None:
    """Stop the kept local workers now, without waiting for their running tasks (after Ctrl-C or
    SIGTERM: a task may run for minutes). ProcessPoolExecutor has no public way to do this before
    Python 3.14 (``terminate_workers``), hence its ``_processes`` map."""
    global _POOL
    with _POOL_LOCK:
        if _POOL is None:
            return
        pool, _POOL = _POOL[1], None
    for proc in list((getattr(pool, "_processes", None) or {}).values()):
        try:
            proc.terminate()
        except (OSError, AttributeError):  # pragma: no cover - already gone
            pass
    pool.shutdown(wait=False)


class LocalExecutor(Executor):
    """Runs tasks in ``workers`` spawned worker processes of this machine (a kept, shared pool).

    Parameters
    ----------
    workers : int
        Pool size. The pool is shared by every LocalExecutor of this size and kept after
        :meth:`close`; asking for another size replaces it (:func:`shutdown_workers` stops it).

    Raises
    ------
    RuntimeError
        From :meth:`map`, when a worker process died (``BrokenProcessPool``).
    """

    def __init__(self, workers: int):
        self.workers = _check_workers(workers)

    def map(self, fn, tasks):
        tasks = [tuple(t) for t in tasks]
        futures: dict = {}
        try:
            pool = _get_pool(self.workers)
            for i, task in enumerate(tasks):
                futures[pool.submit(fn, *task)] = i
            for fut in as_completed(futures):
                yield futures[fut], fut.result()
        except BrokenProcessPool as exc:
            for fut in futures:
                fut.cancel()
            shutdown_workers()
            raise RuntimeError(_BROKEN_MESSAGE) from exc
        except BaseException as exc:  # also KeyboardInterrupt, and GeneratorExit when the caller stops
            if isinstance(exc, KeyboardInterrupt):   # Ctrl-C or SIGTERM: do not wait for running tasks
                # no cancel() first: the pool's manager thread fails every pending future when its
                # workers die, and a cancelled one makes it raise InvalidStateError (Python 3.11)
                terminate_workers()
            else:
                for fut in futures:
                    fut.cancel()
            raise


def _probe_scheduler(address: str, timeout_s: float) -> None:
    """Open (and close) one connection to ``address``, handshake included; a one-line ValueError if that fails.

    Done before a ``distributed.Client`` is made: a client that fails to connect leaves an event
    loop behind whose clean-up stalls and prints tracebacks at exit.
    """
    import asyncio

    from distributed.comm import connect
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import backends

    try:
        scheme, loc = parse_address(address)
        host, port = parse_host_port(loc) if scheme == "tcp" else (None, None)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"bad Dask scheduler address {address!r}: {_one_line(exc)}") from None
    if scheme not in backends:
        raise ValueError(f"bad Dask scheduler address {address!r}: unknown scheme {scheme!r} "
                         f"(known: {', '.join(sorted(backends))})")
    if host is not None:  # a refused TCP connection fails at once (distributed retries until the timeout)
        try:
            socket.create_connection((host, port), timeout=timeout_s).close()
        except OSError as exc:
            raise ValueError(f"cannot reach the Dask scheduler at {address!r}: {_one_line(exc)}") from None

    async def probe():
        comm = await connect(address, timeout=timeout_s)
        await comm.close()

    failure: list[BaseException] = []

    def run():  # in its own thread: the caller may already be running an event loop
        try:
            asyncio.run(probe())
        except Exception as exc:  # noqa: BLE001 - any failure means: not a scheduler we can use
            failure.append(exc)

    t = threading.Thread(target=run, name="dask-probe", daemon=True)
    t.start()
    t.join(timeout_s + 5.0)
    if t.is_alive():
        raise ValueError(f"cannot connect to the Dask scheduler at {address!r}: no answer in {timeout_s:g} s")
    if failure:
        exc = failure[0]
        why = "the server there does not speak the Dask protocol" if isinstance(exc, MemoryError) else _one_line(exc)
        raise ValueError(f"cannot connect to the Dask scheduler at {address!r}: {why}")


class SchedulerLost(ConnectionError):
    """The Dask scheduler went away while tasks were running (one line, naming its address)."""


def _lost_scheduler(exc: BaseException, client) -> bool:
    """Whether ``exc``, raised while waiting for results, means the scheduler (not a task) failed."""
    import asyncio
    import concurrent.futures

    names = {cls.__name__ for cls in type(exc).__mro__}
    if names & {"FutureCancelledError", "CancelledError", "CommClosedError", "StreamClosedError"}:
        return True
    if isinstance(exc, (asyncio.CancelledError, concurrent.futures.CancelledError)):
        return True
    return getattr(client, "status", "running") not in ("running", "connecting")


class DaskExecutor(Executor):
    """Runs tasks on a Dask ``distributed`` cluster.

    Parameters
    ----------
    address : str
        Scheduler address, e.g. ``tcp://10.0.0.5:8786`` or ``localhost:8786``.
    timeout_s : float, default :data:`DASK_CONNECT_TIMEOUT_S`
        Connection timeout.

    Raises
    ------
    ValueError
        If ``distributed`` is not installed, or the address is malformed or does not answer.
    """

    def __init__(self, address: str, timeout_s: float = DASK_CONNECT_TIMEOUT_S):
        if not isinstance(address, str) or not address.strip():
            raise ValueError(f"a Dask scheduler address must be a non-empty string, got {address!r}")
        try:
            import distributed
        except ImportError:
            raise ValueError(_DASK_MISSING) from None
        address = address.strip()
        _probe_scheduler(address, timeout_s)
        try:
            self._client = distributed.Client(address, timeout=timeout_s, set_as_default=False)
        except Exception as exc:  # noqa: BLE001 - any connection failure is the user's address
            raise ValueError(f"cannot connect to the Dask scheduler at {address!r}: {_one_line(exc)}") from None
        self.address = address

    @property
    def workers(self) -> int:
        """Total threads of the cluster's workers (at least 1)."""
        return max(1, int(sum(self._client.nthreads().values())))

    def map(self, fn, tasks):
        import distributed

        futures = []
        try:
            futures = [self._client.submit(fn, *tuple(t), pure=False) for t in tasks]
            index = {fut.key: i for i, fut in enumerate(futures)}
            for fut in distributed.as_completed(futures, loop=self._client.loop):
                yield index[fut.key], fut.result()
        except Exception as exc:
            with contextlib.suppress(Exception):  # the client may be gone already
                self._client.cancel(futures)
            if _lost_scheduler(exc, self._client):
                raise SchedulerLost(f"lost the Dask scheduler at {self.address} ({type(exc).__name__})") from None
            raise
        except BaseException:
            with contextlib.suppress(Exception):  # the client may be gone already
                self._client.cancel(futures)
            raise

    def close(self) -> None:
        client = getattr(self, "_client", None)
        if client is not None and client.status not in ("closed", "closing"):
            with contextlib.suppress(Exception):    # a lost scheduler: nothing left to close politely
                client.close(timeout=5)

    def __repr__(self):
        return f"DaskExecutor({self.address!r})"


def make_executor(workers: int | None = None, scheduler: str | None = None) -> Executor:
    """The executor for ``--workers`` / ``--scheduler``.

    A scheduler address gives a :class:`DaskExecutor` (``workers`` is then not used); otherwise
    one worker (or one available core) a :class:`SerialExecutor` and more a :class:`LocalExecutor`
    (``None``: every available core). Raises a one-line ValueError on bad input.
    """
    if workers is not None:
        workers = _check_workers(workers)
    if scheduler is not None:
        return DaskExecutor(scheduler)
    n = workers if workers is not None else default_workers()
    return SerialExecutor() if n == 1 else LocalExecutor(n)
