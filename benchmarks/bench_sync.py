"""Synchronization benchmark: exact shortest reset words, greedy bounds, pair-chain bounds.

Targets are the times of a state-of-the-art C++ exact solver (Szykula and Zyzik's, compiled per
size) measured on this kind of machine (issue 4); we aim to be within 10x with the same exact
lengths. Numba compile time is excluded: every kernel is warmed up on a small automaton first.
Instances are seeded random automata; times are wall-clock medians over the listed instances.
"""
from __future__ import annotations

import os
import resource
import statistics
import time

import numpy as np

from kruskal_markov import generators
from kruskal_markov.convergence import expected_sync_length, pair_chain_bounds
from kruskal_markov.sync import (
    SyncAutomaton,
    greedy_synchronizing_word,
    shortest_synchronizing_word,
)


def random_automaton(rng, n, k):
    return generators.random_automaton(n, k, rng)


def contracting_automaton(rng, n, k=8):
    """Tray-like: every letter maps all states into a random eighth of them."""
    return SyncAutomaton.from_table(generators.contracting_table(n, k, rng))


def tray_like_support(rng, n, k=8, shrink=64, noise=0.02):
    """Stand-in for a built tray model: the set-valued support automaton of
    :func:`kruskal_markov.generators.set_valued_tray_model`."""
    from kruskal_markov.sync import support_automaton

    return support_automaton(generators.set_valued_tray_model(n, k, shrink, noise, rng))


def _warm_up():
    rng = np.random.default_rng(0)
    a = random_automaton(rng, 40, 2)
    shortest_synchronizing_word(a)
    greedy_synchronizing_word(a)
    expected_sync_length(SyncAutomaton.from_table([[1, 2, 0], [0, 1, 0]]), runs=10)
    b = SyncAutomaton.from_table([[1, 2, 0], [0, 1, 0]])
    pair_chain_bounds(b)


def main() -> None:
    t0 = time.perf_counter()
    _warm_up()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"(numba warm-up {time.perf_counter() - t0:.1f} s, excluded from the times below; "
          f"1-minute load average at start {load:.2f} on {os.cpu_count()} cores -- times are wall clock "
          f"and inflate on a shared machine)")
    rows = []
    cases = [
        ("random binary", 100, 2, random_automaton, 3, "0.03-0.1 s"),
        ("random binary", 150, 2, random_automaton, 3, "~0.15 s"),
        ("random binary", 200, 2, random_automaton, 3, "0.6-1.6 s"),
        ("random 8-letter", 50, 8, random_automaton, 3, "~0.07 s"),
        ("random 8-letter", 100, 8, random_automaton, 3, "12-16 s"),
        ("tray-like contracting", 256, 8, contracting_automaton, 3, "0.3-0.45 s"),
    ]
    for name, n, k, make, count, target in cases:
        rng = np.random.default_rng(1000 + n + k)
        times, lengths, exact = [], [], []
        for _ in range(count):
            aut = make(rng, n, k)
            t = time.perf_counter()
            res = shortest_synchronizing_word(aut, time_budget=300.0)
            times.append(time.perf_counter() - t)
            lengths.append(res.length)
            exact.append(res.exact)
        rows.append((name, n, k, ",".join(str(x) for x in lengths), all(exact),
                     statistics.median(times), target + "  (per instance: "
                     + ", ".join(f"{x:.2f}" for x in times) + " s)"))
    # random contracting n = 1024: greedy upper bound, then an exact attempt within a budget
    rng = np.random.default_rng(2024)
    aut = contracting_automaton(rng, 1024, 8)
    t = time.perf_counter()
    word = greedy_synchronizing_word(aut)
    rows.append(("contracting greedy (Eppstein)", 1024, 8, str(len(word)), False, time.perf_counter() - t,
                 "<= 1 s"))
    t = time.perf_counter()
    res = shortest_synchronizing_word(aut, time_budget=30.0)
    rows.append((f"contracting exact, 30 s budget (lower bound {res.lower_bound})", 1024, 8, str(res.length),
                 res.exact, time.perf_counter() - t, "C++ did not finish in 210 s"))
    rng = np.random.default_rng(77)
    aut = tray_like_support(rng, 3000)
    t = time.perf_counter()
    res = shortest_synchronizing_word(aut, time_budget=60.0)
    rows.append(("tray-like support automaton (set-valued), 2% splits", 3000, 8, str(res.length), res.exact,
                 time.perf_counter() - t, "allen-key model target <= 10 s"))
    print(f"{'case':<52} {'n':>5} {'k':>2} {'length':>12} {'exact':>6} {'seconds':>9}  target (C++)")
    for name, n, k, length, ex, sec, target in rows:
        print(f"{name:<52} {n:>5} {k:>2} {length:>12} {ex!s:>6} {sec:>9.3f}  {target}", flush=True)
    # pair-chain bounds on 3,000 states
    rng = np.random.default_rng(3000)
    aut = contracting_automaton(rng, 3000, 8)
    t = time.perf_counter()
    pb = pair_chain_bounds(aut, time_budget=50.0)
    sec = time.perf_counter() - t
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"pair-chain bounds, tray-like contracting n=3000 k=8: lower {pb['lower']:.1f}, upper {pb['upper']:.1f}, "
          f"{pb['pairs']} reachable pairs, {pb['iterations']} iterations, arrays {pb['memory_mb']:.0f} MB, "
          f"process peak RSS {peak:.0f} MB, {sec:.1f} s (target <= 60 s)")
    cli_budgets()


def _budgeted_run(n, command, budget_args):
    """``kruskal COMMAND`` on a seeded random binary automaton of ``n`` states in a child process:
    (JSON result, wall seconds, peak resident MB of the child)."""
    import json
    import subprocess
    import sys
    import tempfile

    rng = np.random.default_rng(1)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, f"random{n}.json")
        with open(path, "w") as fh:
            json.dump({"states": n, "actions": {"a": rng.integers(0, n, n).tolist(),
                                               "b": rng.integers(0, n, n).tolist()}}, fh)
        t = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "analysis", command, "--automaton", path, "--json",
                               *budget_args], capture_output=True, text=True, timeout=600)
        wall = time.perf_counter() - t
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-2000:])
    peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    return json.loads(proc.stdout), wall, peak_mb


def cli_budgets() -> None:
    """Wall time and memory of ``kruskal sync`` / ``convergence`` on large random automata against
    their time budgets (moved here from the tests: a test must not depend on the machine's speed).
    Target: within twice the budget plus the interpreter's start, and under 4 GB."""
    for n, budget in ((3000, 3.0), (20000, 20.0)):
        for command, args in (("sync", ["--time-budget", str(budget)]),
                              ("convergence", ["--pair-time-budget", str(budget), "--mc-time-budget", str(budget),
                                               "--max-subsets", "20000"])):
            res, wall, peak = _budgeted_run(n, command, args)
            ok = wall < 2 * budget + 10 and peak < 4096
            print(f"{command} n={n} budget {budget:g} s: {wall:.1f} s wall, peak RSS {peak:.0f} MB "
                  f"({'within' if ok else 'OVER'} 2 x budget + 10 s and 4 GB)", flush=True)


if __name__ == "__main__":
    main()
