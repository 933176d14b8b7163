"""The cost of the answers' intervals: ``kruskal ensemble`` with its defaults beside ``--draws 0
--structural-delta 0``, side by side in one run (issue 45: default within 1.2x).

Two 2,000-state, 8-letter models:

* ``automaton`` — a deterministic automaton given as JSON (every letter maps the states into its own
  eighth of them): not sampled, so by default it has no posterior and no structural term;
* ``sampled`` — a stochastic model shaped like a built one (:func:`kruskal_markov.generators.tray_like_model`'s
  supports, 64 report cells) whose rows are sample counts / total, with build metadata: by default
  20 posterior draws and the default structural term.

Each configuration runs ``python -m analysis ensemble --count K --length 50 --json`` in-process,
alternating, best of ``INTERVALS_REPEATS`` (default 2). ``INTERVALS_COUNT`` overrides K (default 10^5).
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import tempfile
import time

import numpy as np
import scipy.sparse as sp


def automaton_json(n=2000, k=8, seed=0) -> dict:
    """A random deterministic automaton: letter ``a`` maps every state into its own eighth of the states."""
    rng = np.random.default_rng(seed)
    return {"states": n, "actions": {f"a{i}": rng.choice(rng.choice(n, n // 8, replace=False), n).tolist()
                                     for i in range(k)}}


def sampled_model(n=2000, k=8, nnz=5, cells=64, seed=0):
    """A tray-like stochastic model whose rows are counts / total, carrying counts and build metadata."""
    from kruskal_markov.model import TransitionModel

    rng = np.random.default_rng(seed)
    mats, extras = [], {}
    for a in range(k):
        targets = rng.choice(n, size=n // 8, replace=False)
        cols = np.sort(targets[rng.integers(0, targets.size, size=(n, nnz))], axis=1)
        counts = 1 + rng.multinomial(15, np.full(nnz, 1.0 / nnz), size=n)
        m = sp.csr_matrix((counts.ravel().astype(float), (np.repeat(np.arange(n), nnz), cols.ravel())), shape=(n, n))
        m.sum_duplicates()
        m.sort_indices()
        extras[f"counts_{a}"] = m.data.astype(np.int64)
        tot = np.asarray(m.sum(1)).ravel()
        mats.append(sp.csr_matrix((m.data / np.repeat(tot, np.diff(m.indptr)), m.indices, m.indptr), shape=(n, n)))
    md = {"kind": "kruskal.built_model", "stats": {"states": n, "note": "synthetic benchmark model"}}
    return TransitionModel([f"a{i}" for i in range(k)], mats, initial=np.full(n, 1.0 / n),
                           partition=rng.integers(0, cells, n), n_cells=cells, metadata=md, extras=extras)


def _run(argv) -> tuple[float, dict]:
    from analysis.cli import main

    buf = io.StringIO()
    t = time.perf_counter()
    with contextlib.redirect_stdout(buf):
        rc = main(argv)
    dt = time.perf_counter() - t
    if rc != 0:
        raise RuntimeError(f"{argv} exited {rc}")
    return dt, json.loads(buf.getvalue())


def main() -> None:
    count = int(os.environ.get("INTERVALS_COUNT", 100_000))
    repeats = int(os.environ.get("INTERVALS_REPEATS", 2))
    with tempfile.TemporaryDirectory() as d:
        aut = os.path.join(d, "automaton.json")
        with open(aut, "w") as fh:
            json.dump(automaton_json(), fh)
        npz = os.path.join(d, "sampled.npz")
        sampled_model().save(npz)
        base = ["ensemble", "--count", str(count), "--length", "50", "--seed", "1", "--json"]
        warm = ["ensemble", "--count", "200", "--length", "50", "--json"]
        for src in (["--automaton", aut], ["--model", npz]):          # compile and warm the kernels
            _run(warm + src)
            _run(warm + src + ["--draws", "0", "--structural-delta", "0"])
        print(f"ensemble {count} x 50 on 2,000 states, 8 letters; best of {repeats} (seconds)")
        print("model      | defaults | --draws 0 --structural-delta 0 | ratio | structural term (default)")
        for name, src in (("automaton", ["--automaton", aut]), ("sampled", ["--model", npz])):
            t_def, t_off = [], []
            for _ in range(repeats):
                dt, out = _run(base + src)
                t_def.append(dt)
                t_off.append(_run(base + src + ["--draws", "0", "--structural-delta", "0"])[0])
            st = out["intervals"]["settings"]
            print(f"{name:10s} | {min(t_def):8.2f} | {min(t_off):30.2f} | {min(t_def) / min(t_off):5.2f} | "
                  f"{st['structural_source']} delta {st['structural_delta']:g}, {st['draws']} draws")


if __name__ == "__main__":
    main()
