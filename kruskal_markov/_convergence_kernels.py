"""Numba kernels for the expected length of random synchronizing sequences: the subset chain's
transition table, Monte Carlo runs on bitsets, the pair chain, and distribution propagation.

Randomness never originates here: letters are drawn in Python and passed in.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

# The bit helpers below are twins of those in _sync_kernels.py (_popcount, _ctz, the FNV-style
# hash of _hash_row): Numba's cache keys on this file alone, so an imported kernel changed in the
# other file would leave a stale compiled copy here. Change both together.
_ONE = np.uint64(1)
_ZERO = np.uint64(0)
_MUL = np.uint64(0x9E3779B97F4A7C15)


@njit(cache=True, inline="always")
def _popcount(x):
    x = x - ((x >> np.uint64(1)) & np.uint64(0x5555555555555555))
    x = (x & np.uint64(0x3333333333333333)) + ((x >> np.uint64(2)) & np.uint64(0x3333333333333333))
    x = (x + (x >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return int((x * np.uint64(0x0101010101010101)) >> np.uint64(56))


@njit(cache=True, inline="always")
def _ctz(x):
    return _popcount((x & (~x + np.uint64(1))) - np.uint64(1))


@njit(cache=True)
def _hash_vec(v):
    h = np.uint64(0xCBF29CE484222325)
    for w in range(v.shape[0]):
        h = (h ^ v[w]) * _MUL
        h ^= h >> np.uint64(29)
    return h


@njit(cache=True)
def _image(src, dst, a, delta, sup, det):
    W = src.shape[0]
    for w in range(W):
        dst[w] = _ZERO
    for w in range(W):
        x = src[w]
        while x != _ZERO:
            b = _ctz(x)
            x &= x - _ONE
            q = w * 64 + b
            if det:
                r = delta[a, q]
                dst[r >> 6] |= _ONE << np.uint64(r & 63)
            else:
                for v in range(W):
                    dst[v] |= sup[a, q, v]


@njit(cache=True)
def subset_chain_table(store, count, delta, sup, det, table, out):
    """``out[i, a]`` = row index of the image of row ``i`` under letter ``a`` (``-1`` if absent)."""
    k = out.shape[1]
    W = store.shape[1]
    tmp = np.empty(W, dtype=np.uint64)
    mask = np.uint64(table.shape[0] - 1)
    for i in range(count):
        for a in range(k):
            _image(store[i], tmp, a, delta, sup, det)
            slot = _hash_vec(tmp) & mask
            found = -1
            while True:
                j = table[slot]
                if j == -1:
                    break
                same = True
                for w in range(W):
                    if store[j, w] != tmp[w]:
                        same = False
                        break
                if same:
                    found = j
                    break
                slot = (slot + _ONE) & mask
            out[i, a] = found


@njit(cache=True)
def mc_sync_steps(cur, letters, delta, sup, det, steps, done):
    """Advance every unfinished run ``i`` through ``letters[i, :]``; ``steps[i]`` counts letters applied,
    ``done[i]`` becomes True when the run's set is a singleton."""
    R, C = letters.shape
    W = cur.shape[1]
    tmp = np.empty(W, dtype=np.uint64)
    for i in range(R):
        if done[i]:
            continue
        for t in range(C):
            _image(cur[i], tmp, letters[i, t], delta, sup, det)
            c = 0
            for w in range(W):
                cur[i, w] = tmp[w]
                c += _popcount(tmp[w])
            steps[i] += 1
            if c == 1:
                done[i] = True
                break


@njit(cache=True, inline="always")
def _pair_index(p, q, n):
    # twin of kruskal_markov._subsets.pair_index (a kernel-local copy, inlined by Numba)
    if p > q:
        p, q = q, p
    return p * n - (p * (p + 1)) // 2 + (q - p - 1)


@njit(cache=True, inline="always")
def _pair_offsets(n):
    """``first[p]`` = index of the first pair ``(p, q)`` (``q > p``) in :func:`_pair_index` order."""
    first = np.empty(n + 1, dtype=np.int64)
    for p in range(n + 1):
        first[p] = p * n - (p * (p + 1)) // 2
    return first


@njit(cache=True, inline="always")
def _pair_of(first, idx):
    """The pair ``(p, q)``, ``p < q``, of pair index ``idx`` (inverse of :func:`_pair_index`)."""
    p = np.searchsorted(first, idx, side="right") - 1
    q = idx - first[p] + p + 1
    return p, q


@njit(cache=True, inline="always")
def _push_images(delta, p, q, n, P, local, order, m):
    """Append to ``order[:m]`` the unmerged images of pair ``(p, q)`` not seen yet (``local`` marks
    the seen ones with their position), growing ``order`` when full; returns ``(order, m)``."""
    k = delta.shape[0]
    for a in range(k):
        pp = delta[a, p]
        qq = delta[a, q]
        if pp != qq:
            j = _pair_index(pp, qq, n)
            if local[j] == -1:
                if m >= order.shape[0]:
                    bigger = np.empty(min(P, 2 * order.shape[0]), dtype=np.int64)
                    bigger[:m] = order[:m]
                    order = bigger
                local[j] = m
                order[m] = j
                m += 1
    return order, m


@njit(cache=True)
def pair_reachable(delta, start_pairs):
    """Pairs reachable in one or more steps from ``start_pairs`` (a list of pair indices).

    Returns ``(order, local)``: the reachable pair indices, and for every pair its position in
    ``order`` (``-1`` if unreachable)."""
    n = delta.shape[1]
    P = n * (n - 1) // 2
    local = np.full(P, -1, dtype=np.int64)
    # decode pair index -> (p, q) on the fly via row offsets
    first = _pair_offsets(n)
    order = np.empty(min(P, 1 << 20), dtype=np.int64)
    m = 0
    # seed: images of the start pairs
    queue_start = 0
    for s in range(start_pairs.shape[0]):
        p, q = _pair_of(first, start_pairs[s])
        order, m = _push_images(delta, p, q, n, P, local, order, m)
    while queue_start < m:
        idx = order[queue_start]
        queue_start += 1
        p, q = _pair_of(first, idx)
        order, m = _push_images(delta, p, q, n, P, local, order, m)
    return order[:m].copy(), local


@njit(cache=True)
def pair_images(delta, pairs, local):
    """``out[i, a]`` = local index of the image of pair ``pairs[i]`` under ``a`` (``-1`` = merged)."""
    k, n = delta.shape
    first = _pair_offsets(n)
    out = np.empty((pairs.shape[0], k), dtype=np.int32)
    for i in range(pairs.shape[0]):
        p, q = _pair_of(first, pairs[i])
        for a in range(k):
            pp = delta[a, p]
            qq = delta[a, q]
            if pp == qq:
                out[i, a] = -1
            else:
                out[i, a] = local[_pair_index(pp, qq, n)]
    return out


@njit(cache=True, inline="always")
def _pair_gather(img, w, x, i, s):
    """``s + sum_a w_a x[image of pair i under a]`` (merged images contribute 0), summed in order."""
    for a in range(img.shape[1]):
        j = img[i, a]
        if j >= 0:
            s += w[a] * x[j]
    return s


@njit(cache=True)
def pair_value_step(img, w, h, out):
    """``out = 1 + Q h`` on the pair chain (merged pairs contribute 0)."""
    for i in range(img.shape[0]):
        out[i] = _pair_gather(img, w, h, i, 1.0)


@njit(cache=True)
def mc_entropy_steps(p0, indptr, indices, data, partition, n_cells, letters, epsilon, out_steps):
    """For each run ``i``, propagate ``p0`` through ``letters[i, :]`` until the partition entropy
    (bits) is ``<= epsilon``; ``out_steps[i]`` = number of tilts, or ``-1`` if never within the row."""
    R, C = letters.shape
    n = p0.shape[0]
    cur = np.empty(n)
    nxt = np.empty(n)
    cells = np.empty(n_cells)
    for i in range(R):
        for s in range(n):
            cur[s] = p0[s]
        out_steps[i] = -1
        for t in range(C):
            a = letters[i, t]
            for s in range(n):
                nxt[s] = 0.0
            for s in range(n):
                x = cur[s]
                if x == 0.0:
                    continue
                for e in range(indptr[a, s], indptr[a, s + 1]):
                    nxt[indices[e]] += x * data[e]
            tot = 0.0
            for c in range(n_cells):
                cells[c] = 0.0
            for s in range(n):
                cur[s] = nxt[s]
                cells[partition[s]] += nxt[s]
                tot += nxt[s]
            h = 0.0
            for c in range(n_cells):
                if cells[c] > 0.0:
                    pc = cells[c] / tot
                    h -= pc * np.log2(pc)
            if h <= epsilon:
                out_steps[i] = t + 1
                break


@njit(cache=True)
def start_pair_stats(delta, start_pairs, local, w, h, v1):
    """For the start pairs: the largest expected merging time ``1 + sum_a w_a h(image)``, and the
    mass vector after one step (added into ``v1``)."""
    k, n = delta.shape
    first = _pair_offsets(n)
    best = 0.0
    for s in range(start_pairs.shape[0]):
        p, q = _pair_of(first, start_pairs[s])
        e = 1.0
        for a in range(k):
            pp = delta[a, p]
            qq = delta[a, q]
            if pp != qq:
                j = local[_pair_index(pp, qq, n)]
                e += w[a] * h[j]
                v1[j] += w[a]
        best = max(best, e)
    return best


@njit(cache=True, parallel=True)
def pair_survival_step(img, w, u, out, v1):
    """``out = Q u`` (gather form: ``out[i] = sum_a w_a u[image of i under a]``, merged = 0);
    returns ``v1 . out``. Independent outputs, so ``prange`` is safe."""
    tot = 0.0
    for i in prange(img.shape[0]):
        s = _pair_gather(img, w, u, i, 0.0)
        out[i] = s
        tot += v1[i] * s
    return tot
