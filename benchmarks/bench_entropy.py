"""Entropy engine benchmarks (issue 3, "Measure").

1. Synthetic tray-like model: 2,000 states, 8 actions, each action maps every state into about an
   eighth of the states with ~5 non-zeros per row; 10^5 random sequences x 50 steps with the Numba
   engine (its automatic choice, the image engine here, and the prefix trie), against a plain
   ``scipy.sparse`` loop (one sparse mat-vec plus numpy entropies per step and sequence) timed
   side by side in the same run on a subset and extrapolated.
2. Scale target: 10^6 random sequences x 50 steps on a tray-grid model that contracts like a
   real tray (walls and corners; near-deterministic rows), wall time and peak memory.

Run: ``python -m benchmarks entropy`` (or ``.venv/bin/python -m benchmarks.bench_entropy``);
``KRUSKAL_BENCH_QUICK=1`` runs 10x fewer sequences.
"""
from __future__ import annotations

import os
import resource
import sys
import time
import tracemalloc

import numpy as np
import scipy.sparse as sp


def tray_like_model(n=2000, k=8, nnz=5, cells=64, seed=0):
    """The shared generator :func:`kruskal_markov.generators.tray_like_model`."""
    from kruskal_markov.generators import tray_like_model as make

    return make(n, k, nnz, cells, seed)


def tray_grid_model(nx=16, ny=16, nt=16, noise=0.05, noisy_fraction=0.3, seed=0, grid=(4, 4, 4)):
    """A contracting tray-like model over ``nx * ny * nt`` pose voxels and the 8 tilts.

    A tilt slides the part to the wall (cardinal) or corner (diagonal) it points at; the free
    coordinate along a wall is kept; the orientation snaps to the nearest of 2-3 stable
    orientations of that wall/corner (random per action). In a random ``noisy_fraction`` of the
    rows, probability ``noise`` goes to a neighbouring outcome (second-nearest stable orientation,
    or the free coordinate +-1). The partition is the coarse ``grid`` (the report grid).
    """
    from kruskal_markov.model import TransitionModel

    rng = np.random.default_rng(seed)
    n = nx * ny * nt
    ix, iy, it = np.unravel_index(np.arange(n), (nx, ny, nt))
    dirs = [(0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1), (-1, 0), (-1, 1)]
    names = ["N", "NE", "E", "SE", "S", "SW", "W", "NW"]
    mats = []
    for dx, dy in dirs:
        stable = np.sort(rng.choice(nt, size=int(rng.integers(2, 4)), replace=False))
        jx = np.full(n, nx - 1) if dx > 0 else (np.zeros(n, int) if dx < 0 else ix)
        jy = np.full(n, ny - 1) if dy > 0 else (np.zeros(n, int) if dy < 0 else iy)
        dist = np.abs(it[:, None] - stable[None, :])
        dist = np.minimum(dist, nt - dist)
        rank = np.argsort(dist + 1e-3 * np.arange(stable.size)[None, :], axis=1)
        t1, t2 = stable[rank[:, 0]], stable[rank[:, 1]]
        main = np.ravel_multi_index((jx, jy, t1), (nx, ny, nt))
        rows, cols, probs = [], [], []
        noisy = rng.random(n) < noisy_fraction
        for i in range(n):
            if not noisy[i]:
                rows.append(i)
                cols.append(main[i])
                probs.append(1.0)
                continue
            alts = [np.ravel_multi_index((jx[i], jy[i], t2[i]), (nx, ny, nt))]
            if dx == 0:
                alts.append(np.ravel_multi_index((int(np.clip(jx[i] + rng.choice([-1, 1]), 0, nx - 1)), jy[i], t1[i]),
                                                 (nx, ny, nt)))
            if dy == 0:
                alts.append(np.ravel_multi_index((jx[i], int(np.clip(jy[i] + rng.choice([-1, 1]), 0, ny - 1)), t1[i]),
                                                 (nx, ny, nt)))
            rows.append(i)
            cols.append(main[i])
            probs.append(1.0 - noise)
            for c in alts:
                rows.append(i)
                cols.append(c)
                probs.append(noise / len(alts))
        mats.append(sp.csr_matrix((probs, (rows, cols)), shape=(n, n)))
    gx, gy, gt = grid
    part = np.ravel_multi_index((ix * gx // nx, iy * gy // ny, it * gt // nt), (gx, gy, gt))
    return TransitionModel(names, mats, partition=part, n_cells=gx * gy * gt)


def scipy_loop(model, seqs):
    """The plain baseline: per sequence and step one CSR mat-vec and numpy entropies."""
    mt = [m.T.tocsr() for m in model.matrices]
    part = model.partition
    out_c = np.empty((seqs.shape[0], seqs.shape[1] + 1))
    out_s = np.empty_like(out_c)

    def ent(p):
        nz = p[p > 0]
        return max(0.0, float(-(nz * np.log2(nz)).sum()))

    for s, seq in enumerate(seqs):
        p = model.initial.copy()
        out_c[s, 0] = ent(np.bincount(part, weights=p, minlength=model.n_cells))
        out_s[s, 0] = ent(p)
        for t, a in enumerate(seq):
            p = mt[a] @ p
            out_c[s, t + 1] = ent(np.bincount(part, weights=p, minlength=model.n_cells))
            out_s[s, t + 1] = ent(p)
    return out_c, out_s


def _maxrss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main(argv=None):
    import numba

    from kruskal_markov.entropy import batch_entropy

    argv = sys.argv[1:] if argv is None else argv
    quick = "--quick" in argv or os.environ.get("KRUSKAL_BENCH_QUICK") == "1"
    print(f"cores: {os.cpu_count()}, numba threads: {numba.get_num_threads()}, "
          f"load average: {os.getloadavg()[0]:.2f}", flush=True)

    # --- 1. tray-like 2,000-state model, 10^5 x 50, against the plain scipy loop -------------
    model = tray_like_model()
    rng = np.random.default_rng(1)
    s_count = 10_000 if quick else 100_000
    seqs = rng.integers(0, 8, size=(s_count, 50)).astype(np.uint8)
    batch_entropy(model, seqs[:64])  # compile / load the cached kernels
    batch_entropy(model, seqs[:64], share_prefixes=False, image_blocks=False)

    def timed(fn):
        w0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        return out, time.perf_counter() - w0, time.process_time() - c0

    from kruskal_markov.entropy import prefers_images

    batch_entropy(model, seqs[:512], method="images")
    batch_entropy(model, seqs[:512], method="trie")
    chosen = "images" if prefers_images(model, True) else "trie"
    res, t_engine, c_engine = timed(lambda: batch_entropy(model, seqs))
    _, t_trie, c_trie = timed(lambda: batch_entropy(model, seqs, method="trie"))
    res_plain, t_plain, c_plain = timed(lambda: batch_entropy(model, seqs, share_prefixes=False,
                                                              image_blocks=False))
    sub = 1_000 if quick else 2_000
    (ref_c, ref_s), t_sub, c_sub = timed(lambda: scipy_loop(model, seqs[:sub]))
    t_scipy, c_scipy = t_sub * s_count / sub, c_sub * s_count / sub
    err = max(np.abs(res.entropy_bits[:sub] - ref_c).max(), np.abs(res.entropy_bits_states[:sub] - ref_s).max())
    err_plain = np.abs(res.entropy_bits - res_plain.entropy_bits).max()
    nnz_row = np.mean([m.nnz / m.shape[0] for m in model.matrices])
    print(f"[tray-like n={model.n_states}, {nnz_row:.1f} nnz/row] {s_count} sequences x 50 steps "
          f"(wall s / process CPU s)")
    print(f"  numba engine, method auto (= {chosen}):      {t_engine:8.2f} / {c_engine:8.2f}")
    print(f"  numba engine, method trie (+ image blocks):  {t_trie:8.2f} / {c_trie:8.2f}")
    print(f"  numba, independent sequences, scatter only:  {t_plain:8.2f} / {c_plain:8.2f}")
    print(f"  plain scipy.sparse loop:                     {t_scipy:8.2f} / {c_scipy:8.2f}  (timed on {sub} "
          f"sequences: {t_sub:.2f} s, extrapolated x{s_count // sub})")
    print(f"  speed-up over scipy, wall: engine {t_scipy / t_engine:.1f}x, trie {t_scipy / t_trie:.1f}x, "
          f"independent {t_scipy / t_plain:.1f}x; CPU time (= single-core equivalent): engine "
          f"{c_scipy / c_engine:.1f}x, trie {c_scipy / c_trie:.1f}x")
    print(f"  max |engine - scipy| entropy on the subset: {err:.2e} bits; engine vs independent: {err_plain:.2e}")
    print(f"  max mass drift: {res.mass_drift.max():.2e}; load average now {os.getloadavg()[0]:.2f}", flush=True)
    del res, res_plain

    # --- 2. 10^6 x 50 on a contracting tray-grid model --------------------------------------
    model = tray_grid_model()
    s_count = 100_000 if quick else 1_000_000
    rng = np.random.default_rng(2)
    seqs = rng.integers(0, 8, size=(s_count, 50)).astype(np.uint8)
    batch_entropy(model, seqs[:64])
    tracemalloc.start()
    res, t_big, c_big = timed(lambda: batch_entropy(model, seqs))
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    nnz_row = np.mean([m.nnz / m.shape[0] for m in model.matrices])
    det = np.mean([np.mean(np.diff(m.indptr) == 1) for m in model.matrices])
    print(f"[tray-grid n={model.n_states}, {nnz_row:.2f} nnz/row, {100 * det:.0f}% point-mass rows, "
          f"report grid {model.n_cells} cells] {s_count} sequences x 50 steps")
    print(f"  numba engine: {t_big:.2f} s wall, {c_big:.2f} s process CPU "
          f"(load average now {os.getloadavg()[0]:.2f})")
    print(f"  peak traced numpy memory: {peak / 2**20:.0f} MiB; process max RSS: {_maxrss_mb():.0f} MiB")
    h = res.entropy_bits
    print(f"  mean entropy (report grid) at steps 0,1,2,5,10,50: "
          f"{', '.join(f'{h[:, t].mean():.3f}' for t in (0, 1, 2, 5, 10, 50))}")
    print(f"  max mass drift: {res.mass_drift.max():.2e}")
    del res, h
    sub = 2_000
    _, t_ind, _ = timed(lambda: batch_entropy(model, seqs[:sub * 10], share_prefixes=False, image_blocks=False))
    _, t_sc, _ = timed(lambda: scipy_loop(model, seqs[:sub]))
    print(f"  for comparison (extrapolated from subsets): independent numba {t_ind * s_count / (sub * 10):.1f} s, "
          f"plain scipy loop {t_sc * s_count / sub:.0f} s", flush=True)


if __name__ == "__main__":
    main()
