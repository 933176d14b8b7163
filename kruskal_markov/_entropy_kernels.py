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

_INV_LN2 = 1.0 / np.log(2.0)
#: log2 of small integers (the upper bound of an entropy over that many values)
_LOG2_INT = np.log2(np.maximum(np.arange(4096, dtype=np.float64), 1.0))


_TAB_N = 128
_TAB_C = 1.0 + (2.0 * np.arange(_TAB_N) + 1.0) / (2.0 * _TAB_N)
_TAB_INVC = 1.0 / _TAB_C
_TAB_LOG2C = np.log2(_TAB_C)
_TINY = 2.2250738585072014e-308  # smallest normal float64
#: images smaller than this are never kept dense (zeros included) for the gather blocks
_MIN_BLOCK_IMAGE = 16


@njit(cache=True, fastmath={"reassoc", "contract"})
def _plogp(p, bits, off, length):
    """``(sum p log2 p, sum p, #positive, #subnormal)`` over ``p[off:off+length]``; zeros and
    subnormals contribute nothing here (the caller adds the subnormals exactly).

    ``bits`` is ``p.view(np.int64)``. A branch-free log2 that the compiler vectorizes: exponent
    from the bits, mantissa ``1 + f`` against the centre ``c`` of its 1/128 table interval,
    ``log2(1+f) = log2(c) + log1p(r) / ln 2`` with ``r = (1+f-c)/c``, ``|r| < 2^-8``, and
    ``log1p`` by its Taylor polynomial to ``r^7`` (truncation < 1e-17, relative error of the
    result ~ 5e-16). Reassociated sums (fastmath) change only the order of additions."""
    s = 0.0
    m = 0.0
    kpos = 0
    nsub = 0
    for t in range(off, off + length):
        v = p[t]
        b = bits[t]
        e = (b >> 52) - 1023
        idx = (b >> 45) & 127
        mm = 1.0 + np.float64(b & 0xFFFFFFFFFFFFF) * 2.220446049250313e-16
        r = (mm - _TAB_C[idx]) * _TAB_INVC[idx]
        r2 = r * r
        l1p = r - r2 * (0.5 - r * (0.3333333333333333 - r * (0.25 - r * (
            0.2 - r * (0.16666666666666666 - r * 0.14285714285714285)))))
        lg = np.float64(e) + _TAB_LOG2C[idx] + l1p * 1.4426950408889634
        normal = v >= _TINY
        s += v * lg if normal else 0.0
        m += v
        kpos += v > 0.0
        nsub += (v > 0.0) & (v < _TINY)
    return s, m, kpos, nsub


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
def image_blocks(indptr, indices, data, img_ptr, img_idx, n, conservative):
    """Per pair (previous action b, action a): ``P_a`` restricted to the rows of ``b``'s image,
    transposed (one row per state of ``a``'s image), with image-local indices.

    After action ``b`` a distribution lives on ``b``'s image; when it fills that image its
    support list is a dense vector over it, and the next step is a gather ``out[j] =
    sum_i p[i] P_a[i, j]`` over this block: no scatter, no scratch, no support search. With
    ``conservative`` each row's pivot value (its first entry) is raised by ``1 - sum(row)``
    computed with a compensated (TwoSum) sum, so the block's rows sum to 1 within half an ulp
    -- the gather form of the conservative splitting of :func:`_step`.

    Returns ``(blk_rp_off, blk_en_off, blk_rowptr, blk_src, blk_val)``: block ``g = b * K + a``
    has row pointers ``blk_rowptr[blk_rp_off[g]:...]`` (``|img_a| + 1`` of them) relative to
    ``blk_en_off[g]`` in ``blk_src`` (int32, local index into ``b``'s image) / ``blk_val``."""
    k = indptr.shape[0]
    corr = np.zeros(indptr[k - 1, n], dtype=np.float64)
    if conservative:
        for a in range(k):
            for i in range(n):
                lo = indptr[a, i]
                hi = indptr[a, i + 1]
                s = 0.0
                c = 0.0
                for t in range(lo, hi):  # TwoSum: s + c is the sum to ~1e-32
                    x = data[t]
                    y = s + x
                    bp = y - s
                    c += (s - (y - bp)) + (x - bp)
                    s = y
                corr[lo] = (1.0 - s) - c
    loc_src = np.full(n, -1, dtype=np.int64)
    loc_dst = np.full(n, -1, dtype=np.int64)
    blk_rp_off = np.zeros(k * k + 1, dtype=np.int64)
    blk_en_off = np.zeros(k * k + 1, dtype=np.int64)
    for b in range(k):
        for a in range(k):
            g = b * k + a
            na = img_ptr[a + 1] - img_ptr[a]
            cnt = 0
            for t in range(img_ptr[b], img_ptr[b + 1]):
                i = img_idx[t]
                cnt += indptr[a, i + 1] - indptr[a, i]
            blk_rp_off[g + 1] = blk_rp_off[g] + na + 1
            blk_en_off[g + 1] = blk_en_off[g] + cnt
    blk_rowptr = np.zeros(blk_rp_off[k * k], dtype=np.int64)
    blk_src = np.empty(blk_en_off[k * k], dtype=np.int32)
    blk_val = np.empty(blk_en_off[k * k], dtype=np.float64)
    for b in range(k):
        for t in range(img_ptr[b], img_ptr[b + 1]):
            loc_src[img_idx[t]] = t - img_ptr[b]
        for a in range(k):
            g = b * k + a
            for t in range(img_ptr[a], img_ptr[a + 1]):
                loc_dst[img_idx[t]] = t - img_ptr[a]
            rp = blk_rp_off[g]
            na = img_ptr[a + 1] - img_ptr[a]
            for t in range(img_ptr[b], img_ptr[b + 1]):
                i = img_idx[t]
                for e in range(indptr[a, i], indptr[a, i + 1]):
                    blk_rowptr[rp + 1 + loc_dst[indices[e]]] += 1
            for jl in range(na):
                blk_rowptr[rp + jl + 1] += blk_rowptr[rp + jl]
            fill = blk_rowptr[rp:rp + na].copy()
            eo = blk_en_off[g]
            for t in range(img_ptr[b], img_ptr[b + 1]):
                i = img_idx[t]
                for e in range(indptr[a, i], indptr[a, i + 1]):
                    jl = loc_dst[indices[e]]
                    pos = eo + fill[jl]
                    fill[jl] += 1
                    blk_src[pos] = loc_src[i]
                    blk_val[pos] = data[e] + corr[e]
            for t in range(img_ptr[a], img_ptr[a + 1]):
                loc_dst[img_idx[t]] = -1
        for t in range(img_ptr[b], img_ptr[b + 1]):
            loc_src[img_idx[t]] = -1
    return blk_rp_off, blk_en_off, blk_rowptr, blk_src, blk_val


@njit(cache=True)
def _step(indptr, indices, data, img_ptr, img_idx, a, buf_idx, buf_p, src, src_len, dst, q, flag,
          conservative):
    """One step on support lists held in the buffers ``buf_idx`` / ``buf_p``: the distribution at
    offset ``src`` (``src_len`` entries) times ``P_a`` is written at offset ``dst`` (room for
    ``n`` entries needed). ``q`` (float64, n) and ``flag`` (uint8, n) are zero scratch arrays and
    are left zero. Returns the new length (entries that are exactly 0 are dropped).

    Offsets instead of array views and swaps keep Numba from reference counting in the hot loop.
    Two ways to find the result's support, same arithmetic: when the rows of the support hold at
    least a quarter as many non-zeros as the action's image has states, accumulate and then
    gather by a branch-free scan of the image; otherwise track the touched states with flags. A
    point mass on a point-mass row is O(1). Conservative splitting: every entry gets
    ``p_i * P[i, j]``, then the row's pivot (its first entry) gets the correction
    ``p_i - sum_j p_i * P[i, j]`` (round-off sized; clipped so that the pivot's total share is
    never negative)."""
    if src_len == 1:
        i = buf_idx[src]
        lo = indptr[a, i]
        if indptr[a, i + 1] - lo == 1:
            v = buf_p[src] if conservative else buf_p[src] * data[lo]
            buf_idx[dst] = indices[lo]
            buf_p[dst] = v
            return 1 if v > 0.0 else 0
    ilo = img_ptr[a]
    ihi = img_ptr[a + 1]
    dense = 4 * src_len >= ihi - ilo
    if not dense:
        bound = 0
        for s in range(src, src + src_len):
            i = buf_idx[s]
            bound += indptr[a, i + 1] - indptr[a, i]
        dense = 4 * bound >= ihi - ilo
    m = 0
    for s in range(src, src + src_len):
        i = buf_idx[s]
        pi = buf_p[s]
        lo = indptr[a, i]
        hi = indptr[a, i + 1]
        acc = 0.0
        if dense:
            for t in range(lo, hi):
                c = pi * data[t]
                acc += c
                q[indices[t]] += c
        else:
            for t in range(lo, hi):
                c = pi * data[t]
                acc += c
                j = indices[t]
                q[j] += c
                if flag[j] == 0:
                    flag[j] = 1
                    buf_idx[dst + m] = j
                    m += 1
        if conservative:
            r = pi - acc
            cp = pi * data[lo]
            if r < -cp:
                r = -cp
            q[indices[lo]] += r
    out = dst
    if dense:
        # branch-free gather over the image (a write past the last kept entry is overwritten
        # by the next one or ignored)
        for t in range(ilo, ihi):
            j = img_idx[t]
            v = q[j]
            q[j] = 0.0
            buf_idx[out] = j
            buf_p[out] = v
            out += v > 0.0
    else:
        for t in range(dst, dst + m):
            j = buf_idx[t]
            v = q[j]
            q[j] = 0.0
            flag[j] = 0
            buf_idx[out] = j
            buf_p[out] = v
            out += v > 0.0
    return out - dst


@njit(cache=True)
def _entropy_of(p, off, length):
    """(entropy in bits of p/sum(p), sum(p)) for ``p[off:off+length]``, all > 0.

    H = log2(m) - sum(p log2 p) / m, clamped to [0, log2(length)] (its exact range), which
    only ever removes round-off."""
    if length <= 1:
        return 0.0, (p[off] if length == 1 else 0.0)
    m = 0.0
    s = 0.0
    for t in range(off, off + length):
        v = p[t]
        m += v
        s += v * np.log2(v)
    if m <= 0.0:
        return 0.0, m
    d = m - 1.0
    if abs(d) < 1e-5:
        # log2(m) by its series about 1 (error < 1e-16; mass is 1 up to round-off here)
        lm = (d - 0.5 * d * d) * _INV_LN2
    else:
        lm = np.log2(m)
    h = lm - s / m
    hmax = _LOG2_INT[length] if length < _LOG2_INT.size else np.log2(length)
    if h > hmax:
        h = hmax
    if h < 0.0:
        h = 0.0
    return h, m


@njit(cache=True)
def _entropies(idx, p, off, length, partition, cell_mass, cell_list, cell_vals, has_partition):
    """(cell entropy, state entropy, mass) of the support list at ``off``. ``cell_mass``
    (n_cells) must be zero and is left zero; ``cell_list`` / ``cell_vals`` are free scratch of
    length n_cells."""
    if length <= 1:
        return 0.0, 0.0, (p[off] if length == 1 else 0.0)
    hs, m = _entropy_of(p, off, length)
    if not has_partition:
        return hs, hs, m
    n_cells = cell_mass.size
    nc = 0
    if n_cells <= 4 * length:
        # dense: accumulate, then one branch-free scan of all cells
        for t in range(off, off + length):
            cell_mass[partition[idx[t]]] += p[t]
        for c in range(n_cells):
            v = cell_mass[c]
            cell_mass[c] = 0.0
            cell_vals[nc] = v
            nc += v > 0.0
    else:
        for t in range(off, off + length):
            c = partition[idx[t]]
            if cell_mass[c] == 0.0:
                cell_list[nc] = c
                nc += 1
            cell_mass[c] += p[t]
        for t in range(nc):
            c = cell_list[t]
            cell_vals[t] = cell_mass[c]
            cell_mass[c] = 0.0
    if nc == length:
        # every state in a cell of its own: the cell masses are the state masses
        return hs, hs, m
    hc, _ = _entropy_of(cell_vals, 0, nc)
    return hc, hs, m


@njit(cache=True)
def entropy_of(p):
    """Entropy (bits) of the positive values ``p`` read as a distribution up to its mass."""
    h, _ = _entropy_of(p, 0, p.size)
    return h


@njit(cache=True)
def walk(indptr, indices, data, img_ptr, img_idx, init_idx, init_p, seq, partition, n_cells,
         has_partition, conservative, out_hc, out_hs, out_mass, out_support, out_dist, store_dist):
    """One sequence: entropies and mass after every step (``len(seq) + 1`` values each).

    With ``store_dist`` the distributions are written densely into ``out_dist`` (``(N+1, n)``,
    zero-filled by the caller)."""
    n = indptr.shape[1] - 1
    buf_idx = np.empty(2 * n, dtype=np.int32)
    buf_p = np.empty(2 * n, dtype=np.float64)
    q = np.zeros(n, dtype=np.float64)
    flag = np.zeros(n, dtype=np.uint8)
    cell_mass = np.zeros(n_cells, dtype=np.float64)
    cell_list = np.empty(n_cells, dtype=np.int64)
    cell_vals = np.empty(n_cells, dtype=np.float64)
    length = init_idx.size
    for t in range(length):
        buf_idx[t] = init_idx[t]
        buf_p[t] = init_p[t]
    cur = 0
    for step in range(seq.size + 1):
        hc, hs, m = _entropies(buf_idx, buf_p, cur, length, partition, cell_mass, cell_list,
                               cell_vals, has_partition)
        out_hc[step] = hc
        out_hs[step] = hs
        out_mass[step] = m
        out_support[step] = length
        if store_dist:
            for t in range(cur, cur + length):
                out_dist[step, buf_idx[t]] = buf_p[t]
        if step == seq.size:
            break
        nxt = n - cur
        length = _step(indptr, indices, data, img_ptr, img_idx, seq[step], buf_idx, buf_p, cur,
                       length, nxt, q, flag, conservative)
        cur = nxt


@njit(cache=True)
def _run_task(indptr, indices, data, img_ptr, img_idx, use_blocks, blk_rp_off, blk_en_off,
              blk_rowptr, blk_src, blk_val, init_idx, init_p, m0, seqs, order, tmp_order, lo0, hi0,
              partition, has_partition, conservative, out_hc, out_hs, drift, q, flag, cell_mass,
              cell_list, cell_vals, counts, lvl_lo, lvl_hi, lvl_ds, lvl_dl, lvl_cur, lvl_one,
              lvl_act, lvl_full, bounds, pool_idx, pool_p):
    """Depth-first walk of the prefix trie of the sequences ``order[lo0:hi0]``.

    A trie node at depth ``d`` is a range of ``order`` whose sequences share their first ``d``
    actions; its distribution is computed once, its entropies written for all of them, and its
    range bucketed (counting sort) by action ``d`` into children (a node with one sequence has
    the one child its next action names). The distributions of the current root-to-node path are
    support lists stacked in ``pool_idx`` / ``pool_p``, grown when needed (the grown arrays are
    returned).

    The step and the entropies are written out here rather than called: Numba does not inline
    :func:`_step` / :func:`_entropies` cheaply, and a call costs more than a whole step on the
    tiny supports of an oriented part (same arithmetic as those functions). Measured: the node's
    entropies, the bucketing and the step as separate ``@njit(inline="always")`` functions gave
    bit-identical results but took 0.33 s instead of 0.20-0.25 s on the benchmark's contracting
    tray-grid model (50,000 sequences x 50 steps), 3-5% more on the random one."""
    n = indptr.shape[1] - 1
    k_actions = indptr.shape[0]
    n_steps = seqs.shape[1]
    n_cells = cell_mass.size
    length = init_idx.size
    if pool_idx.size < length + 2 * n:
        pool_idx = np.empty(2 * (length + 2 * n), dtype=np.int32)
        pool_p = np.empty(2 * (length + 2 * n), dtype=np.float64)
    for t in range(length):
        pool_idx[t] = init_idx[t]
        pool_p[t] = init_p[t]
    pool_bits = pool_p.view(np.int64)
    cell_bits = cell_vals.view(np.int64)
    d = 0
    lvl_lo[0] = lo0
    lvl_hi[0] = hi0
    lvl_ds[0] = 0
    lvl_dl[0] = length
    lvl_act[0] = -1
    lvl_full[0] = 0
    state = 0  # 0 enter node, 1 go up, 2 next child
    while True:
        if state == 0:
            lo = lvl_lo[d]
            hi = lvl_hi[d]
            ds = lvl_ds[d]
            dl = lvl_dl[d]
            # ---- entropies of the support list (as _entropies) ----
            if dl <= 1:
                hc = 0.0
                hs = 0.0
                m = pool_p[ds] if dl == 1 else 0.0
            else:
                # (lists written in image-block mode may hold zeros: skipped, 0 log 0 = 0)
                if dl >= 8:
                    sl, m, kpos, nsub = _plogp(pool_p, pool_bits, ds, dl)
                    if nsub:
                        for t in range(ds, ds + dl):
                            v = pool_p[t]
                            if 0.0 < v < _TINY:
                                sl += v * np.log2(v)
                else:
                    m = 0.0
                    sl = 0.0
                    kpos = 0
                    for t in range(ds, ds + dl):
                        v = pool_p[t]
                        if v > 0.0:
                            m += v
                            sl += v * np.log2(v)
                            kpos += 1
                hs = 0.0
                if m > 0.0 and kpos > 1:
                    dm = m - 1.0
                    lm = (dm - 0.5 * dm * dm) * _INV_LN2 if abs(dm) < 1e-5 else np.log2(m)
                    hs = lm - sl / m
                    hmax = _LOG2_INT[kpos] if kpos < _LOG2_INT.size else np.log2(kpos)
                    hs = min(max(hs, 0.0), hmax)
                hc = hs
                if has_partition:
                    nc = 0
                    if n_cells <= 4 * dl:
                        for t in range(ds, ds + dl):
                            cell_mass[partition[pool_idx[t]]] += pool_p[t]
                        for c in range(n_cells):
                            v = cell_mass[c]
                            cell_mass[c] = 0.0
                            cell_vals[nc] = v
                            nc += v > 0.0
                    else:
                        for t in range(ds, ds + dl):
                            v = pool_p[t]
                            if v > 0.0:
                                c = partition[pool_idx[t]]
                                if cell_mass[c] == 0.0:
                                    cell_list[nc] = c
                                    nc += 1
                                cell_mass[c] += v
                        for t in range(nc):
                            c = cell_list[t]
                            cell_vals[t] = cell_mass[c]
                            cell_mass[c] = 0.0
                    if nc <= 1:
                        hc = 0.0
                    elif nc != kpos:  # nc == kpos: every state in a cell of its own, hc = hs
                        if nc >= 8:
                            sc, mc, _, nsub = _plogp(cell_vals, cell_bits, 0, nc)
                            if nsub:
                                for t in range(nc):
                                    v = cell_vals[t]
                                    if v < _TINY:
                                        sc += v * np.log2(v)
                        else:
                            mc = 0.0
                            sc = 0.0
                            for t in range(nc):
                                v = cell_vals[t]
                                mc += v
                                sc += v * np.log2(v)
                        hc = 0.0
                        if mc > 0.0:
                            dm = mc - 1.0
                            lm = (dm - 0.5 * dm * dm) * _INV_LN2 if abs(dm) < 1e-5 else np.log2(mc)
                            hc = lm - sc / mc
                            hmax = _LOG2_INT[nc] if nc < _LOG2_INT.size else np.log2(nc)
                            hc = min(max(hc, 0.0), hmax)
            dev = abs(m - m0)
            for k in range(lo, hi):
                r = order[k]
                out_hc[r, d] = hc
                out_hs[r, d] = hs
                if dev > drift[r]:
                    drift[r] = dev
            if d == n_steps:
                state = 1
            elif hi - lo == 1:
                lvl_one[d] = 1
                lvl_cur[d] = 0
                state = 2
            else:
                lvl_one[d] = 0
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
            if lvl_one[d]:
                if lvl_cur[d] == 1:
                    state = 1
                    continue
                lvl_cur[d] = 1
                a = seqs[order[lvl_lo[d]], d]
                clo = lvl_lo[d]
                chi = lvl_hi[d]
            else:
                b = lvl_cur[d]
                while b < k_actions and bounds[d, b + 1] == bounds[d, b]:
                    b += 1
                if b == k_actions:
                    state = 1
                    continue
                lvl_cur[d] = b + 1
                a = b
                clo = bounds[d, b]
                chi = bounds[d, b + 1]
            ds = lvl_ds[d]
            dl = lvl_dl[d]
            top = ds + dl
            if pool_idx.size < top + 2 * n:
                new_size = 2 * (top + 2 * n)
                new_idx = np.empty(new_size, dtype=np.int32)
                new_p = np.empty(new_size, dtype=np.float64)
                new_idx[:top] = pool_idx[:top]
                new_p[:top] = pool_p[:top]
                pool_idx = new_idx
                pool_p = new_p
                pool_bits = pool_p.view(np.int64)
            # ---- one step: pool[ds:ds+dl] @ P_a -> pool[top:...] (as _step) ----
            length = -1
            full = 0
            prev = lvl_act[d]
            if use_blocks and lvl_full[d] and dl > 1:
                # the support is exactly the previous action's image, in image order: gather
                g = prev * k_actions + a
                rp = blk_rp_off[g]
                eo = blk_en_off[g]
                ilo = img_ptr[a]
                na = img_ptr[a + 1] - ilo
                keep = na >= _MIN_BLOCK_IMAGE  # zeros kept: the list stays the image, in order
                out = top
                for jl in range(na):
                    acc = 0.0
                    for e in range(eo + blk_rowptr[rp + jl], eo + blk_rowptr[rp + jl + 1]):
                        acc += pool_p[ds + blk_src[e]] * blk_val[e]
                    pool_idx[out] = img_idx[ilo + jl]
                    pool_p[out] = acc
                    out += keep or acc > 0.0
                length = out - top
                full = keep
            if length < 0 and dl == 1:
                i = pool_idx[ds]
                rlo = indptr[a, i]
                if indptr[a, i + 1] - rlo == 1:
                    v = pool_p[ds] if conservative else pool_p[ds] * data[rlo]
                    pool_idx[top] = indices[rlo]
                    pool_p[top] = v
                    length = 1 if v > 0.0 else 0
            if length < 0:
                ilo = img_ptr[a]
                ihi = img_ptr[a + 1]
                dense = 4 * dl >= ihi - ilo
                if not dense:
                    bound = 0
                    for s_ in range(ds, ds + dl):
                        i = pool_idx[s_]
                        bound += indptr[a, i + 1] - indptr[a, i]
                    dense = 4 * bound >= ihi - ilo
                mm = 0
                for s_ in range(ds, ds + dl):
                    i = pool_idx[s_]
                    pi = pool_p[s_]
                    rlo = indptr[a, i]
                    rhi = indptr[a, i + 1]
                    acc = 0.0
                    if dense:
                        for t in range(rlo, rhi):
                            c = pi * data[t]
                            acc += c
                            q[indices[t]] += c
                    else:
                        for t in range(rlo, rhi):
                            c = pi * data[t]
                            acc += c
                            j = indices[t]
                            q[j] += c
                            if flag[j] == 0:
                                flag[j] = 1
                                pool_idx[top + mm] = j
                                mm += 1
                    if conservative:
                        rr = pi - acc
                        cp = pi * data[rlo]
                        if rr < -cp:
                            rr = -cp
                        q[indices[rlo]] += rr
                out = top
                if dense:
                    keep = use_blocks and ihi - ilo >= _MIN_BLOCK_IMAGE
                    for t in range(ilo, ihi):
                        j = img_idx[t]
                        v = q[j]
                        q[j] = 0.0
                        pool_idx[out] = j
                        pool_p[out] = v
                        out += (v > 0.0) or keep  # image-block mode keeps zeros
                    full = keep
                else:
                    for t in range(top, top + mm):
                        j = pool_idx[t]
                        v = q[j]
                        q[j] = 0.0
                        flag[j] = 0
                        pool_idx[out] = j
                        pool_p[out] = v
                        out += v > 0.0
                length = out - top
            lvl_lo[d + 1] = clo
            lvl_hi[d + 1] = chi
            lvl_ds[d + 1] = top
            lvl_dl[d + 1] = length
            lvl_act[d + 1] = a
            lvl_full[d + 1] = full
            d += 1
            state = 0
    return pool_idx, pool_p


@njit(cache=True, parallel=True)
def batch(indptr, indices, data, img_ptr, img_idx, use_blocks, blk_rp_off, blk_en_off, blk_rowptr,
          blk_src, blk_val, init_idx, init_p, m0, seqs, order, task_lo, task_hi, block_ptr,
          partition, n_cells, has_partition, conservative, out_hc, out_hs, drift):
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
        counts = np.empty(k_actions, dtype=np.int64)
        lvl_lo = np.empty(n_steps + 1, dtype=np.int64)
        lvl_hi = np.empty(n_steps + 1, dtype=np.int64)
        lvl_ds = np.empty(n_steps + 1, dtype=np.int64)
        lvl_dl = np.empty(n_steps + 1, dtype=np.int64)
        lvl_cur = np.empty(n_steps + 1, dtype=np.int64)
        lvl_one = np.empty(n_steps + 1, dtype=np.uint8)
        lvl_act = np.empty(n_steps + 1, dtype=np.int64)
        lvl_full = np.empty(n_steps + 1, dtype=np.uint8)
        bounds = np.empty((n_steps + 1, k_actions + 1), dtype=np.int64)
        pool_idx = np.empty(4 * n, dtype=np.int32)
        pool_p = np.empty(4 * n, dtype=np.float64)
        for t in range(block_ptr[blk], block_ptr[blk + 1]):
            pool_idx, pool_p = _run_task(
                indptr, indices, data, img_ptr, img_idx, use_blocks, blk_rp_off, blk_en_off,
                blk_rowptr, blk_src, blk_val, init_idx, init_p, m0, seqs, order, tmp_order,
                task_lo[t], task_hi[t], partition, has_partition, conservative, out_hc, out_hs,
                drift, q, flag, cell_mass, cell_list, cell_vals, counts, lvl_lo, lvl_hi, lvl_ds,
                lvl_dl, lvl_cur, lvl_one, lvl_act, lvl_full, bounds, pool_idx, pool_p)


# ------------------------------------------------------------------------------------------
# Level-synchronous engine for models whose distributions fill the images of the actions
# ------------------------------------------------------------------------------------------
# Indices in the loops below are unsigned: Numba then skips its negative-index wrap-around
# test, and LLVM vectorizes the loops across sequences (3-4x faster than with int64 indices).
@njit(cache=True, fastmath={"reassoc", "contract"})
def _rows_plogp(y, ybits, width, nrows, c0, c1, s_acc, m_acc, kpos, nsub):
    """For every column ``k`` in ``[c0, c1)`` of the row-major ``nrows x width`` array ``y``:
    accumulate ``sum v log2 v`` (normal ``v`` only, table log as in :func:`_plogp`), ``sum v``,
    ``#(v > 0)`` and ``#subnormal`` into the column's slots. Vectorized across columns."""
    uc0 = np.uint64(c0)
    uc1 = np.uint64(c1)
    for k in range(uc0, uc1):
        s_acc[k] = 0.0
        m_acc[k] = 0.0
        kpos[k] = 0
        nsub[k] = 0
    for row in range(nrows):
        base = np.uint64(row * width)
        for k in range(uc0, uc1):
            v = y[base + k]
            b = ybits[base + k]
            e = (b >> 52) - 1023
            idx = (b >> 45) & 127
            mm = 1.0 + np.float64(b & 0xFFFFFFFFFFFFF) * 2.220446049250313e-16
            r = (mm - _TAB_C[idx]) * _TAB_INVC[idx]
            r2 = r * r
            l1p = r - r2 * (0.5 - r * (0.3333333333333333 - r * (0.25 - r * (
                0.2 - r * (0.16666666666666666 - r * 0.14285714285714285)))))
            lg = np.float64(e) + _TAB_LOG2C[idx] + l1p * 1.4426950408889634
            normal = v >= _TINY
            s_acc[k] += v * lg if normal else 0.0
            m_acc[k] += v
            kpos[k] += v > 0.0
            nsub[k] += (v > 0.0) & (v < _TINY)


@njit(cache=True)
def _finish_rows(y, width, nrows, c0, c1, s_acc, m_acc, kpos, nsub, out):
    """Entropies (bits) of the columns ``[c0, c1)`` from their accumulated sums, into ``out``;
    subnormal entries (rare) are added exactly first."""
    for k in range(c0, c1):
        if nsub[k]:
            for row in range(nrows):
                v = y[row * width + k]
                if 0.0 < v < _TINY:
                    s_acc[k] += v * np.log2(v)
    for k in range(c0, c1):
        m = m_acc[k]
        kp = kpos[k]
        if kp <= 1 or m <= 0.0:
            out[k] = 0.0
            continue
        dm = m - 1.0
        lm = (dm - 0.5 * dm * dm) * _INV_LN2 if abs(dm) < 1e-5 else np.log2(m)
        h = lm - s_acc[k] / m
        hmax = _LOG2_INT[kp] if kp < _LOG2_INT.size else np.log2(kp)
        out[k] = min(max(h, 0.0), hmax)


@njit(cache=True, parallel=True)
def batch_images(img_ptr, img_idx, blk_rp_off, blk_en_off, blk_rowptr, blk_src, blk_val, first,
                 cell_ptr, cell_loc, n_cells_img, h0c, h0s, m0, seqs, chunk, has_partition,
                 out_hc, out_hs, drift):
    """Entropies of many sequences, level by level, for models whose distributions fill images.

    After its first action every distribution is a dense vector over the image of its last
    action (``first[a]`` is the distribution after a first action ``a``, in image order). A
    chunk of sequences is a matrix (image state x sequence); at every step its columns are
    sorted by (previous action, action) and each group is advanced by one sparse-times-dense
    product with that pair's gather block (:func:`image_blocks`, which carries the conservative
    correction), vectorized across the group's sequences, like its entropies (table log2, see
    :func:`_plogp`). ``cell_loc[cell_ptr[a] + j]`` is the local report cell of the ``j``-th
    state of ``a``'s image (``n_cells_img[a]`` cells). Memory per chunk: three
    (largest image x chunk) arrays."""
    s_count = seqs.shape[0]
    n_steps = seqs.shape[1]
    k_actions = img_ptr.size - 1
    max_img = 0
    max_cells = 1
    for a in range(k_actions):
        max_img = max(max_img, img_ptr[a + 1] - img_ptr[a])
        max_cells = max(max_cells, n_cells_img[a])
    n_chunks = (s_count + chunk - 1) // chunk
    for ci in prange(n_chunks):
        s0 = ci * chunk
        s1 = min(s_count, s0 + chunk)
        w = s1 - s0
        x = np.zeros(max_img * w)
        xs = np.zeros(max_img * w)
        y = np.zeros(max_img * w)
        ybits = y.view(np.int64)
        cm = np.zeros(max_cells * w)
        cmbits = cm.view(np.int64)
        colseq = np.empty(w, dtype=np.int64)
        colact = np.empty(w, dtype=np.int64)
        newseq = np.empty(w, dtype=np.int64)
        newact = np.empty(w, dtype=np.int64)
        perm = np.empty(w, dtype=np.uint64)
        counts = np.zeros(k_actions * k_actions + 1, dtype=np.int64)
        s_acc = np.empty(w)
        m_acc = np.empty(w)
        kpos = np.empty(w, dtype=np.int64)
        nsub = np.empty(w, dtype=np.int64)
        h_tmp = np.empty(w)
        # results of the chunk, row = sequence - s0 (copied out at the end: the scattered
        # writes stay in cache)
        loc_hc = np.empty((w, n_steps + 1))
        loc_hs = np.empty((w, n_steps + 1)) if has_partition else loc_hc
        loc_drift = np.zeros(w)
        uw = np.uint64(w)
        for k in range(w):
            loc_hc[k, 0] = h0c
            loc_hs[k, 0] = h0s
        for k in range(w):
            colseq[k] = s0 + k
            colact[k] = 0
        for t in range(n_steps):
            # group the columns by (previous action, action): counting sort
            for g in range(k_actions * k_actions + 1):
                counts[g] = 0
            for k in range(w):
                counts[colact[k] * k_actions + seqs[colseq[k], t] + 1] += 1
            for g in range(k_actions * k_actions):
                counts[g + 1] += counts[g]
            for k in range(w):
                g = colact[k] * k_actions + seqs[colseq[k], t]
                perm[counts[g]] = k
                counts[g] += 1
            # counts[g] is now the end of group g, counts[g - 1] its start
            if t > 0:
                # columns in group order: the products below run over contiguous memory
                for r in range(max_img):
                    base = np.uint64(r * w)
                    for k in range(uw):
                        xs[base + k] = x[base + perm[k]]
            for g in range(k_actions * k_actions):
                c0 = counts[g - 1] if g > 0 else 0
                c1 = counts[g]
                if c1 == c0:
                    continue
                uc0 = np.uint64(c0)
                uc1 = np.uint64(c1)
                a = g % k_actions
                na = img_ptr[a + 1] - img_ptr[a]
                if t == 0:
                    for r in range(na):
                        base = np.uint64(r * w)
                        v = first[a, r]
                        for k in range(uc0, uc1):
                            y[base + k] = v
                else:
                    rp = blk_rp_off[g]
                    eo = blk_en_off[g]
                    for r in range(na):
                        base = np.uint64(r * w)
                        for k in range(uc0, uc1):
                            y[base + k] = 0.0
                        for e in range(eo + blk_rowptr[rp + r], eo + blk_rowptr[rp + r + 1]):
                            val = blk_val[e]
                            sb = np.uint64(blk_src[e] * w)
                            for k in range(uc0, uc1):
                                y[base + k] += val * xs[sb + k]
                for k in range(c0, c1):
                    newseq[k] = colseq[perm[k]]
                    newact[k] = a
                # entropies of the group's columns: states, then report cells
                _rows_plogp(y, ybits, w, na, c0, c1, s_acc, m_acc, kpos, nsub)
                _finish_rows(y, w, na, c0, c1, s_acc, m_acc, kpos, nsub, h_tmp)
                for k in range(c0, c1):
                    sq = newseq[k] - s0
                    loc_hs[sq, t + 1] = h_tmp[k]
                    dev = abs(m_acc[k] - m0)
                    if dev > loc_drift[sq]:
                        loc_drift[sq] = dev
                if has_partition:
                    nci = n_cells_img[a]
                    for r in range(nci):
                        base = np.uint64(r * w)
                        for k in range(uc0, uc1):
                            cm[base + k] = 0.0
                    cp = cell_ptr[a]
                    for r in range(na):
                        base = np.uint64(r * w)
                        cb = np.uint64(cell_loc[cp + r] * w)
                        for k in range(uc0, uc1):
                            cm[cb + k] += y[base + k]
                    _rows_plogp(cm, cmbits, w, nci, c0, c1, s_acc, m_acc, kpos, nsub)
                    _finish_rows(cm, w, nci, c0, c1, s_acc, m_acc, kpos, nsub, h_tmp)
                    for k in range(c0, c1):
                        loc_hc[newseq[k] - s0, t + 1] = h_tmp[k]
            x, y = y, x
            ybits = y.view(np.int64)
            colseq, newseq = newseq, colseq
            colact, newact = newact, colact
        for k in range(w):
            for t in range(n_steps + 1):
                out_hc[s0 + k, t] = loc_hc[k, t]
                out_hs[s0 + k, t] = loc_hs[k, t]
            drift[s0 + k] = loc_drift[k]
