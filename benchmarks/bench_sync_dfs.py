"""Where the time of ruling out one length goes in the exact reset-word search's inverse
depth-first phase (issue 43, random 8 x 200): counts and CPU by kernel, length by length.

The search is :func:`kruskal_markov.sync.exact._exact_search` on one benchmark instance
(:mod:`benchmarks.bench_sync_record`'s generator), with ``upper`` the beam's word (20 on random
8 x 200 seeds 1 and 2; the beam is skipped here, it finds that word in 0.06 s) and a 4,000 MB memory
budget, so that the breadth-first stores fill and the deepening phase tests one length at a time.
The kernels the phase calls are wrapped with timers (CPU time by ``time.process_time``, so run it
on one core): the preimage expansion with its duplicate removal (``SubsetStore.expand`` in the
phase's fresh stores), the meet test against the forward trie (``_trie.superset_mask``), the
set sizes (``_level_sizes``); the rest of the phase is Python and array copies. Counted per
length ruled out: preimages generated (``k`` per expanded set), kept after duplicate removal (the
store hits are the difference), queries to the trie and their sizes against the forward level's
smallest set, hits. ``--dominance-sample N`` also measures, on every ``N``-th expanded level,
how many of the new level's sets are a proper subset of another set of the same level (the
self-dominance of Kisielewicz, Kowalski and Szykula 2015 / synchrowords' ``reduce``) and what the
check costs -- measured, not used.

Usage (from the worktree root): ``python -m benchmarks.bench_sync_dfs [--seed S] [--budget SEC]
[--upper U] [--dominance-sample N] [--options k=v,...]``; ``--compare [--seed S] [--share D]``:
the phase's designs one by one on the same stores (:func:`run_compare`; ``--round 7``: this
round's, :data:`COMPARE7`; ``--third-share D3``: length ``total + 3`` too, on ``1 / D3`` of the level); ``python -m benchmarks sync_dfs`` runs
seed 1 with a 240 s budget. Prints; stores nothing.
"""
from __future__ import annotations

import resource
import sys
import time
from collections import defaultdict

import numpy as np

from benchmarks.bench_sync_record import instance_table
from kruskal_markov import _subsets
from kruskal_markov.sync import ExactSearchOptions, SyncAutomaton, _trie, exact


class _Profile:
    """Counters and kernel timers of one search, split at each length the phase rules out."""

    def __init__(self, dominance_sample=0):
        self.phase = "bfs"
        self.depth = 0
        self.dominance_sample = dominance_sample
        self.expands = 0
        self.rows = []
        self.reset()
        self.t0, self.c0 = time.perf_counter(), time.process_time()
        self.mark = (self.t0, self.c0)

    def reset(self):
        self.cpu = defaultdict(float)
        self.n = defaultdict(int)
        self.by_depth = defaultdict(lambda: [0, 0, 0, 0])     # expanded, generated, kept, queried
        self.dom = defaultdict(lambda: [0, 0, 0.0])            # sets checked, dominated, cpu

    def close(self, label):
        now, cnow = time.perf_counter(), time.process_time()
        row = {"label": label, "wall": now - self.mark[0], "cpu": cnow - self.mark[1],
               "at": now - self.t0, "cpu_by": dict(self.cpu), "n": dict(self.n),
               "by_depth": {d: list(v) for d, v in sorted(self.by_depth.items())},
               "dom": {d: list(v) for d, v in sorted(self.dom.items())}}
        self.rows.append(row)
        self.mark = (now, cnow)
        self.reset()
        return row


def _patch(prof: _Profile, fmin: list):
    """Wrap the kernels the depth-first phase calls; returns a function undoing it."""
    orig_store, orig_mask, orig_sizes, orig_descend = exact.SubsetStore, _trie.superset_mask, \
        exact._k._level_sizes, exact._descend

    class TimedStore(_subsets.SubsetStore):
        def expand(self, aut, forward, tasks=1):
            if prof.phase != "dfs":
                return super().expand(aut, forward, tasks)
            lo, hi = self.levels[-1]
            c = time.process_time()
            grown = super().expand(aut, forward, tasks)
            prof.cpu["expand"] += time.process_time() - c
            d = prof.by_depth[prof.depth]
            d[0] += hi - lo
            d[1] += aut.k * (hi - lo)
            d[2] += grown or 0
            prof.expands += 1
            if prof.dominance_sample and grown and prof.expands % prof.dominance_sample == 0:
                lo2, hi2 = self.levels[-1]
                c = time.process_time()
                dom = _trie.subset_mask(self.rows[lo2:hi2], self.rows[lo2:hi2], aut.n, proper=True, tasks=1)
                e = prof.dom[prof.depth]
                e[0] += hi2 - lo2
                e[1] += int(dom.sum())
                e[2] += time.process_time() - c
            return grown

    def mask(stored, query, *args, **kw):
        c = time.process_time()
        out = orig_mask(stored, query, *args, **kw)
        if prof.phase == "dfs":
            prof.cpu["meet-trie"] += time.process_time() - c
            prof.n["queries"] += query.shape[0]
            prof.n["hits"] += int(out.sum())
            if fmin:
                prof.n["queries-below-min-forward"] += int(
                    (exact._k._level_sizes(query, 0, query.shape[0]) < fmin[0]).sum())
            prof.by_depth[prof.depth][3] += query.shape[0]
        return out

    def sizes(rows, lo, hi):
        c = time.process_time()
        out = orig_sizes(rows, lo, hi)
        if prof.phase == "dfs":
            prof.cpu["set-sizes"] += time.process_time() - c
        return out

    def descend(rec, aut, cap, forward, used, rows, rid, words, x, split=None, x_child=None, emit=None):
        prof.depth = x + 1 if x_child is None else x_child
        return orig_descend(rec, aut, cap, forward, used, rows, rid, words, x, split=split, x_child=x_child, emit=emit)

    orig_images = exact._k.level_images

    def images(rows, lo, hi, *args, **kw):
        c = time.process_time()
        out = orig_images(rows, lo, hi, *args, **kw)
        if prof.phase == "dfs":
            prof.cpu["leaf-images"] += time.process_time() - c
            prof.n["leaf preimages"] += out.shape[0]
        return out

    exact.SubsetStore, _trie.superset_mask, exact._k._level_sizes, exact._descend = TimedStore, mask, sizes, descend
    exact._k.level_images = images

    def undo():
        exact.SubsetStore, _trie.superset_mask, exact._k._level_sizes, exact._descend = \
            orig_store, orig_mask, orig_sizes, orig_descend
        exact._k.level_images = orig_images
    return undo


def _print_row(row):
    cpu = row["cpu"]
    kern = sum(row["cpu_by"].values())
    parts = ", ".join(f"{k} {v:.1f} s ({v / max(cpu, 1e-9):.0%})" for k, v in sorted(row["cpu_by"].items()))
    print(f"== {row['label']}: {row['wall']:.1f} s wall, {cpu:.1f} s CPU (at {row['at']:.1f} s): {parts}, "
          f"other (Python, copies) {cpu - kern:.1f} s ({(cpu - kern) / max(cpu, 1e-9):.0%})", flush=True)
    n = row["n"]
    if n:
        print(f"   trie queries {n.get('queries', 0):,}, hits {n.get('hits', 0):,}, queries smaller than the "
              f"smallest forward set {n.get('queries-below-min-forward', 0):,}, deepest-level preimages generated "
              f"unstored {n.get('leaf preimages', 0):,}", flush=True)
    for d, (exp, gen, kept, q) in row["by_depth"].items():
        print(f"   depth {d}: sets expanded {exp:,}, preimages {gen:,}, kept {kept:,} "
              f"({kept / max(gen, 1):.1%}; store hits {gen - kept:,}), queried {q:,}", flush=True)
    for d, (m, dom, c) in row["dom"].items():
        print(f"   dominance sample depth {d}: {dom:,} of {m:,} sets a proper subset of another of their level "
              f"({dom / max(m, 1):.1%}), {c:.2f} s CPU ({1e6 * c / max(m, 1):.2f} us a set)", flush=True)


def run_profile(seed=1, budget=240.0, upper=20, memory_mb=4000.0, dominance_sample=0, options=None):
    """Profile one search of random 8 x 200 ``seed`` (see the module docstring)."""
    aut = SyncAutomaton.from_table(instance_table("random", 8, 200, seed))
    exact._exact_search(SyncAutomaton.from_table(instance_table("random", 8, 30, 1)), np.arange(30), 5.0, 50.0,
                        upper=40)       # compile the kernels first
    prof = _Profile(dominance_sample)
    fmin = []

    def observe(event, value):
        now = time.perf_counter()
        if event == "depth-first":
            _print_row(prof.close(f"breadth-first phase (total {value} met)"))
            prof.phase = "dfs"
            print(f"   store bytes: forward {srch_bytes('fwd'):,}, backward {srch_bytes('bwd'):,}; "
                  f"peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB", flush=True)
        elif event == "deepened":
            _print_row(prof.close(f"length {value} ruled out"))
        elif event in ("forward-level", "backward-level", "meet"):
            print(f"  {now - prof.t0:8.1f} s  {event} {value}", flush=True)

    stores = {}

    class Bi(exact._Bidirectional):
        def __init__(self, *a, **kw):
            super().__init__(*a, **kw)
            stores["fwd"], stores["bwd"] = self.fwd, self.bwd

        def _depth_first(self):
            flo, fhi = self.fwd.levels[-1]
            fmin.append(int(exact._k._level_sizes(self.fwd.rows, flo, fhi).min()))
            print(f"   newest forward level: {fhi - flo:,} sets, smallest {fmin[0]} states; newest backward "
                  f"level {self.bwd.levels[-1][1] - self.bwd.levels[-1][0]:,} sets", flush=True)
            return super()._depth_first()

    def srch_bytes(name):
        return int(stores[name].nbytes()) if hasattr(stores[name], "nbytes") else -1

    opts = ExactSearchOptions(observe=observe, use_beam=False, **(options or {})).resolved()
    print(f"random-8-200-s{seed}: upper {upper}, time budget {budget:g} s, memory {memory_mb:g} MB, "
          f"threads {opts.threads}, options {options or {}}", flush=True)
    undo = _patch(prof, fmin)
    orig_bi = exact._Bidirectional
    exact._Bidirectional = Bi
    try:
        word, status, explored, lower = exact._exact_search(aut, np.arange(aut.n), budget, memory_mb, None, upper,
                                                            options=opts)
    finally:
        undo()
        exact._Bidirectional = orig_bi
    _print_row(prof.close(f"at the stop ({status})"))
    print(f"=> status {status}, word {None if word is None else len(word)}, lower bound {lower}, sets {explored:,}, "
          f"{time.perf_counter() - prof.t0:.1f} s, peak RSS "
          f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB", flush=True)
    return prof.rows


#: the designs ``--compare`` runs on the same stores: (name, options)
COMPARE = (
    ("last round (stored leaves, natural order)", {"relabel_rows": None, "leaf_images": False}),
    ("relabelled by frequency", {"relabel_rows": 1, "leaf_images": False}),
    ("unstored leaves", {"relabel_rows": None, "leaf_images": True, "leaf_batch": None}),
    ("both", {"relabel_rows": 1, "leaf_images": True, "leaf_batch": None}),
    ("both, two processes (on one core: overhead only)", {"relabel_rows": 1, "leaf_images": True, "leaf_batch": None,
                                                          "parallel": True, "fork_rows": 1}),
)

#: the seventh round's designs (``--compare --round 7``): the deepest level's test, one change at a time
COMPARE7 = (
    ("last round (26 + 27: per-slice walk by indices)", {"relabel_rows": 1, "leaf_batch": None}),
    ("30 batched, rows moved (size filter only)", {"relabel_rows": 1, "count_blocks": None}),
    ("30 + 31 count filter (6 blocks)", {"relabel_rows": 1}),
)


def breadth_first_stores(seed, memory_mb, upper):
    """Random 8 x 200 automaton ``seed`` searched up to the inverse depth-first phase, which is
    not run: ``(automaton, forward store, backward store, total, cache, seconds)``, the forward
    level sorted for the phase (the Numba kernels compiled first on a small instance)."""
    aut = SyncAutomaton.from_table(instance_table("random", 8, 200, seed))
    exact._exact_search(SyncAutomaton.from_table(instance_table("random", 8, 30, 1)), np.arange(30), 5.0, 50.0,
                        upper=40)
    got = {}

    class Bi(exact._Bidirectional):
        def _depth_first(self):
            got.update(fwd=self.fwd, bwd=self.bwd, total=self.total, cache=self.cache)
            return None, "budget", self.count, self.total + 1

    t0 = time.perf_counter()
    orig = exact._Bidirectional
    exact._Bidirectional = Bi
    try:
        exact._exact_search(aut, np.arange(aut.n), None, memory_mb, None, upper)
    finally:
        exact._Bidirectional = orig
    fwd, bwd, total, cache = got["fwd"], got["bwd"], got["total"], got["cache"]
    exact._sorted_forward(fwd, cache)
    return aut, fwd, bwd, total, cache, time.perf_counter() - t0


def run_compare(seed=1, upper=20, memory_mb=4000.0, share=16, designs=COMPARE, third_share=None):
    """Each design of :data:`COMPARE` measured alone on the same breadth-first stores (grown once,
    up to the inverse depth-first phase): its set-up (the forward trie relabelled, when it is),
    length ``total + 1`` ruled out over the whole newest backward level, then length ``total + 2``
    over its first ``1 / share`` (a fixed sample of the chunks); sets generated and CPU (this
    process and a forked child) of each. Every design starts from its own copy of the
    breadth-first phase's sorted forward level. With ``third_share``, length ``total + 3`` too, over
    the first ``1 / third_share`` of the level."""
    import types

    from benchmarks.bench_sync_record import _child_cpu

    aut, fwd, bwd, total, cache, seconds = breadth_first_stores(seed, memory_mb, upper)
    blo, bhi = bwd.levels[-1]
    print(f"random-8-200-s{seed}: breadth-first phase to total {total} in {seconds:.1f} s; "
          f"newest backward level {bhi - blo:,} sets; length {total + 2} on its first 1/{share}", flush=True)

    def part(d):
        return types.SimpleNamespace(rows=bwd.rows, levels=bwd.levels[:-1] + [(blo, blo + (bhi - blo) // d)],
                                     count=bwd.count, path=bwd.path)

    runs = [(total + 1, bwd, 1), (total + 2, part(share), share)]
    if third_share:
        runs.append((total + 3, part(third_share), third_share))

    def clock():
        return time.perf_counter(), time.process_time() + _child_cpu()

    for name, extra in designs:
        opts = ExactSearchOptions(**({"parallel": False} | extra)).resolved()
        own = {"level": cache["level"], "rows": cache["rows"].copy(), "split": cache["split"]}
        (t, c) = clock()
        dfs = exact._InverseDepthFirst(aut, fwd, bwd, None, None, memory_mb / 4, opts, time.perf_counter, own)
        (t1, c1) = clock()
        print(f"  {name:52s} set-up {c1 - c:.1f} s CPU", flush=True)
        for length, store, d in runs:
            dfs.bwd, dfs.used = store, [0]
            res = dfs.run(length - total, length - total)
            (t2, c2) = clock()
            print(f"  {name:52s} length {length}{'' if d == 1 else f' (1/{d})'}: "
                  f"{'ruled out' if res is None else res}, sets {dfs.used[0]:,}, {c2 - c1:.1f} s CPU, "
                  f"{t2 - t1:.1f} s wall", flush=True)
            (t1, c1) = (t2, c2)
        del dfs, own


def _parse_options(text):
    out = {}
    for item in filter(None, text.split(",")):
        k, v = item.split("=")
        out[k] = {"true": True, "false": False, "none": None}.get(v.lower(), None) if v.lower() in (
            "true", "false", "none") else (int(v) if v.lstrip("-").isdigit() else float(v))
    return out


def main(argv=()) -> None:
    argv = list(argv)

    def arg(name, default, conv):
        return conv(argv[argv.index(name) + 1]) if name in argv else default

    if "--compare" in argv:
        seventh = arg("--round", 6, int) == 7
        run_compare(seed=arg("--seed", 1, int), share=arg("--share", 16, int),
                    designs=COMPARE7 if seventh else COMPARE, third_share=arg("--third-share", None, int))
        return
    run_profile(seed=arg("--seed", 1, int), budget=arg("--budget", 240.0, float), upper=arg("--upper", 20, int),
                memory_mb=arg("--memory-mb", 4000.0, float), dominance_sample=arg("--dominance-sample", 0, int),
                options=arg("--options", None, _parse_options))


if __name__ == "__main__":
    main(sys.argv[1:])
