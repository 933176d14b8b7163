"""Numba kernels of the plan search (:mod:`kruskal_markov.sync.plan`): sparse images of state sets
and distributions, the target tests, the admissible bounds, and a resumable depth-first
(IDA*) pass with a memory-bounded transposition table.

A search node is a sorted vector of states ``idx[:m]`` (the support of the image of the start set)
with values ``val[:m]`` (probabilities; unused for the set targets). States of several models are
numbered consecutively (a disjoint union): ``model_of[q]`` is the model of state ``q`` and
``cell[q]`` its report cell (local to its model; for the ``state`` target ``cell[q] = q``).
Kinds: ``0`` = all states of every model in one cell (targets ``state`` and ``cell``),
``1`` = at least ``thr`` of every model's probability in one cell (target ``probability:E``).

Every kernel this file's kernels call lives in this file (Numba's cache does not see other files).
"""
from __future__ import annotations

import numpy as np
from numba import njit

_MUL = np.uint64(0x9E3779B97F4A7C15)
_ZERO = np.uint64(0)
#: values are compared in the transposition table after rounding to multiples of 2**-40
_QUANT = float(2 ** 40)


@njit(cache=True)
def image(idx, val, m, a, kind, indptr, indices, probs, acc, mark, stamp, out_idx, out_val):
    """Image of node ``(idx[:m], val[:m])`` under letter ``a`` into ``out_idx``/``out_val`` (sorted);
    returns its size. ``acc`` (float64, n) and ``mark`` (int64, n) are work arrays; ``stamp`` is a
    value never used before in ``mark``."""
    cnt = 0
    for t in range(m):
        q = idx[t]
        for e in range(indptr[a, q], indptr[a, q + 1]):
            r = indices[e]
            if mark[r] != stamp:
                mark[r] = stamp
                out_idx[cnt] = r
                cnt += 1
                acc[r] = 0.0
            if kind == 1:
                acc[r] += val[t] * probs[e]
    out_idx[:cnt].sort()
    if kind == 1:
        for t in range(cnt):
            out_val[t] = acc[out_idx[t]]
    return cnt


@njit(cache=True)
def goal(idx, val, m, kind, cell, model_of, n_models, n_cells, thr, cellmass, out_cells):
    """True if the node meets the target under every model; ``out_cells[model]`` = its cell."""
    if kind == 0:
        for t in range(n_models):
            out_cells[t] = -1
        for t in range(m):
            q = idx[t]
            g = model_of[q]
            if out_cells[g] == -1:
                out_cells[g] = cell[q]
            elif out_cells[g] != cell[q]:
                return False
        return True
    cellmass[:, :] = 0.0
    for t in range(m):
        q = idx[t]
        cellmass[model_of[q], cell[q]] += val[t]
    for g in range(n_models):
        best = -1
        bm = -1.0
        for c in range(n_cells):
            if cellmass[g, c] > bm:
                bm = cellmass[g, c]
                best = c
        out_cells[g] = best
        if bm < thr - 1e-12:
            return False
    return True


@njit(cache=True)
def cell_masks(indptr, indices, cell, n, Wc, R):
    """``within[r, q]``: bitset of the cells ``c`` (of ``q``'s model) into which some word of length at
    most ``r`` drives every successor of ``q`` (support semantics); ``r = 0..R``. Returns
    ``(within, saturated_at)``: from ``saturated_at`` (or -1) on the masks no longer change."""
    k = indptr.shape[0]
    exact = np.zeros((n, Wc), dtype=np.uint64)
    within = np.zeros((R + 1, n, Wc), dtype=np.uint64)
    for q in range(n):
        c = cell[q]
        exact[q, c >> 6] |= np.uint64(1) << np.uint64(c & 63)
    within[0] = exact
    sat = -1
    nxt = np.zeros((n, Wc), dtype=np.uint64)
    tmp = np.zeros(Wc, dtype=np.uint64)
    for r in range(1, R + 1):
        nxt[:, :] = _ZERO
        for q in range(n):
            for a in range(k):
                for w in range(Wc):
                    tmp[w] = ~_ZERO
                for e in range(indptr[a, q], indptr[a, q + 1]):
                    s = indices[e]
                    for w in range(Wc):
                        tmp[w] &= exact[s, w]
                for w in range(Wc):
                    nxt[q, w] |= tmp[w]
        changed = False
        for q in range(n):
            for w in range(Wc):
                if exact[q, w] != nxt[q, w]:
                    changed = True
                exact[q, w] = nxt[q, w]
                within[r, q, w] = within[r - 1, q, w] | nxt[q, w]
        if not changed and sat < 0:
            sat = r - 1         # a fixed point of the exact sets: nothing changes from here on
    return within, sat


@njit(cache=True)
def value_tables(indptr, indices, probs, cell, n, C, R):
    """``V[r, q, c]``: the largest probability, over words of length exactly ``r`` chosen with the
    state known (the fully observable relaxation), of ending in cell ``c`` from state ``q``. An upper
    bound on what any one word achieves from a distribution: ``sum_q p(q) V[r, q, c]``."""
    k = indptr.shape[0]
    V = np.zeros((R + 1, n, C), dtype=np.float32)
    for q in range(n):
        V[0, q, cell[q]] = 1.0
    tmp = np.zeros(C, dtype=np.float64)
    for r in range(1, R + 1):
        for q in range(n):
            for a in range(k):
                tmp[:] = 0.0
                for e in range(indptr[a, q], indptr[a, q + 1]):
                    s = indices[e]
                    for c in range(C):
                        tmp[c] += probs[e] * V[r - 1, s, c]
                for c in range(C):
                    # round up by one float32 ulp-ish margin so that the bound stays admissible
                    v = tmp[c] * (1.0 + 1e-6) + 1e-7
                    if v > V[r, q, c]:
                        V[r, q, c] = min(1.0, v)
    return V


@njit(cache=True)
def feasible(idx, val, m, kind, rem, model_of, n_models, masks, msat, V, pd, n_pd, thr, work):
    """False when no word of length <= ``rem`` can reach the target from the node (admissible
    pruning). ``masks`` (kind 0) / ``V`` (kind 1) may be empty (shape[0] == 0): then not used; ``pd``
    (pair merging distances, ``n_pd`` states, kind 0 target ``state`` only) likewise."""
    if kind == 0:
        R = masks.shape[0] - 1
        if R >= 0:
            r = rem
            if r > R:
                r = R if (msat >= 0 and msat <= R) else -1
            if r >= 0:
                Wc = masks.shape[2]
                g_prev = -1
                for t in range(m + 1):
                    g = model_of[idx[t]] if t < m else -2
                    if g != g_prev:
                        if g_prev >= 0:
                            ok = False
                            for w in range(Wc):
                                if work[w] != _ZERO:
                                    ok = True
                            if not ok:
                                return False
                        if g >= 0:
                            for w in range(Wc):
                                work[w] = ~_ZERO
                        g_prev = g
                    if g >= 0:
                        q = idx[t]
                        for w in range(Wc):
                            work[w] &= masks[r, q, w]
        if n_pd > 0:
            for i in range(m):
                p = idx[i]
                for j in range(i + 1, m):
                    q = idx[j]
                    if model_of[p] != model_of[q]:
                        continue
                    d = pd[p * n_pd - (p * (p + 1)) // 2 + (q - p - 1)]
                    if d < 0 or d > rem:
                        return False
        return True
    R = V.shape[0] - 1
    if R < 0 or rem > R:
        return True
    C = V.shape[2]
    for r in range(rem + 1):
        all_ok = True
        for g in range(n_models):
            best = 0.0
            for c in range(C):
                s = 0.0
                for t in range(m):
                    q = idx[t]
                    if model_of[q] == g:
                        s += val[t] * V[r, q, c]
                if s > best:
                    best = s
            if best < thr - 1e-9:
                all_ok = False
                break
        if all_ok:
            return True
    return False


@njit(cache=True)
def _hash(idx, val, m, kind):
    h = np.uint64(0xCBF29CE484222325)
    for t in range(m):
        h = (h ^ np.uint64(idx[t])) * _MUL
        h ^= h >> np.uint64(29)
        if kind == 1:
            h = (h ^ np.uint64(np.int64(val[t] * _QUANT + 0.5))) * _MUL
            h ^= h >> np.uint64(31)
    return h


@njit(cache=True)
def tt_visit(idx, val, m, kind, depth, table, e_off, e_len, e_depth, pool_i, pool_v, tstate):
    """Transposition table: True if the node was already expanded at a depth <= ``depth`` in this pass
    (skip it); otherwise record it (if the pool has room) and return False. ``tstate`` =
    ``[entries, pool_used, 1 once a node found no room]``; nodes are stored whole (no false matches: exactness is kept)."""
    mask = np.uint64(table.shape[0] - 1)
    slot = _hash(idx, val, m, kind) & mask
    while True:
        j = table[slot]
        if j == -1:
            break
        if e_len[j] == m:
            same = True
            o = e_off[j]
            for t in range(m):
                if pool_i[o + t] != idx[t]:
                    same = False
                    break
                if kind == 1 and pool_v[o + t] != np.int64(val[t] * _QUANT + 0.5):
                    same = False
                    break
            if same:
                if e_depth[j] <= depth:
                    return True
                e_depth[j] = depth
                return False
        slot = (slot + np.uint64(1)) & mask
    ne = tstate[0]
    used = tstate[1]
    if ne >= e_off.shape[0] or used + m > pool_i.shape[0] or 2 * (ne + 1) > table.shape[0]:
        tstate[2] = 1                       # full: no record (said in the notes), the search stays exact
        return False
    e_off[ne] = used
    e_len[ne] = m
    e_depth[ne] = depth
    for t in range(m):
        pool_i[used + t] = idx[t]
        if kind == 1:
            pool_v[used + t] = np.int64(val[t] * _QUANT + 0.5)
    table[slot] = ne
    tstate[0] = ne + 1
    tstate[1] = used + m
    return False


@njit(cache=True)
def dfs_pass(D, kind, indptr, indices, probs, cell, model_of, n_models, n_cells, thr,
             masks, msat, V, pd, n_pd,
             st_idx, st_val, st_len, letter_at, word, st, quota,
             acc, mark, cellmass, out_cells, work,
             table, e_off, e_len, e_depth, pool_i, pool_v, tstate):
    """One resumable depth-first pass with depth bound ``D`` (IDA*: Korf 1985).

    The stack (``st_idx[d, :st_len[d]]``, ``st_val``, ``letter_at[d]``, ``word[:d]``) and the scalars
    ``st = [depth, nodes, cut, stamp]`` live in arrays, so the pass can stop after ``quota`` images and
    resume. Level 0 must hold the start node and ``st[0] = 0`` at the first call. ``cut`` is set when a
    node is left unexpanded for a depth-dependent reason (the bound ``D`` or a length-dependent
    pruning): a pass without a cut has exhausted every reachable node.
    Returns ``1`` (a target node at depth ``st[0]``; its word is ``word[:st[0]]``), ``0`` (pass
    complete, nothing found), ``-1`` (quota used up; call again).
    """
    k = indptr.shape[0]
    d = st[0]
    done = 0
    while d >= 0:
        if done >= quota:
            st[0] = d
            return -1
        if letter_at[d] >= k:
            d -= 1
            continue
        a = letter_at[d]
        letter_at[d] += 1
        st[3] += 1
        m = image(st_idx[d], st_val[d], st_len[d], a, kind, indptr, indices, probs, acc, mark, st[3],
                  st_idx[d + 1], st_val[d + 1])
        st_len[d + 1] = m
        done += 1
        st[1] += 1
        word[d] = a
        if goal(st_idx[d + 1], st_val[d + 1], m, kind, cell, model_of, n_models, n_cells, thr, cellmass,
                out_cells):
            st[0] = d + 1
            return 1
        rem = D - (d + 1)
        if rem <= 0:
            st[2] = 1
            continue
        if not feasible(st_idx[d + 1], st_val[d + 1], m, kind, rem, model_of, n_models, masks, msat, V,
                        pd, n_pd, thr, work):
            if kind == 1 or msat < 0 or rem < msat or n_pd > 0:
                st[2] = 1
            continue
        if tt_visit(st_idx[d + 1], st_val[d + 1], m, kind, d + 1, table, e_off, e_len, e_depth, pool_i,
                    pool_v, tstate):
            continue
        d += 1
        letter_at[d] = 0
    st[0] = 0
    return 0


@njit(cache=True)
def random_words_success(idx0, val0, m0, kind, indptr, indices, probs, cell, model_of, n_models, n_cells,
                         thr, words, acc, mark, cellmass, out_cells, out):
    """``out[i, L]`` = 1 if the first ``L`` letters of ``words[i]`` reach the target (L = 0..len)."""
    n = acc.shape[0]
    cur_i = np.empty(n, dtype=np.int32)
    cur_v = np.empty(n, dtype=np.float64)
    nxt_i = np.empty(n, dtype=np.int32)
    nxt_v = np.empty(n, dtype=np.float64)
    stamp = 1
    for i in range(words.shape[0]):
        m = m0
        cur_i[:m] = idx0[:m]
        cur_v[:m] = val0[:m]
        out[i, 0] = 1 if goal(cur_i, cur_v, m, kind, cell, model_of, n_models, n_cells, thr, cellmass,
                              out_cells) else 0
        for t in range(words.shape[1]):
            stamp += 1
            m = image(cur_i, cur_v, m, words[i, t], kind, indptr, indices, probs, acc, mark, stamp,
                      nxt_i, nxt_v)
            cur_i[:m] = nxt_i[:m]
            cur_v[:m] = nxt_v[:m]
            out[i, t + 1] = 1 if goal(cur_i, cur_v, m, kind, cell, model_of, n_models, n_cells, thr,
                                      cellmass, out_cells) else 0
