"""Exact shortest reset words at the record holder's scale (issue 43), side by side with synchrowords.

Instances (generator below, seeds fixed before any result was seen; seed 0 of the random
families was used for tuning and is not in the list): Cerny automata, random complete binary
automata of 100-300 states, random 8-letter automata of 50-200 states, contracting 8-letter
automata of 256-1,024 states (:func:`kruskal_markov.generators.contracting_table`).

Ours: :func:`kruskal_markov.sync.shortest_synchronizing_word` with a 4,000 MB memory budget and the
time budget of the row (the issue's target: 3x synchrowords' time, 10 minutes for 8 letters and
200 states), on the cores the process may run on; Numba compile time is excluded (warm-up first).
synchrowords (Szykula and Zyzik, ESA 2022) returns lengths only; its times (its own
per-algorithm timers, JIT compilation excluded) and lengths are stored in
``benchmarks/data/sync_record_synchrowords.json`` and printed beside ours.

synchrowords is not a dependency; to compare with it, build it outside the repository:
``git clone https://github.com/marekesz/synchrowords`` (v1.1.0, commit 964f55a), then ``make`` in
it (it needs ``g++`` with ``-pthread``, ``make`` and ``libtbb-dev``; it compiles each automaton
size just in time on its first run). ``PATH`` below is its ``synchro`` script. ``CONFIG``
defaults to ``benchmarks/data/synchrowords_exact.json``: its ``configs/exact.json`` with
``threads`` 2 and ``max_memory_mb`` 4096 (the issue's 2 cores and 4 GB).

Modes (arguments read from ``sys.argv``; there is no ``--help``; ``--only`` takes key prefixes,
comma-separated, e.g. ``--only random-2-200,cerny``; ``--max-budget S`` caps every time budget at
S s):

- no mode (``python -m benchmarks sync_record``): our solver on every row, results in
  ``benchmarks/data/sync_record.json``;
- ``--synchrowords PATH [CONFIG]``: synchrowords on the rows, stored in its file;
- ``--side-by-side PATH [CONFIG]``: synchrowords and ours alternately, instance by instance, in
  one process, printing the ratios of wall clock and of CPU time (both files updated);
- ``--work [--memory-mb M]``: our answer and the subsets generated without a time budget (a
  change that only makes the search faster leaves them unchanged), with the CPU time;
- ``--trace [--memory-mb M]``: where one solve's time goes, stage by stage (:func:`run_trace`).
"""
from __future__ import annotations

import json
import os
import pathlib
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

from kruskal_markov import _sync_kernels as _k
from kruskal_markov import generators
from kruskal_markov.sync import ExactSearchOptions, SyncAutomaton, is_synchronizing_word, shortest_synchronizing_word
from kruskal_markov.sync.options import usable_cores

DATA = pathlib.Path(__file__).parent / "data"
SW_FILE = DATA / "sync_record_synchrowords.json"
OUT_FILE = DATA / "sync_record.json"
SW_CONFIG = DATA / "synchrowords_exact.json"      # synchrowords' exact config: 2 threads, 4,096 MB
MEMORY_MB = 4000.0
SW_LIMIT = 120.0        # synchrowords' time limit in the target (seconds)

#: (family, letters, states, seed)
INSTANCES = [
    ("cerny", 2, 16, 0), ("cerny", 2, 32, 0),
    ("random", 2, 100, 1), ("random", 2, 200, 1), ("random", 2, 300, 1),
    ("random", 8, 50, 1), ("random", 8, 100, 1), ("random", 8, 200, 1),
    ("contracting", 8, 256, 1), ("contracting", 8, 1024, 1),
    # held out for the subset-trie round (named in docs/plans.md before it was run)
    ("random", 2, 200, 2), ("random", 2, 200, 3), ("random", 8, 100, 2), ("random", 8, 100, 3),
    # held out for the cheaper-sets round (named in docs/plans.md before it was run)
    ("random", 8, 100, 4), ("random", 8, 100, 5), ("random", 2, 200, 4), ("random", 8, 200, 2),
    # held out for the depth-first round (issue 43, sixth; named in docs/plans.md before it was run)
    ("random", 8, 200, 5), ("random", 8, 200, 6),
    # held out for the leaf-test round (issue 43, seventh; named in the brief and docs/plans.md before it was run)
    ("random", 8, 200, 7), ("random", 8, 200, 8),
]


def instance_table(family: str, k: int, n: int, seed: int) -> np.ndarray:
    """The ``(k, n)`` next-state table of a benchmark instance."""
    if family == "cerny":
        return generators.cerny_table(n)
    if family == "random":
        return generators.random_table(n, k, seed)
    if family == "contracting":
        return generators.contracting_table(n, k, seed)
    raise ValueError(f"unknown family {family!r}")


def key(inst) -> str:
    family, k, n, seed = inst
    return f"{family}-{k}-{n}-s{seed}"


def _time_budget(inst, sw: dict | None) -> float:
    """3x synchrowords' time (at least 10 s), 600 s where it took over 2 minutes or was not run."""
    if sw is None or sw.get("seconds") is None or sw["seconds"] > SW_LIMIT:
        return 600.0
    return max(10.0, 3.0 * sw["seconds"])


def _big_stack():
    """synchrowords keeps its subsets on the stack: at 1,024 states the default 8 MB stack
    overflows (a segmentation fault, no result line), so it runs with an unlimited stack."""
    import resource

    resource.setrlimit(resource.RLIMIT_STACK, (resource.RLIM_INFINITY, resource.RLIM_INFINITY))


def _run_capped(cmd, timeout):
    """Run ``cmd`` in its own process group; past ``timeout`` seconds kill the whole group (the
    ``synchro`` script starts the solver as a child, which a plain timeout leaves running) and
    raise ``subprocess.TimeoutExpired``."""
    import signal

    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, preexec_fn=_big_stack,
                            start_new_session=True)
    try:
        proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        raise


def _child_cpu() -> float:
    """CPU seconds (user + system) of the finished child processes so far."""
    import resource

    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run_synchrowords(binary: str, config: str, only: tuple = (), instances=None) -> dict:
    """Run synchrowords on every instance (or those whose key starts with one of ``only``;
    ``SW_LIMIT`` seconds each) and return ``{key: row}``: its own timers' sum (``seconds``), the
    wall clock of the process (``wall``) and its CPU time (``cpu``, user + system of the process
    and its threads, start-up included)."""
    out = {}
    for inst in INSTANCES if instances is None else instances:
        if only and not key(inst).startswith(only):
            continue
        t = instance_table(*inst)
        k, n = t.shape
        with tempfile.TemporaryDirectory() as d:
            src = os.path.join(d, "in.txt")
            with open(src, "w") as f:
                f.write(f"{k} {n}\n" + " ".join(str(int(t[a, q])) for q in range(n) for a in range(k)) + "\n")
            res = os.path.join(d, "out.txt")
            cmd = [binary, "-c", config, "-f", src, "-o", res]
            try:        # JIT compilation for this (n, k) (a solve too: capped like the timed run)
                _run_capped(cmd, SW_LIMIT + 30)
            except subprocess.TimeoutExpired:
                pass
            t0 = time.perf_counter()
            c0 = _child_cpu()
            try:
                _run_capped(cmd, SW_LIMIT + 30)
                wall = time.perf_counter() - t0
                cpu = _child_cpu() - c0
                line = open(res).read().strip() if os.path.exists(res) else ""
            except subprocess.TimeoutExpired:
                out[key(inst)] = {"length": None, "exact": False, "seconds": None, "wall": None,
                                  "note": f"not done within {SW_LIMIT + 30:.0f} s"}
                continue
        m = re.match(r"\d+: \[(\d+), (\d+)\] \((.*)\)", line)
        if m is None:
            out[key(inst)] = {"length": None, "exact": False, "seconds": None, "wall": wall,
                              "note": f"no result line (output {line[:200]!r})"}
            continue
        lo, hi = int(m.group(1)), int(m.group(2))
        ms = sum(int(x) for x in re.findall(r", (\d+)\)", m.group(3)))
        out[key(inst)] = {"length": hi, "lower": lo, "exact": lo == hi, "seconds": ms / 1000, "wall": wall,
                          "cpu": round(cpu, 3), "raw": line}
        print(key(inst), out[key(inst)], flush=True)
    return out


def _warm_up():
    """Compile every Numba kernel before the timed runs: small automata (the fast path), then, past
    the fast path (a node budget skips it), the beam, the cost model's steps and the last level on
    automata of over 64 states (two-word bitsets; tuning seed 0, not a benchmark row)."""
    a = SyncAutomaton.from_table(generators.random_table(40, 2, 0))
    shortest_synchronizing_word(a, time_budget=None)
    shortest_synchronizing_word(SyncAutomaton.from_table(generators.random_table(40, 8, 0)), time_budget=None)
    for n, k in ((80, 8), (100, 2)):
        shortest_synchronizing_word(SyncAutomaton.from_table(generators.random_table(n, k, 0)), time_budget=None,
                                    node_budget=10 ** 9)
    # the kernels of large levels (compiled on first use), both directions
    rows = np.random.default_rng(0).integers(0, 2 ** a.n, size=(1 << 15, a.n_words), dtype=np.uint64)   # n = 40
    for forward in (True, False):
        _k.level_images(rows, 0, rows.shape[0], a.delta, a.sup, True, forward, *a.inverse)


def run_ours(only: tuple = (), max_budget: float | None = None, instances=None, sw_all=None, warm=True) -> dict:
    """Our solver on the instances (budgets: :func:`_time_budget`, capped at ``max_budget``), beside
    synchrowords' rows ``sw_all`` (default: the stored file); wall clock and CPU time (``cpu``: this
    process, every thread) of each solve."""
    if sw_all is None:
        sw_all = json.loads(SW_FILE.read_text()) if SW_FILE.exists() else {}
    if warm:
        _warm_up()
    rows = {}
    for inst in INSTANCES if instances is None else instances:
        if only and not key(inst).startswith(only):
            continue
        t = instance_table(*inst)
        aut = SyncAutomaton.from_table(t)
        sw = sw_all.get(key(inst))
        budget = _time_budget(inst, sw) if max_budget is None else min(max_budget, _time_budget(inst, sw))
        t0 = time.perf_counter()
        c0 = time.process_time() + _child_cpu()       # a forked depth-first process counts as ours

        def observe(event, value, t0=t0):
            if event in ("depth-first", "deepened"):
                print(f"  {time.perf_counter() - t0:8.1f} s  {event} {value}", flush=True)

        r = shortest_synchronizing_word(aut, time_budget=budget, memory_budget_mb=MEMORY_MB,
                                        options=ExactSearchOptions(observe=observe))
        sec = time.perf_counter() - t0
        cpu = time.process_time() + _child_cpu() - c0
        ok = r.word is not None and is_synchronizing_word(aut, r.word)
        rows[key(inst)] = {"length": r.length, "exact": r.exact, "lower_bound": r.lower_bound, "method": r.method,
                           "seconds": round(sec, 3), "cpu": round(cpu, 3), "time_budget": budget, "word_checked": ok,
                           "subsets": r.states_explored, "threads": r.threads, "cores": usable_cores()}
        swl = "-" if sw is None else f"{sw.get('length')} {'exact' if sw.get('exact') else ''} {sw.get('seconds')} s"
        target = sw is not None and sw.get("exact") and sw["seconds"] <= SW_LIMIT
        met = (r.exact and r.length == sw["length"] and sec <= 3 * sw["seconds"]) if target else None
        rows[key(inst)]["target_met"] = met
        print(f"{key(inst):24s} ours {r.length} exact={r.exact} lb={r.lower_bound} {sec:7.2f} s cpu {cpu:7.2f} s "
              f"{r.method:24s} threads {r.threads} | synchrowords {swl} | target met: {met}", flush=True)
    return rows


def _save(path, rows):
    old = json.loads(path.read_text()) if path.exists() else {}
    old.update(rows)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(old, indent=1, sort_keys=True) + "\n")
    tmp.replace(path)


def run_side_by_side(binary: str, config: str, only: tuple = (), max_budget: float | None = None) -> None:
    """synchrowords, then ours, instance by instance in one process (both slowed alike by whatever
    else runs); ratios of wall clock (ours against synchrowords' own timers) and of CPU time. Both
    files are updated, synchrowords' rows with ``conditions: side by side``."""
    _warm_up()
    # in the order of ``only`` (the rows that matter first, in case the job is cut short)
    order = [i for p in only for i in INSTANCES if key(i).startswith(p)] if only else INSTANCES
    for inst in dict.fromkeys(order):
        load = os.getloadavg()[0]
        sw = run_synchrowords(binary, config, instances=[inst])
        for row in sw.values():
            row["conditions"] = f"side by side with ours, {time.strftime('%Y-%m-%d %H:%M', time.gmtime())} UTC, " \
                                f"load {load:.2f}"
        _save(SW_FILE, sw)
        ours = run_ours(max_budget=max_budget, instances=[inst], sw_all=sw, warm=False)
        _save(OUT_FILE, ours)
        a, b = ours[key(inst)], sw[key(inst)]
        if b.get("seconds") and b.get("cpu"):
            print(f"{key(inst):24s} ratio wall {a['seconds'] / b['seconds']:.2f} (ours {a['seconds']:.3f} s, theirs "
                  f"{b['seconds']:.3f} s) cpu {a['cpu'] / b['cpu']:.2f} (ours {a['cpu']:.3f} s, theirs {b['cpu']:.3f} s) "
                  f"load {load:.2f}", flush=True)


def run_work(only: tuple = (), memory_mb: float = MEMORY_MB) -> dict:
    """The search's answer and work on each instance, without a time budget: length, ``exact``,
    method, lower bound and the subsets generated (which a change that only makes the search
    faster leaves unchanged), with the CPU time (this process, every thread) and the threads.
    ``--work`` (optionally ``--memory-mb M``: a small memory budget sends the search into its
    depth-first phases)."""
    _warm_up()
    rows = {}
    for inst in INSTANCES:
        if only and not key(inst).startswith(only):
            continue
        aut = SyncAutomaton.from_table(instance_table(*inst))
        c0 = time.process_time()
        r = shortest_synchronizing_word(aut, time_budget=None, memory_budget_mb=memory_mb)
        cpu = time.process_time() - c0
        ok = r.word is not None and is_synchronizing_word(aut, r.word)
        rows[key(inst)] = {"length": r.length, "exact": r.exact, "method": r.method, "lower_bound": r.lower_bound,
                           "subsets": r.states_explored, "word_checked": ok, "cpu": round(cpu, 3),
                           "threads": r.threads}
        print(f"{key(inst):24s} memory {memory_mb:g} MB: {r.length} exact={r.exact} lb={r.lower_bound} "
              f"{r.method} subsets {r.states_explored} word checked {ok} cpu {cpu:.2f} s threads {r.threads}",
              flush=True)
    return rows


def run_trace(only: tuple = (), max_budget: float | None = None, memory_mb: float = MEMORY_MB) -> None:
    """Where one solve's time goes: every stage the search reports
    (:class:`~kruskal_markov.sync.options.ExactSearchOptions`' ``observe`` events: the fast path, the
    beams' words, each breadth-first level's sets, each meet test, the last level, the depth-first
    phases), printed with the wall clock and CPU time since the solve's start and since the
    previous event; the depth-first phases' batches are summed (a progress line every 30 s), and
    the process's peak memory is printed at the end. ``--trace`` (with ``--only``, ``--max-budget``
    and ``--memory-mb``); the time budget is the benchmark row's."""
    import resource

    sw_all = json.loads(SW_FILE.read_text()) if SW_FILE.exists() else {}
    _warm_up()
    for inst in INSTANCES:
        if only and not key(inst).startswith(only):
            continue
        aut = SyncAutomaton.from_table(instance_table(*inst))
        budget = _time_budget(inst, sw_all.get(key(inst)))
        budget = budget if max_budget is None else min(max_budget, budget)
        print(f"{key(inst)}: time budget {budget:g} s, memory {memory_mb:g} MB", flush=True)
        t0, c0 = time.perf_counter(), time.process_time()
        last = [t0, t0]               # the previous event, the previous progress line
        dfs = [0, 0]                  # depth-first batches, sets in them

        def observe(event, value):
            now = time.perf_counter()
            if event == "dfs-batch":
                dfs[0] += 1
                dfs[1] += value
                if now - last[1] < 30:
                    return
                event, value = "depth-first progress: batches, sets", f"{dfs[0]} {dfs[1]}"
            print(f"  {now - t0:9.2f} s (+{now - last[0]:7.2f}) cpu {time.process_time() - c0:9.2f} s  {event} {value}",
                  flush=True)
            last[:] = now, now

        r = shortest_synchronizing_word(aut, time_budget=budget, memory_budget_mb=memory_mb,
                                        options=ExactSearchOptions(observe=observe))
        print(f"  => {r.length} exact={r.exact} lb={r.lower_bound} {r.method} subsets {r.states_explored} "
              f"{time.perf_counter() - t0:.2f} s cpu {time.process_time() - c0:.2f} s threads {r.threads}; "
              f"depth-first batches {dfs[0]}, sets {dfs[1]}; peak RSS "
              f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB", flush=True)


def _solver_args(argv, flag):
    """``(PATH, CONFIG)`` after ``flag``; CONFIG defaults to :data:`SW_CONFIG`."""
    i = argv.index(flag)
    config = argv[i + 2] if len(argv) > i + 2 and not argv[i + 2].startswith("--") else str(SW_CONFIG)
    return argv[i + 1], config


def main(argv=()) -> None:
    argv = list(argv)
    only = tuple(argv[argv.index("--only") + 1].split(",")) if "--only" in argv else ()
    cap = float(argv[argv.index("--max-budget") + 1]) if "--max-budget" in argv else None
    memory_mb = float(argv[argv.index("--memory-mb") + 1]) if "--memory-mb" in argv else MEMORY_MB
    if "--work" in argv:
        run_work(only, memory_mb)
        return
    if "--trace" in argv:
        run_trace(only, cap, memory_mb)
        return
    if "--side-by-side" in argv:
        run_side_by_side(*_solver_args(argv, "--side-by-side"), only, cap)
        return
    if "--synchrowords" in argv:
        res = run_synchrowords(*_solver_args(argv, "--synchrowords"), only)
        old = json.loads(SW_FILE.read_text()) if SW_FILE.exists() else {}
        old.update(res)
        tmp = SW_FILE.with_suffix(".tmp")
        tmp.write_text(json.dumps(old, indent=1, sort_keys=True) + "\n")
        tmp.replace(SW_FILE)
        return
    load = os.getloadavg()[0]
    print(f"(1-minute load average at start {load:.2f} on {os.cpu_count()} cores; wall-clock times)")
    rows = run_ours(only, cap)
    old = json.loads(OUT_FILE.read_text()) if OUT_FILE.exists() else {}
    old.update(rows)
    tmp = OUT_FILE.with_suffix(".tmp")
    tmp.write_text(json.dumps(old, indent=1, sort_keys=True) + "\n")
    tmp.replace(OUT_FILE)


if __name__ == "__main__":
    main(sys.argv[1:])
