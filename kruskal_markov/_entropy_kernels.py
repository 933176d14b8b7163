"""Numba kernels of the entropy engine (private; arrays in, preallocated arrays out).

All kernels, and the kernels they call, live in this one file (Numba's cache does not track
changes in other files). The model arrives packed (see ``TransitionModel.packed``):
``indptr[a, i] .. indptr[a, i + 1]`` are the positions of row ``i`` of action ``a`` in
``indices`` / ``data``, reordered so that each row's largest entry (its pivot) comes first
(:func:`pivot_first`).

Distributions are sparse support lists ``(idx[:length], p[:length])`` with every ``p > 0``.

Propagation is *mass conservative*: state ``i``'s mass ``p_i`` goes to ``p_i * P[i, j]`` for every
entry of its row, and the row's largest entry (the pivot) also receives the correction
``p_i - sum_j p_i * P[i, j]``, so that what leaves state ``i`` adds up to ``p_i``. In exact
arithmetic with rows summing to 1 the correction is 0 and this is the plain product ``p @ P``; in
floating point it stops the model's last-ulp row-sum errors (and those of the products) from
accumulating, so the total mass changes only by round-off of the additions (a random walk, about
1e-16 per step) instead of drifting systematically. The pivot's share could only come out negative
if a row summed to more than 1 by more than its largest entry, which validated models exclude; it
is clipped at 0 all the same (the only clipping anywhere). No renormalisation ever happens: the
mass is tracked and reported.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True)
def pivot_first(indptr, indices, data):
    """In place: move every row's (first) largest entry to the front of the row (the pivot)."""
    k, n1 = indptr.shape
    for a in range(k):
        for i in range(n1 - 1):
            lo = indptr[a, i]
            hi = indptr[a, i + 1]
            best = lo
            for t in range(lo + 1, hi):
                if data[t] > data[best]:
                    best = t
            if best != lo:
                ti = indices[lo]
                indices[lo] = indices[best]
                indices[best] = ti
                td = data[lo]
                data[lo] = data[best]
                data[best] = td


@njit(cache=True)
def action_images(indptr, indices, n):
    """The image of every action (sorted distinct columns of its matrix), packed.

    Returns ``(img_ptr, img_idx)``: action ``a``'s image is ``img_idx[img_ptr[a]:img_ptr[a + 1]]``."""
    k = indptr.shape[0]
    seen = np.zeros(n, dtype=np.uint8)
    img_ptr = np.zeros(k + 1, dtype=np.int64)
    total = 0
    for a in range(k):
        for t in range(indptr[a, 0], indptr[a, n]):
            seen[indices[t]] = 1
        cnt = 0
        for j in range(n):
            cnt += seen[j]
            seen[j] = 0
        total += cnt
        img_ptr[a + 1] = total
    img_idx = np.empty(total, dtype=np.int32)
    for a in range(k):
        for t in range(indptr[a, 0], indptr[a, n]):
            seen[indices[t]] = 1
        pos = img_ptr[a]
        for j in range(n):
            if seen[j]:
                img_idx[pos] = j
                pos += 1
                seen[j] = 0
    return img_ptr, img_idx


@njit(cache=True)
def _step(indptr, indices, data, img_ptr, img_idx, a, src_idx, src_p, src_len, dst_idx, dst_p, q,
          flag, conservative):
    """dst = src @ P_a on support lists; ``q`` (float64, n) and ``flag`` (uint8, n) are zero scratch
    arrays and are left zero. Returns the length of dst (entries that are exactly 0 are dropped).

    Two ways to find the result's support, same arithmetic: when the rows of the support hold at
    least a quarter as many non-zeros as the action's image has states, accumulate and then
    gather by a branch-free scan of the image; otherwise track the touched states with flags.
    Conservative splitting: every entry gets ``p_i * P[i, j]``, then the row's pivot (its first
    entry) gets the correction ``p_i - sum_j p_i * P[i, j]`` (round-off sized; clipped so that the
    pivot's total share is never negative)."""
    bound = 0
    for s in range(src_len):
        i = src_idx[s]
        bound += indptr[a, i + 1] - indptr[a, i]
    ilo = img_ptr[a]
    ihi = img_ptr[a + 1]
    if 4 * bound >= ihi - ilo:
        for s in range(src_len):
            i = src_idx[s]
            pi = src_p[s]
            lo = indptr[a, i]
            hi = indptr[a, i + 1]
            acc = 0.0
            for t in range(lo, hi):
                c = pi * data[t]
                acc += c
                q[indices[t]] += c
            if conservative:
                r = pi - acc
                cp = pi * data[lo]
                if r < -cp:
                    r = -cp
                q[indices[lo]] += r
        # branch-free gather over the image (a write past the last kept entry is overwritten
        # by the next one or ignored)
        out = 0
        for t in range(ilo, ihi):
            j = img_idx[t]
            v = q[j]
            q[j] = 0.0
            dst_idx[out] = j
            dst_p[out] = v
            out += v > 0.0
        return out
    m = 0
    for s in range(src_len):
        i = src_idx[s]
        pi = src_p[s]
        lo = indptr[a, i]
        hi = indptr[a, i + 1]
        acc = 0.0
        for t in range(lo, hi):
            c = pi * data[t]
            acc += c
            j = indices[t]
            q[j] += c
            if flag[j] == 0:
                flag[j] = 1
                dst_idx[m] = j
                m += 1
        if conservative:
            r = pi - acc
            cp = pi * data[lo]
            if r < -cp:
                r = -cp
            q[indices[lo]] += r
    out = 0
    for t in range(m):
        j = dst_idx[t]
        v = q[j]
        q[j] = 0.0
        flag[j] = 0
        dst_idx[out] = j
        dst_p[out] = v
        out += v > 0.0
    return out


@njit(cache=True)
def _entropy_of(p, length):
    """(entropy in bits of p/sum(p), sum(p)) for the first ``length`` values, all > 0.

    H = log2(m) - sum(p log2 p) / m, clamped to [0, log2(length)] (its exact range), which
    only ever removes round-off."""
    m = 0.0
    s = 0.0
    for t in range(length):
        v = p[t]
        m += v
        s += v * np.log2(v)
    if length <= 1 or m <= 0.0:
        return 0.0, m
    h = np.log2(m) - s / m
    hmax = np.log2(length)
    if h > hmax:
        h = hmax
    if h < 0.0:
        h = 0.0
    return h, m


@njit(cache=True)
def _entropies(idx, p, length, partition, cell_mass, cell_list, cell_vals, has_partition):
    """(cell entropy, state entropy, mass) of a support list. ``cell_mass`` (n_cells) must be zero
    and is left zero; ``cell_list`` / ``cell_vals`` are free scratch of length n_cells."""
    hs, m = _entropy_of(p, length)
    if not has_partition:
        return hs, hs, m
    if length <= 1:
        return 0.0, hs, m
    n_cells = cell_mass.size
    nc = 0
    if n_cells <= 4 * length:
        # dense: accumulate, then one branch-free scan of all cells
        for t in range(length):
            cell_mass[partition[idx[t]]] += p[t]
        for c in range(n_cells):
            v = cell_mass[c]
            cell_mass[c] = 0.0
            cell_vals[nc] = v
            nc += v > 0.0
    else:
        for t in range(length):
            c = partition[idx[t]]
            if cell_mass[c] == 0.0:
                cell_list[nc] = c
                nc += 1
            cell_mass[c] += p[t]
        for t in range(nc):
            c = cell_list[t]
            cell_vals[t] = cell_mass[c]
            cell_mass[c] = 0.0
    hc, _ = _entropy_of(cell_vals, nc)
    return hc, hs, m


@njit(cache=True)
def walk(indptr, indices, data, img_ptr, img_idx, init_idx, init_p, seq, partition, n_cells, has_partition,
         conservative, out_hc, out_hs, out_mass, out_dist, store_dist):
    """One sequence: entropies and mass after every step (``len(seq) + 1`` values each).

    With ``store_dist`` the distributions are written densely into ``out_dist`` (``(N+1, n)``,
    zero-filled by the caller)."""
    n = indptr.shape[1] - 1
    a_idx = np.empty(n, dtype=np.int32)
    a_p = np.empty(n, dtype=np.float64)
    b_idx = np.empty(n, dtype=np.int32)
    b_p = np.empty(n, dtype=np.float64)
    q = np.zeros(n, dtype=np.float64)
    flag = np.zeros(n, dtype=np.uint8)
    cell_mass = np.zeros(n_cells, dtype=np.float64)
    cell_list = np.empty(n_cells, dtype=np.int64)
    cell_vals = np.empty(n_cells, dtype=np.float64)
    length = init_idx.size
    for t in range(length):
        a_idx[t] = init_idx[t]
        a_p[t] = init_p[t]
    for step in range(seq.size + 1):
        hc, hs, m = _entropies(a_idx, a_p, length, partition, cell_mass, cell_list, cell_vals,
                               has_partition)
        out_hc[step] = hc
        out_hs[step] = hs
        out_mass[step] = m
        if store_dist:
            for t in range(length):
                out_dist[step, a_idx[t]] = a_p[t]
        if step == seq.size:
            break
        length = _step(indptr, indices, data, img_ptr, img_idx, seq[step], a_idx, a_p, length, b_idx, b_p, q,
                       flag, conservative)
        a_idx, b_idx = b_idx, a_idx
        a_p, b_p = b_p, a_p


@njit(cache=True)
def _record(out_hc, out_hs, drift, order, lo, hi, col, hc, hs, dev):
    for k in range(lo, hi):
        r = order[k]
        out_hc[r, col] = hc
        out_hs[r, col] = hs
        if dev > drift[r]:
            drift[r] = dev


@njit(cache=True)
def _run_task(indptr, indices, data, img_ptr, img_idx, init_idx, init_p, m0, seqs, order, tmp_order, lo0, hi0,
              partition, has_partition, conservative, out_hc, out_hs, drift,
              q, flag, cell_mass, cell_list, cell_vals, a_idx, a_p, b_idx, b_p, counts,
              lvl_lo, lvl_hi, lvl_ds, lvl_dl, lvl_cur, bounds, pool_idx, pool_p):
    """Depth-first walk of the prefix trie of the sequences ``order[lo0:hi0]``.

    A trie node at depth ``d`` is a range of ``order`` whose sequences share their first ``d``
    actions; its distribution is computed once, its entropies written for all of them, and its
    range bucketed (counting sort) by action ``d`` into children. A node holding a single sequence
    walks the rest of that sequence alone. Distributions of the current root-to-node path are kept
    as support lists in a stack-like pool. Returns the (possibly grown) pool arrays."""
    n = indptr.shape[1] - 1
    k_actions = indptr.shape[0]
    n_steps = seqs.shape[1]
    # root: the initial distribution
    length = init_idx.size
    if pool_idx.size < length + n:
        pool_idx = np.empty(2 * (length + n), dtype=np.int32)
        pool_p = np.empty(2 * (length + n), dtype=np.float64)
    for t in range(length):
        pool_idx[t] = init_idx[t]
        pool_p[t] = init_p[t]
    d = 0
    lvl_lo[0] = lo0
    lvl_hi[0] = hi0
    lvl_ds[0] = 0
    lvl_dl[0] = length
    state = 0  # 0 enter node, 1 go up, 2 next child
    while True:
        if state == 0:
            lo = lvl_lo[d]
            hi = lvl_hi[d]
            ds = lvl_ds[d]
            dl = lvl_dl[d]
            hc, hs, m = _entropies(pool_idx[ds:], pool_p[ds:], dl, partition, cell_mass, cell_list,
                                   cell_vals, has_partition)
            _record(out_hc, out_hs, drift, order, lo, hi, d, hc, hs, abs(m - m0))
            if d == n_steps:
                state = 1
            elif hi - lo == 1:
                # a single sequence: walk the rest alone
                r = order[lo]
                for t in range(dl):
                    a_idx[t] = pool_idx[ds + t]
                    a_p[t] = pool_p[ds + t]
                length = dl
                dev_max = drift[r]
                for step in range(d, n_steps):
                    length = _step(indptr, indices, data, img_ptr, img_idx, seqs[r, step], a_idx, a_p, length,
                                   b_idx, b_p, q, flag, conservative)
                    a_idx, b_idx = b_idx, a_idx
                    a_p, b_p = b_p, a_p
                    hc, hs, m = _entropies(a_idx, a_p, length, partition, cell_mass, cell_list,
                                           cell_vals, has_partition)
                    out_hc[r, step + 1] = hc
                    out_hs[r, step + 1] = hs
                    dev = abs(m - m0)
                    if dev > dev_max:
                        dev_max = dev
                drift[r] = dev_max
                state = 1
            else:
                # counting sort of order[lo:hi] by the action at step d
                for b in range(k_actions):
                    counts[b] = 0
                for kk in range(lo, hi):
                    counts[seqs[order[kk], d]] += 1
                bounds[d, 0] = lo
                for b in range(k_actions):
                    bounds[d, b + 1] = bounds[d, b] + counts[b]
                    counts[b] = bounds[d, b]
                for kk in range(lo, hi):
                    b = seqs[order[kk], d]
                    tmp_order[counts[b]] = order[kk]
                    counts[b] += 1
                for kk in range(lo, hi):
                    order[kk] = tmp_order[kk]
                lvl_cur[d] = 0
                state = 2
        elif state == 1:
            if d == 0:
                break
            d -= 1
            state = 2
        else:
            b = lvl_cur[d]
            while b < k_actions and bounds[d, b + 1] == bounds[d, b]:
                b += 1
            if b == k_actions:
                state = 1
                continue
            lvl_cur[d] = b + 1
            ds = lvl_ds[d]
            dl = lvl_dl[d]
            top = ds + dl
            if pool_idx.size < top + n:
                new_size = 2 * (top + n)
                new_idx = np.empty(new_size, dtype=np.int32)
                new_p = np.empty(new_size, dtype=np.float64)
                new_idx[:top] = pool_idx[:top]
                new_p[:top] = pool_p[:top]
                pool_idx = new_idx
                pool_p = new_p
            length = _step(indptr, indices, data, img_ptr, img_idx, b, pool_idx[ds:], pool_p[ds:], dl,
                           pool_idx[top:], pool_p[top:], q, flag, conservative)
            lvl_lo[d + 1] = bounds[d, b]
            lvl_hi[d + 1] = bounds[d, b + 1]
            lvl_ds[d + 1] = top
            lvl_dl[d + 1] = length
            d += 1
            state = 0
    return pool_idx, pool_p


@njit(cache=True, parallel=True)
def batch(indptr, indices, data, img_ptr, img_idx, init_idx, init_p, m0, seqs, order, task_lo, task_hi,
          block_ptr, partition, n_cells, has_partition, conservative, out_hc, out_hs, drift):
    """Entropies of many sequences, parallel over blocks of tasks.

    ``order`` is a permutation of the sequence indices; task ``t`` is the range
    ``order[task_lo[t]:task_hi[t]]``; block ``b`` runs tasks ``block_ptr[b]:block_ptr[b+1]``
    one after the other with its own scratch (O(n) memory per block, never O(S n))."""
    n = indptr.shape[1] - 1
    k_actions = indptr.shape[0]
    n_steps = seqs.shape[1]
    n_blocks = block_ptr.size - 1
    tmp_order = np.empty_like(order)
    for blk in prange(n_blocks):
        q = np.zeros(n, dtype=np.float64)
        flag = np.zeros(n, dtype=np.uint8)
        cell_mass = np.zeros(n_cells, dtype=np.float64)
        cell_list = np.empty(n_cells, dtype=np.int64)
        cell_vals = np.empty(n_cells, dtype=np.float64)
        a_idx = np.empty(n, dtype=np.int32)
        a_p = np.empty(n, dtype=np.float64)
        b_idx = np.empty(n, dtype=np.int32)
        b_p = np.empty(n, dtype=np.float64)
        counts = np.empty(k_actions, dtype=np.int64)
        lvl_lo = np.empty(n_steps + 1, dtype=np.int64)
        lvl_hi = np.empty(n_steps + 1, dtype=np.int64)
        lvl_ds = np.empty(n_steps + 1, dtype=np.int64)
        lvl_dl = np.empty(n_steps + 1, dtype=np.int64)
        lvl_cur = np.empty(n_steps + 1, dtype=np.int64)
        bounds = np.empty((n_steps + 1, k_actions + 1), dtype=np.int64)
        pool_idx = np.empty(4 * n, dtype=np.int32)
        pool_p = np.empty(4 * n, dtype=np.float64)
        for t in range(block_ptr[blk], block_ptr[blk + 1]):
            pool_idx, pool_p = _run_task(
                indptr, indices, data, img_ptr, img_idx, init_idx, init_p, m0, seqs, order, tmp_order,
                task_lo[t], task_hi[t], partition, has_partition, conservative, out_hc, out_hs,
                drift, q, flag, cell_mass, cell_list, cell_vals, a_idx, a_p, b_idx, b_p, counts,
                lvl_lo, lvl_hi, lvl_ds, lvl_dl, lvl_cur, bounds, pool_idx, pool_p)
