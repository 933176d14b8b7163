"""What the deepest level's test costs in the exact reset-word search's inverse depth-first phase,
and what each cheaper test buys (issue 43, seventh round; random 8 x 200).

The breadth-first stores of random 8 x 200 ``seed`` are grown as the search grows them (beam
skipped, upper bound 20, 4,000 MB), the phase is set up (relabelled, sync/_relabel), and every
``share``-th chunk of the newest backward level is grown two levels down (stored, as the search
does); the preimages at the third level -- the sets whose test rules out length ``total + 3``
(length 18 on seeds 1, 2, 5, 6) -- are generated and tested by the search's present test (its
CPU and counts printed), and those at least as large as the smallest forward set are kept in
memory. On them, one thread, CPU by ``time.process_time`` (run it on one core):

- their sizes against the forward sets', and how many are duplicates;
- the trie walk by indices (:func:`kruskal_markov.sync._trie.superset_mask`) in batches of
  40,000 / 150,000 / 600,000 rows and in one batch, and the walk with rows moved
  (:mod:`kruskal_markov.sync._rowtrie`) in the same batches;
- the per-block count filter (:mod:`kruskal_markov.sync._countfilter`) with 2 to 6 blocks: the
  share it keeps and the walk on the rest;
- the forward sets split into tries by size (:mod:`kruskal_markov.sync._sizetrie`, not used by
  the search: measured slower).

Usage (from the worktree root): ``python -m benchmarks.bench_sync_leaves [--seed S] [--share D]``
(default seed 6, every 64th chunk). Prints; stores nothing.
"""
from __future__ import annotations

import sys
import time

import numpy as np

from benchmarks.bench_sync_dfs import breadth_first_stores
from kruskal_markov import _sync_kernels as _k
from kruskal_markov.sync import ExactSearchOptions, _countfilter, _rowtrie, _sizetrie, _trie, exact


def collect(seed: int, share: int):
    """The relabelled forward trie, its size split and the sampled deepest-level preimages that
    pass the size filter (see the module docstring)."""
    aut, fwd, bwd, total, cache, seconds = breadth_first_stores(seed, 4000.0, 20)
    print(f"random-8-200-s{seed}: breadth-first phase to total {total} in {seconds:.1f} s",
          flush=True)
    opts = ExactSearchOptions(parallel=False, leaf_batch=None).resolved()
    c0 = time.process_time()
    dfs = exact._InverseDepthFirst(aut, fwd, bwd, None, None, 1000.0, opts, time.perf_counter, cache)
    print(f"  set-up (relabelling, count filter) {time.process_time() - c0:.1f} s CPU; forward trie "
          f"{dfs.fsorted.shape[0]:,} sets, smallest {dfs.fsplit.min_size} states", flush=True)
    kept, st = [], {"pre": 0, "pass": 0, "gen": 0.0, "test": 0.0, "depth2": 0}
    inv_ptr, inv_idx, supcount = dfs.aut.inverse

    def leaves(rows, rid, words, x):
        st["depth2"] += rows.shape[0]
        c = time.process_time()
        pre = _k.level_images(rows, 0, rows.shape[0], dfs.aut.delta, dfs.aut.step_table(False), True, False,
                              inv_ptr, inv_idx, supcount, tasks=1)
        c1 = time.process_time()
        st["gen"] += c1 - c
        for lo in range(0, pre.shape[0], 1 << 20):         # the search's slices of a million preimages
            if _trie.superset_mask(dfs.fsorted, pre[lo:lo + (1 << 20)], sorted_stored=True, tasks=1,
                                   split=dfs.fsplit).any():
                raise RuntimeError("a hit: this length is not ruled out on this seed")
        st["test"] += time.process_time() - c1
        keep = _k._level_sizes(pre, 0, pre.shape[0]) >= dfs.fsplit.min_size
        st["pre"] += pre.shape[0]
        st["pass"] += int(keep.sum())
        kept.append(pre[keep])
        return None

    dfs.leaves = leaves
    dfs.limit, dfs.test_from = 3, 3
    blo, bhi = bwd.levels[-1]
    starts = range(blo, bhi, opts.dfs_chunk)
    c0 = time.process_time()
    for lo in starts[::share]:
        dfs.chunk(lo)
    print(f"  length {total + 3}, every {share}th chunk ({len(starts[::share])} of {len(starts)}): depth-2 sets "
          f"{st['depth2']:,}, preimages {st['pre']:,}, at least as large as the smallest forward set {st['pass']:,} "
          f"({st['pass'] / max(st['pre'], 1):.1%}); CPU {time.process_time() - c0:.1f} s, of it preimages "
          f"{st['gen']:.1f} s, the present test {st['test']:.1f} s", flush=True)
    return dfs.fsorted, dfs.fsplit, np.concatenate(kept)


def _timed(label, fn, Q, batch, n_total):
    c = time.process_time()
    hits = 0
    for lo in range(0, Q.shape[0], batch):
        hits += int(fn(Q[lo:lo + batch]).sum())
    t = time.process_time() - c
    print(f"  {label}: {t:.2f} s CPU, {1e6 * t / n_total:.2f} us a query, hits {hits}", flush=True)
    return t


def measure(F, split, Q):
    """The tests of the module docstring on the sampled queries ``Q`` (forward trie ``F``)."""
    qs, fs = _trie._row_sizes(Q), _trie._row_sizes(F)
    distinct = np.unique(Q, axis=0).shape[0]
    print(f"queries {Q.shape[0]:,} ({1 - distinct / Q.shape[0]:.1%} duplicates); sizes by quartile "
          f"{np.percentile(qs, [25, 50, 75, 99]).tolist()}; forward sets' {np.percentile(fs, [1, 25, 50, 75]).tolist()}",
          flush=True)
    _trie.superset_mask(F, Q[:1000], sorted_stored=True, tasks=1, split=split)
    _rowtrie.superset_mask_rows(F, Q[:1000], split)
    n = Q.shape[0]
    for batch in (40_000, 150_000, 600_000, n):
        _timed(f"walk by indices, batches of {batch:,}", lambda q: _trie.superset_mask(
            F, q, sorted_stored=True, tasks=1, split=split), Q, batch, n)
        _timed(f"walk with rows moved, batches of {batch:,}", lambda q: _rowtrie.superset_mask_rows(F, q, split),
               Q, batch, n)
    for blocks in (2, 3, 4, 5, 6):
        c = time.process_time()
        cf = _countfilter.CountFilter(F, 200, blocks)
        tb = time.process_time() - c
        c = time.process_time()
        keep = cf.keep(Q)
        tk = time.process_time() - c
        print(f"  count filter, {cf.blocks} blocks (table {cf.table.size:,} bytes, built in {tb:.1f} s): keeps "
              f"{keep.mean():.1%}, {1e9 * tk / n:.0f} ns a query", flush=True)
        _timed(f"  then rows moved, batches of 600,000 (+{1e6 * tk / n:.2f} us filter)",
               lambda q: _rowtrie.superset_mask_rows(F, q, split), Q[keep], 600_000, n)
    for first, growth in ((1 << 12, 1.0), (1 << 16, 4.0), (1 << 18, 4.0), (1 << 20, 8.0)):
        edges = _sizetrie.bucket_edges(fs, first, growth)
        sb = _sizetrie.SizeBuckets(F[_sizetrie.order_by_buckets(F, edges, lex_sorted=True)], edges)
        _timed(f"tries by size, edges {edges.tolist()}, batches of 600,000", sb.superset_mask, Q, 600_000, n)
        del sb


def main(argv=()) -> None:
    argv = list(argv)

    def arg(name, default):
        return int(argv[argv.index(name) + 1]) if name in argv else default

    F, split, Q = collect(arg("--seed", 6), arg("--share", 64))
    measure(F, split, Q)


if __name__ == "__main__":
    main(sys.argv[1:])
