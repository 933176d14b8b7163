"""Plan benchmark (issue 29): exact shortest reset words where the memory budget used to end the
search, and the three plan targets on the allen key's default model.

1. Random automata of 100 states / 8 letters and 200 states / 2 letters (the generator and seeds of
   ``bench_sync``): before the depth-first phase, ``sync`` stopped at its 2 GB memory budget and
   returned greedy words of 23-24 against exact 13-14. Reported: length, exact, method, seconds.
2. The allen key's default model (``kruskal build --shape allen-key``; cached after the first build,
   which takes 10-15 minutes on one core; ``KRUSKAL_KEY_MODEL=PATH`` uses a given model): targets
   ``state``, ``cell`` and ``probability:0.001`` -- plan, length, proof (exact / lower bound), time.

Times are wall clock after a Numba warm-up, on a shared machine; the answers (lengths, proofs) do
not depend on the machine because the budgets are node budgets, except where a time budget is named.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np

from kruskal_markov.sync import SyncAutomaton, random_word_success, shortest_plan, shortest_synchronizing_word

#: exact search budgets of the key-model runs
KEY_NODE_BUDGET = int(os.environ.get("KRUSKAL_PLAN_NODES", 30_000_000))
KEY_TIME_BUDGET = float(os.environ.get("KRUSKAL_PLAN_SECONDS", 600))


def random_automaton(rng, n, k):
    return SyncAutomaton.from_table(rng.integers(0, n, size=(k, n)))


def random_cases(count=3, time_budget=600.0):
    rows = []
    for n, k in ((100, 8), (200, 2)):
        rng = np.random.default_rng(1000 + n + k)          # the instances of bench_sync
        for i in range(count):
            aut = random_automaton(rng, n, k)
            t = time.perf_counter()
            res = shortest_synchronizing_word(aut, time_budget=time_budget)
            rows.append({"case": f"random n={n} k={k} #{i}", "length": res.length, "exact": res.exact,
                         "lower_bound": res.lower_bound, "method": res.method,
                         "subsets": res.states_explored, "seconds": time.perf_counter() - t})
            print(json.dumps(rows[-1]), flush=True)
    return rows


def key_model_path():
    path = os.environ.get("KRUSKAL_KEY_MODEL")
    if path:
        return path
    out = subprocess.run([sys.executable, "-m", "analysis", "build", "--shape", "allen-key", "--workers", "1",
                          "--json"], capture_output=True, text=True, check=True)
    return json.loads(out.stdout)["model"]


def key_cases(path, targets=("cell", "probability:0.001", "state")):
    from kruskal_markov.model import TransitionModel

    model = TransitionModel.load(path)
    rows = []
    for target in targets:
        t = time.perf_counter()
        res = shortest_plan(model, target, node_budget=KEY_NODE_BUDGET, time_budget=KEY_TIME_BUDGET)
        row = {"case": f"allen key {target}", **res.to_dict(), "wall_seconds": time.perf_counter() - t}
        rows.append(row)
        print(json.dumps(row), flush=True)
    # how rare are good plans: random words of length 1..50 from the model (5,000 words, seed 29)
    for target in targets:
        t = time.perf_counter()
        rw = random_word_success(model, target, max_length=50, words=5000, seed=29)
        p = rw["probability"]
        print(json.dumps({"case": f"allen key random words {target}", "seconds": time.perf_counter() - t,
                          "probability_at": {L: p[L] for L in (8, 11, 12, 15, 20, 30, 40, 50)}}), flush=True)
    return rows


def main() -> None:
    t0 = time.perf_counter()
    shortest_synchronizing_word(SyncAutomaton.from_table(np.random.default_rng(0).integers(0, 40, (2, 40))))
    shortest_plan(_cerny4_model(), "probability:0.2")
    print(f"(numba warm-up {time.perf_counter() - t0:.1f} s; 1-minute load {os.getloadavg()[0]:.2f} on "
          f"{os.cpu_count()} cores)", flush=True)
    random_cases()
    key_cases(key_model_path())


def _cerny4_model():
    from kruskal_markov.automaton_json import model_from_automaton

    return model_from_automaton({"states": 4, "actions": {"a": [1, 2, 3, 0], "b": [0, 1, 2, 0]}})


if __name__ == "__main__":
    main()
