"""Numba kernels for synchronization: subsets as bitsets (``uint64`` words), hashed subset stores,
forward (image) and inverse (preimage) breadth-first levels, the subset-inclusion meet test, the
pair graph and Eppstein's greedy pair merging.

All kernels take arrays and write into preallocated arrays; nothing here allocates randomness.
A letter is given twice: ``delta[a, q]`` (next state, deterministic automata; ``-1`` rows mean
"use ``sup``") and ``sup[a, q, :]`` (bitset of the support of row ``q`` of action ``a``). For a
set-valued (support) automaton the image of a set is the union of the supports of its states and
the preimage of ``S`` is ``{q : supp(q, a) is a subset of S}``.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

_ONE = np.uint64(1)
_ZERO = np.uint64(0)
_ALL = np.uint64(0xFFFFFFFFFFFFFFFF)
_MUL = np.uint64(0x9E3779B97F4A7C15)


@njit(cache=True, inline="always")
def _popcount(x):
    x = x - ((x >> np.uint64(1)) & np.uint64(0x5555555555555555))
    x = (x & np.uint64(0x3333333333333333)) + ((x >> np.uint64(2)) & np.uint64(0x3333333333333333))
    x = (x + (x >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return int((x * np.uint64(0x0101010101010101)) >> np.uint64(56))


@njit(cache=True, inline="always")
def _ctz(x):
    # index of the lowest set bit of a non-zero word
    return _popcount((x & (~x + np.uint64(1))) - np.uint64(1))


@njit(cache=True)
def _hash_row(store, i):
    h = np.uint64(0xCBF29CE484222325)
    for w in range(store.shape[1]):
        h = (h ^ store[i, w]) * _MUL
        h ^= h >> np.uint64(29)
    return h


@njit(cache=True)
def _rows_equal(store, i, j):
    for w in range(store.shape[1]):
        if store[i, w] != store[j, w]:
            return False
    return True


@njit(cache=True)
def set_size(store, i):
    c = 0
    for w in range(store.shape[1]):
        c += _popcount(store[i, w])
    return c


@njit(cache=True)
def rehash(store, count, table):
    """Fill ``table`` (power-of-two length, int64, reset to -1 here) with rows ``0..count-1``."""
    table[:] = -1
    mask = np.uint64(table.shape[0] - 1)
    for i in range(count):
        slot = _hash_row(store, i) & mask
        while table[slot] != -1:
            slot = (slot + _ONE) & mask
        table[slot] = i


@njit(cache=True)
def _insert_last(store, count, table):
    """Insert row ``count`` if new; return True when inserted."""
    mask = np.uint64(table.shape[0] - 1)
    slot = _hash_row(store, count) & mask
    while True:
        j = table[slot]
        if j == -1:
            table[slot] = count
            return True
        if _rows_equal(store, j, count):
            return False
        slot = (slot + _ONE) & mask


@njit(cache=True)
def expand_level(store, count, lo, hi, delta, sup, det, forward, table, parent, letter, max_count,
                 inv_ptr, inv_idx, supcount):
    """Append to ``store`` the new images (``forward``) or non-empty preimages of rows ``lo..hi-1``.

    Rows are appended from ``count``; ``parent``/``letter`` record where each new row came from.
    Preimages use the inverse adjacency (``inv_ptr[a, r]..inv_ptr[a, r+1]`` indexes into ``inv_idx``
    the states ``q`` with ``r`` in ``supp(q, a)``) and ``supcount[a, q] = |supp(q, a)|``: ``q`` is in
    the preimage of ``S`` when all its successors are in ``S``.
    Returns the new count, or ``-1`` if ``max_count`` would be exceeded (the store then holds a
    partial level that the caller discards).
    """
    k = delta.shape[0]
    n = delta.shape[1]
    W = store.shape[1]
    cnt = np.zeros(n, dtype=np.int64)
    elems = np.empty(n, dtype=np.int64)
    tab = det and sup.shape[1] > 1
    m = 0
    for i in range(lo, hi):
        if not tab:
            m = _members(store, i, elems)
        for a in range(k):
            if count >= max_count:
                return -1
            for w in range(W):
                store[count, w] = _ZERO
            if tab:
                if _image_row_tab(store, count, store, i, a, sup):
                    continue
            elif _image_row(store, count, elems, m, a, delta, sup, det, forward, inv_ptr, inv_idx, supcount, cnt):
                continue
            if _insert_last(store, count, table):
                parent[count] = i
                letter[count] = a
                count += 1
    return count


@njit(cache=True)
def insert_images(store, count, images, first_parent, k, table, parent, letter, max_count):
    """Append to ``store`` the rows of ``images`` not stored yet (zero rows, empty preimages,
    skipped), in order; row ``j`` of ``images`` is the image of store row ``first_parent + j // k``
    under letter ``j % k`` (the layout of :func:`level_images`). Same rows, parents and letters as
    :func:`expand_level` on those parents. Returns the new count, or ``-1`` if ``max_count`` would
    be exceeded."""
    W = store.shape[1]
    for j in range(images.shape[0]):
        if count >= max_count:
            return -1
        nonzero = False
        for w in range(W):
            if images[j, w] != _ZERO:
                nonzero = True
                break
        if not nonzero:
            continue
        for w in range(W):
            store[count, w] = images[j, w]
        if _insert_last(store, count, table):
            parent[count] = first_parent + j // k
            letter[count] = j % k
            count += 1
    return count


@njit(cache=True)
def _images_into(out, rows, lo, hi, base, delta, sup, det, forward, inv_ptr, inv_idx, supcount):
    """Rows ``lo..hi-1``'s images into ``out[(i - base) k + a]`` (one thread's share)."""
    k = delta.shape[0]
    n = delta.shape[1]
    cnt = np.zeros(n, dtype=np.int64)
    elems = np.empty(n, dtype=np.int64)
    tab = det and sup.shape[1] > 1
    for i in range(lo, hi):
        if tab:
            for a in range(k):
                _image_row_tab(out, (i - base) * k + a, rows, i, a, sup)
            continue
        m = _members(rows, i, elems)
        for a in range(k):
            _image_row(out, (i - base) * k + a, elems, m, a, delta, sup, det, forward, inv_ptr, inv_idx, supcount,
                       cnt)


@njit(cache=True, parallel=True)
def _level_images_par(out, rows, lo, hi, tasks, delta, sup, det, forward, inv_ptr, inv_idx, supcount):
    step = (hi - lo + tasks - 1) // tasks
    for t in prange(tasks):
        a = lo + t * step
        b = min(hi, a + step)
        if a < b:
            _images_into(out, rows, a, b, lo, delta, sup, det, forward, inv_ptr, inv_idx, supcount)


#: rows per task below which :func:`level_images` runs on one thread
_IMAGES_PAR_MIN = 8192


def level_images(rows, lo, hi, delta, sup, det, forward, inv_ptr, inv_idx, supcount, tasks=8,
                 min_parallel=_IMAGES_PAR_MIN):
    """The images (``forward``) or preimages of rows ``lo..hi-1`` under every letter, unhashed:
    row ``(i - lo) k + a`` of the result is the image of row ``i`` under letter ``a`` (an empty
    preimage is a zero row). The last level of a search, which is only tested, never expanded
    again, needs no duplicate removal (same arithmetic as :func:`expand_level`). Rows are split
    into ``tasks`` slices run on Numba's threads (both cores) when ``hi - lo >= 2 min_parallel``;
    the result does not depend on the split."""
    k = delta.shape[0]
    out = np.zeros(((hi - lo) * k, rows.shape[1]), dtype=np.uint64)
    if tasks > 1 and hi - lo >= 2 * min_parallel:
        _level_images_par(out, rows, lo, hi, tasks, delta, sup, det, forward, inv_ptr, inv_idx, supcount)
    else:
        _images_into(out, rows, lo, hi, lo, delta, sup, det, forward, inv_ptr, inv_idx, supcount)
    return out


@njit(cache=True, inline="always")
def _image_row_tab(out, o, src, i, a, tab):
    """OR into the (zeroed) row ``out[o]`` the image or preimage of ``src[i]`` under letter ``a`` by
    byte tables (``SyncAutomaton.step_table``: ``tab[a, 256 j + v]`` for byte ``j`` of value
    ``v``), one table row per non-zero byte; returns whether the result is empty."""
    W = src.shape[1]
    for w in range(W):
        x = src[i, w]
        while x != _ZERO:
            sh = np.uint64(_ctz(x) & 56)               # the lowest non-zero byte's shift
            v = (x >> sh) & np.uint64(255)
            x &= ~(np.uint64(255) << sh)
            t = (w * 8 + int(sh >> np.uint64(3))) * 256 + int(v)
            for u in range(W):
                out[o, u] |= tab[a, t, u]
    for u in range(W):
        if out[o, u] != _ZERO:
            return False
    return True


@njit(cache=True, inline="always")
def _image_row(out, o, elems, m, a, delta, sup, det, forward, inv_ptr, inv_idx, supcount, cnt):
    """OR into the (zeroed) bitset row ``out[o]`` the image (``forward``) or preimage under letter
    ``a`` of the set ``elems[:m]``; returns whether it is empty (an image of a non-empty set never is).
    A preimage of a set-valued automaton counts, per state ``q``, its successors inside the set
    (``cnt``, left all zero); a deterministic one is the union of the members' inverse lists."""
    if forward:
        for t in range(m):
            q = elems[t]
            if det:
                r = delta[a, q]
                out[o, r >> 6] |= _ONE << np.uint64(r & 63)
            else:
                for v in range(out.shape[1]):
                    out[o, v] |= sup[a, q, v]
        return False
    empty = True
    if det:     # one successor per state: q is in the preimage when delta[a, q] is, no counting
        for t in range(m):
            r = elems[t]
            for e in range(inv_ptr[a, r], inv_ptr[a, r + 1]):
                q = inv_idx[e]
                out[o, q >> 6] |= _ONE << np.uint64(q & 63)
                empty = False
        return empty
    for t in range(m):
        r = elems[t]
        for e in range(inv_ptr[a, r], inv_ptr[a, r + 1]):
            q = inv_idx[e]
            cnt[q] += 1
            if cnt[q] == supcount[a, q]:
                out[o, q >> 6] |= _ONE << np.uint64(q & 63)
                empty = False
    for t in range(m):          # reset the counters touched above
        r = elems[t]
        for e in range(inv_ptr[a, r], inv_ptr[a, r + 1]):
            cnt[inv_idx[e]] = 0
    return empty


@njit(cache=True, inline="always")
def _members(rows, i, elems):
    """The states of bitset row ``i`` into ``elems[:m]``, in increasing order; returns ``m``."""
    m = 0
    for w in range(rows.shape[1]):
        x = rows[i, w]
        while x != _ZERO:
            b = _ctz(x)
            x &= x - _ONE
            elems[m] = w * 64 + b
            m += 1
    return m


@njit(cache=True, inline="always")
def _elems_by_freq(rows, i, freq, elems):
    """The states of row ``i`` into ``elems[:m]``, rarest first (insertion sort by ``freq``: rare
    states first make the AND over their inverted-index rows vanish sooner); returns ``m``."""
    m = _members(rows, i, elems)
    for u in range(1, m):
        e = elems[u]
        t = u
        while t > 0 and freq[elems[t - 1]] > freq[e]:
            elems[t] = elems[t - 1]
            t -= 1
        elems[t] = e
    return m


@njit(cache=True, inline="always")
def _count_at_least(size, order, start, stop, m):
    """How many of the positions ``start..stop-1`` (sizes ``size[order[.]]`` non-increasing) hold
    a size ``>= m`` (they come first): binary search."""
    lo_ = start
    hi_ = stop
    while lo_ < hi_:
        mid = (lo_ + hi_) // 2
        if size[order[mid]] >= m:
            lo_ = mid + 1
        else:
            hi_ = mid
    return lo_ - start


def _meet_query_py(fstore, flo, fhi, inv, freq, bsize, order, start, stop, chunk, flag, res):
    """Query forward rows against one block of the inverted index, ``chunk`` rows per parallel task.

    Task ``t`` writes its meeting pair only into ``res[t]``; any pair is optimal (all pairs tested
    have the same total depth), so the shared ``flag`` is only a hint for the others to stop early.
    """
    n = inv.shape[0]
    ntasks = (fhi - flo + chunk - 1) // chunk
    for task in prange(ntasks):
        if flag[0] != 0:
            continue
        elems = np.empty(n, dtype=np.int64)
        for i in range(flo + task * chunk, min(fhi, flo + (task + 1) * chunk)):
            if flag[0] != 0:
                break
            m = _elems_by_freq(fstore, i, freq, elems)
            if m > 0 and freq[elems[0]] == 0:
                continue
            # backward sets of this block with size >= m: positions [0, cnt)
            cnt = _count_at_least(bsize, order, start, stop, m)
            used = (cnt + 63) // 64
            for v in range(used):
                acc = _ALL
                for t in range(m):
                    acc &= inv[elems[t], v]
                    if acc == _ZERO:
                        break
                if acc != _ZERO:
                    res[task, 0] = i
                    res[task, 1] = start + v * 64 + _ctz(acc)
                    flag[0] = 1
                    break
            if res[task, 0] >= 0:
                break


_meet_query_par = njit(cache=True, parallel=True)(_meet_query_py)
_meet_query_seq = njit(cache=True)(_meet_query_py)


@njit(cache=True)
def _meet_index(bstore, blo, order, start, stop, inv, freq):
    inv[:, :] = _ZERO
    freq[:] = 0
    elems = np.empty(freq.shape[0], dtype=np.int64)
    for jj in range(stop - start):
        bit = _ONE << np.uint64(jj & 63)
        for t in range(_members(bstore, blo + order[start + jj], elems)):
            inv[elems[t], jj >> 6] |= bit
            freq[elems[t]] += 1


@njit(cache=True)
def _level_sizes(store, lo, hi):
    out = np.empty(hi - lo, dtype=np.int64)
    for j in range(hi - lo):
        out[j] = set_size(store, lo + j)
    return out


class MeetIndex:
    """The inverted index of backward rows ``blo..bhi-1`` for repeated meet queries.

    For each state, the bitset of the backward rows containing it, block by block of ``block`` rows
    taken in decreasing size, so that a forward set of size ``s`` only scans the backward sets of
    size ``>= s``. Built once per backward level and kept while it fits ``max_bytes`` (otherwise
    each query rebuilds the blocks in turn): the breadth-first search queries a level slice by
    slice and the depth-first phase queries it once per chunk, and rebuilding the index for every
    slice cost more than the queries themselves (issue 43: 156 rebuilds of 0.25 s out of 0.9 s on
    a random 8-letter automaton of 70 states).
    """

    def __init__(self, bstore, blo, bhi, n, block, max_bytes=256 * 2 ** 20):
        self.bstore, self.blo, self.n = bstore, blo, n
        self.nb = max(0, bhi - blo)
        self.bsize = _level_sizes(bstore, blo, bhi) if self.nb else np.zeros(0, dtype=np.int64)
        self.order = np.argsort(-self.bsize, kind="stable")
        self.words = (block + 63) // 64
        self.spans = [(start, min(self.nb, start + block)) for start in range(0, self.nb, block)]
        self.cache = None
        if n * self.words * 8 * len(self.spans) <= max_bytes:
            self.cache = [self._build(start, stop) for start, stop in self.spans]

    def _build(self, start, stop, inv=None, freq=None):
        if inv is None:
            inv = np.zeros((self.n, self.words), dtype=np.uint64)
            freq = np.zeros(self.n, dtype=np.int64)
        _meet_index(self.bstore, self.blo, self.order, start, stop, inv, freq)
        return inv, freq

    def query(self, fstore, flo, fhi, chunk=256, parallel=None):
        """``(f, b)`` with forward row ``f`` in ``flo..fhi-1`` a subset of backward row ``b``, or
        ``(-1, -1)``; forward rows are queried in parallel (``parallel=None``: threads only for
        large blocks, where they pay for their start-up)."""
        if self.nb <= 0 or fhi <= flo:
            return -1, -1
        flag = np.zeros(1, dtype=np.int64)
        res = np.full(((fhi - flo + chunk - 1) // chunk, 2), -1, dtype=np.int64)
        inv = freq = None
        for s_, (start, stop) in enumerate(self.spans):
            if self.cache is not None:
                inv, freq = self.cache[s_]
            else:
                inv, freq = self._build(start, stop, inv, freq)
            par = (fhi - flo) * (stop - start) > 4_000_000 if parallel is None else parallel
            query = _meet_query_par if par else _meet_query_seq
            query(fstore, flo, fhi, inv, freq, self.bsize, self.order, start, stop, chunk, flag, res)
            hits = np.flatnonzero(res[:, 0] >= 0)
            if hits.size:
                f, j = res[hits[0]]
                return int(f), int(self.blo + self.order[j])
        return -1, -1


def meet(fstore, flo, fhi, bstore, blo, bhi, n, block, chunk=256, parallel=None):
    """Find ``F`` in forward rows ``flo..fhi-1`` and ``B`` in backward rows ``blo..bhi-1`` with F <= B
    (one query of a fresh :class:`MeetIndex`). Returns ``(f, b)`` or ``(-1, -1)``."""
    return MeetIndex(bstore, blo, bhi, n, block).query(fstore, flo, fhi, chunk, parallel)


@njit(cache=True)
def apply_word(bits, word, delta, sup, det):
    """Image of the bitset ``bits`` under ``word`` (returns a new bitset)."""
    W = bits.shape[0]
    cur = bits.copy().reshape(1, W)
    nxt = np.zeros(W, dtype=np.uint64)
    elems = np.empty(W * 64, dtype=np.int64)
    for t in range(word.shape[0]):
        a = word[t]
        nxt[:] = _ZERO
        for u in range(_members(cur, 0, elems)):
            q = elems[u]
            if det:
                r = delta[a, q]
                nxt[r >> 6] |= _ONE << np.uint64(r & 63)
            else:
                for v in range(W):
                    nxt[v] |= sup[a, q, v]
        cur[0, :] = nxt
    return cur[0].copy()


# ----------------------------------------------------------------------------- pair graph
@njit(cache=True, inline="always")
def pair_index(p, q, n):
    # twin of kruskal_markov._subsets.pair_index (a kernel-local copy, inlined by Numba)
    if p > q:
        p, q = q, p
    return p * n - (p * (p + 1)) // 2 + (q - p - 1)


@njit(cache=True)
def _pair_edges(indptr, indices, n, counting, indeg, dist, nxt, queue, fill, radj, rlet):
    """Walk the pair graph's edges {p,q} --a--> {p',q'} in a fixed order (action, p < q, then
    their successors). ``counting``: count each edge into an unmerged pair in ``indeg[target + 1]``
    and queue every pair that some letter merges (``dist`` 1, ``nxt`` that letter), returning the
    queue's length; otherwise write each edge's source and letter at ``fill[target]`` of
    ``radj`` / ``rlet`` (the reverse adjacency), returning 0."""
    qlen = 0
    for a in range(indptr.shape[0]):
        for p in range(n):
            for q in range(p + 1, n):
                src = pair_index(p, q, n)
                for s in range(indptr[a, p], indptr[a, p + 1]):
                    for t in range(indptr[a, q], indptr[a, q + 1]):
                        pp = indices[s]
                        qq = indices[t]
                        if pp == qq:
                            if counting and dist[src] == -1:
                                dist[src] = 1
                                nxt[src] = a
                                queue[qlen] = src
                                qlen += 1
                        elif counting:
                            indeg[pair_index(pp, qq, n) + 1] += 1
                        else:
                            d = pair_index(pp, qq, n)
                            radj[fill[d]] = src
                            rlet[fill[d]] = a
                            fill[d] += 1
    return qlen


@njit(cache=True)
def pair_merge_distance(indptr, indices, n):
    """Shortest merging length of every pair (``-1`` if no word merges it) by inverse BFS.

    Edges: pair {p,q} --a--> {p',q'} for p' in supp(p,a), q' in supp(q,a) (for deterministic
    automata exactly the pair automaton). A pair is merged in one step if some choice gives p'=q'.
    Returns ``(dist, nxt_letter)`` over pair indices (``pair_index``), ``nxt_letter`` being the first
    letter of a shortest merging word.
    """
    P = n * (n - 1) // 2
    dist = np.full(P, -1, dtype=np.int64)
    nxt = np.full(P, -1, dtype=np.int32)
    queue = np.empty(P, dtype=np.int64)
    # reverse adjacency in CSR: count in-degrees (and queue the pairs merged in one step) first
    indeg = np.zeros(P + 1, dtype=np.int64)
    radj = np.empty(0, dtype=np.int64)
    rlet = np.empty(0, dtype=np.int32)
    qlen = _pair_edges(indptr, indices, n, True, indeg, dist, nxt, queue, indeg, radj, rlet)
    for i in range(P):
        indeg[i + 1] += indeg[i]
    fill = indeg[:P].copy()
    radj = np.empty(indeg[P], dtype=np.int64)
    rlet = np.empty(indeg[P], dtype=np.int32)
    _pair_edges(indptr, indices, n, False, indeg, dist, nxt, queue, fill, radj, rlet)
    head = 0
    while head < qlen:
        cur = queue[head]
        head += 1
        for e in range(indeg[cur], indeg[cur + 1]):
            src = radj[e]
            if dist[src] == -1:
                dist[src] = dist[cur] + 1
                nxt[src] = rlet[e]
                queue[qlen] = src
                qlen += 1
    return dist, nxt


@njit(cache=True)
def eppstein_greedy(delta, start, dist, nxt, out_word):
    """Eppstein's (1990) greedy: repeatedly merge the pair of the current set with the shortest
    merging word. Deterministic automata only. Returns the word length written into ``out_word``,
    or ``-1`` if some pair cannot be merged, ``-2`` if ``out_word`` is too short.
    """
    n = delta.shape[1]
    cur = start.copy()
    m = cur.shape[0]
    mark = np.zeros(n, dtype=np.int64)
    stamp = 0
    length = 0
    while m > 1:
        best = -1
        bp = -1
        bq = -1
        for i in range(m):
            for j in range(i + 1, m):
                d = dist[pair_index(cur[i], cur[j], n)]
                if d < 0:
                    return -1
                if best < 0 or d < best:
                    best = d
                    bp = cur[i]
                    bq = cur[j]
                    if best == 1:
                        break
            if best == 1:
                break
        p = bp
        q = bq
        while p != q:
            a = nxt[pair_index(p, q, n)]
            if length >= out_word.shape[0]:
                return -2
            out_word[length] = a
            length += 1
            p = delta[a, p]
            q = delta[a, q]
            # apply the letter to the whole current set, deduplicating
            stamp += 1
            mm = 0
            for i in range(m):
                r = delta[a, cur[i]]
                if mark[r] != stamp:
                    mark[r] = stamp
                    cur[mm] = r
                    mm += 1
            m = mm
    return length




@njit(cache=True)
def max_pair_distance_rows(rows, dist, n, out):
    """``out[i]``: the largest pair-merging distance among the states of bitset row ``i`` (``-1`` if
    some pair never merges; 0 for a single state): a lower bound on the length of every word
    that synchronizes the set (each pair must merge)."""
    elems = np.empty(n, dtype=np.int64)
    for i in range(rows.shape[0]):
        m = _members(rows, i, elems)
        best = 0
        for s in range(m):
            if best < 0:
                break
            for t in range(s + 1, m):
                d = dist[pair_index(elems[s], elems[t], n)]
                if d < 0:
                    best = -1
                    break
                if d > best:
                    best = d
        out[i] = best


@njit(cache=True)
def first_superset(rows, bits):
    """Index of the first row of ``rows`` containing the bitset ``bits`` (``-1`` if none)."""
    for i in range(rows.shape[0]):
        ok = True
        for w in range(rows.shape[1]):
            if bits[w] & ~rows[i, w]:
                ok = False
                break
        if ok:
            return i
    return -1


# ----------------------------------------------------------------------------- meet test by rarest element
@njit(cache=True)
def _postings(bstore, blo, bhi, n, order):
    """Posting lists of the backward rows: ``ids[ptr[e]:ptr[e + 1]]`` are the rows (offsets from
    ``blo``) containing state ``e``, in the order ``order`` (decreasing size); ``ptr[e + 1] -
    ptr[e]`` is its frequency."""
    ptr = np.zeros(n + 1, dtype=np.int64)
    elems = np.empty(n, dtype=np.int64)
    for j in range(bhi - blo):
        for t in range(_members(bstore, blo + j, elems)):
            ptr[elems[t] + 1] += 1
    for e in range(n):
        ptr[e + 1] += ptr[e]
    fill = ptr[:n].copy()
    ids = np.empty(ptr[n], dtype=np.int64)
    for jj in range(bhi - blo):
        j = order[jj]
        for t in range(_members(bstore, blo + j, elems)):
            e = elems[t]
            ids[fill[e]] = j
            fill[e] += 1
    return ptr, ids


@njit(cache=True)
def _rarest_members(fstore, flo, fhi, freq, out):
    """``out[i - flo]``: the member of forward row ``i`` contained in the fewest backward rows
    (``-1`` when some member is in none: the row meets nothing)."""
    n = freq.shape[0]
    elems = np.empty(n, dtype=np.int64)
    for i in range(flo, fhi):
        m = _members(fstore, i, elems)
        best = -1
        for t in range(m):
            e = elems[t]
            if freq[e] == 0:
                best = -1
                break
            if best < 0 or freq[e] < freq[best]:
                best = e
        out[i - flo] = best


def _meet_rows_py(fstore, frow, r0, r1, sub, csize, freq, hit):
    """Forward rows ``frow[r0:r1]`` against the restricted index ``sub`` of candidates of sizes
    ``csize`` (non-increasing; a row of size ``m`` scans only those of size ``>= m``), 64 rows per
    parallel task; task ``t`` writes its row and candidate column into ``hit[t]``."""
    ntask = (r1 - r0 + 63) // 64
    order = np.arange(csize.shape[0])
    for task in prange(ntask):
        elems = np.empty(freq.shape[0], dtype=np.int64)
        for r in range(r0 + task * 64, min(r1, r0 + (task + 1) * 64)):
            i = frow[r]
            m = _elems_by_freq(fstore, i, freq, elems)
            used = (_count_at_least(csize, order, 0, csize.shape[0], m) + 63) // 64
            for v in range(used):
                acc = _ALL
                for t in range(m):
                    acc &= sub[elems[t], v]
                    if acc == _ZERO:
                        break
                if acc != _ZERO:
                    hit[task, 0] = i
                    hit[task, 1] = v * 64 + _ctz(acc)
                    break
            if hit[task, 0] >= 0:
                break


_meet_rows_par = njit(cache=True, parallel=True)(_meet_rows_py)
_meet_rows_seq = njit(cache=True)(_meet_rows_py)
#: forward rows of a group from which the rows are tested in parallel (threads cost their start-up)
_PAR_ROWS = 8192


@njit(cache=True)
def _restricted_index(bstore, blo, ids, lo, c0, c1, n):
    words = (c1 - c0 + 63) // 64
    sub = np.zeros((n, words), dtype=np.uint64)
    elems = np.empty(n, dtype=np.int64)
    for j in range(c1 - c0):
        bit = _ONE << np.uint64(j & 63)
        for t in range(_members(bstore, blo + ids[lo + c0 + j], elems)):
            sub[elems[t], j >> 6] |= bit
    return sub


def _meet_groups(fstore, frow, gstart, gkey, g0, g1, bstore, blo, ptr, ids, freq, max_words, bsize):
    """Groups ``g0..g1-1`` of forward rows (``frow[gstart[g]:gstart[g + 1]]``, all with rarest member
    ``gkey[g]``) against the backward rows containing that member only: for each group an inverted
    index restricted to those candidates (``max_words`` 64-row words at a time), then the AND over
    each forward row's members, rarest first, rows in parallel. Returns ``(f, b)`` or ``(-1, -1)``."""
    n = freq.shape[0]
    for g in range(g0, g1):
        e0 = gkey[g]
        lo = ptr[e0]
        f0 = ptr[e0 + 1] - lo
        r0, r1 = gstart[g], gstart[g + 1]
        for c0 in range(0, f0, max_words * 64):
            c1 = min(f0, c0 + max_words * 64)
            sub = _restricted_index(bstore, blo, ids, lo, c0, c1, n)
            hit = np.full(((r1 - r0 + 63) // 64, 2), -1, dtype=np.int64)
            csize = bsize[ids[lo + c0:lo + c1]]
            rows = _meet_rows_par if (r1 - r0) * sub.shape[1] >= _PAR_ROWS * 16 else _meet_rows_seq
            rows(fstore, frow, r0, r1, sub, csize, freq, hit)
            found = np.flatnonzero(hit[:, 0] >= 0)
            if found.size:
                f, col = hit[found[0]]
                return int(f), int(blo + ids[lo + c0 + col])
    return -1, -1


class RarestMeetIndex:
    """Meet test by rarest member: a forward set ``F`` can only lie in a backward set containing
    ``F``'s member that the fewest backward sets contain, so forward rows are grouped by that
    member and each group is tested against those candidates only (an inverted index restricted
    to them), instead of every backward set of at least its size (:class:`MeetIndex`). The
    posting lists are built once per backward level. Same answers as :class:`MeetIndex`: some
    meeting pair if one exists."""

    def __init__(self, bstore, blo, bhi, n, max_bytes=64 * 2 ** 20):
        self.bstore, self.blo, self.n = bstore, blo, n
        self.nb = max(0, bhi - blo)
        self.bsize = _level_sizes(bstore, blo, bhi) if self.nb else np.zeros(0, dtype=np.int64)
        self.ptr, self.ids = _postings(bstore, blo, max(blo, bhi), n, np.argsort(-self.bsize, kind="stable"))
        self.freq = np.diff(self.ptr)
        self.max_words = max(1, max_bytes // (8 * n))

    def groups(self, fstore, flo, fhi):
        """``(frow, gstart, gkey)``: forward rows ``flo..fhi-1`` that may meet, grouped by rarest member."""
        key = np.empty(max(0, fhi - flo), dtype=np.int64)
        _rarest_members(fstore, flo, fhi, self.freq, key)
        ok = np.flatnonzero(key >= 0)
        order = ok[np.argsort(key[ok], kind="stable")]
        frow = flo + order
        k = key[order]
        cut = np.flatnonzero(np.diff(k)) + 1 if k.size else np.zeros(0, dtype=np.int64)
        gstart = np.concatenate([[0], cut, [k.size]]).astype(np.int64) if k.size else np.zeros(1, dtype=np.int64)
        gkey = k[gstart[:-1]] if k.size else np.zeros(0, dtype=np.int64)
        return frow, gstart, gkey

    def query_groups(self, fstore, grouped, g0, g1):
        """Groups ``g0..g1-1`` of :meth:`groups`: ``(f, b)`` or ``(-1, -1)``."""
        frow, gstart, gkey = grouped
        if g1 <= g0:
            return -1, -1
        return _meet_groups(fstore, frow, gstart, gkey, g0, g1, self.bstore, self.blo, self.ptr, self.ids,
                            self.freq, self.max_words, self.bsize)

    def query(self, fstore, flo, fhi):
        """``(f, b)`` with forward row ``f`` in ``flo..fhi-1`` a subset of backward row ``b``, or ``(-1, -1)``."""
        if self.nb <= 0 or fhi <= flo:
            return -1, -1
        grouped = self.groups(fstore, flo, fhi)
        return self.query_groups(fstore, grouped, 0, grouped[2].shape[0])


def _dominated_rows_py(store, frow, r0, r1, sub, csize, freq, lo, out):
    """Rows ``frow[r0:r1]`` of ``store``: ``out[row - lo]`` set when the restricted index ``sub`` (candidates
    of sizes ``csize``, non-increasing) holds a strictly larger superset."""
    order = np.arange(csize.shape[0])
    for r in prange(r0, r1):
        elems = np.empty(freq.shape[0], dtype=np.int64)
        i = frow[r]
        m = _elems_by_freq(store, i, freq, elems)
        cnt = _count_at_least(csize, order, 0, csize.shape[0], m + 1)
        used = (cnt + 63) // 64
        for v in range(used):
            acc = _ALL
            if v == used - 1 and (cnt & 63) != 0:      # only the candidates larger than the row
                acc = (_ONE << np.uint64(cnt & 63)) - _ONE
            for t in range(m):
                acc &= sub[elems[t], v]
                if acc == _ZERO:
                    break
            if acc != _ZERO:
                out[i - lo] = True
                break


_dominated_rows_par = njit(cache=True, parallel=True)(_dominated_rows_py)
_dominated_rows_seq = njit(cache=True)(_dominated_rows_py)


def dominated_in_store(store, ylo, yhi, lo, hi, n, max_bytes=64 * 2 ** 20):
    """Rows ``lo..hi-1`` of ``store`` that are proper subsets of some row ``ylo..yhi-1`` (boolean
    mask): subset dominance of the inverse search (Kisielewicz, Kowalski and Szykula 2015) -- a
    backward set inside a larger stored one meets no forward set the larger one does not. Rows
    are grouped by their least frequent member and tested against the stored sets holding it
    (:class:`RarestMeetIndex`'s scheme), larger than them only."""
    out = np.zeros(hi - lo, dtype=np.bool_)
    index = RarestMeetIndex(store, ylo, yhi, n, max_bytes)
    frow, gstart, gkey = index.groups(store, lo, hi)
    for g in range(gkey.shape[0]):
        e0 = gkey[g]
        p0 = index.ptr[e0]
        f0 = index.ptr[e0 + 1] - p0
        r0, r1 = gstart[g], gstart[g + 1]
        for c0 in range(0, f0, index.max_words * 64):
            c1 = min(f0, c0 + index.max_words * 64)
            csize = index.bsize[index.ids[p0 + c0:p0 + c1]]
            if csize[0] <= 1:
                break
            sub = _restricted_index(store, ylo, index.ids, p0, c0, c1, n)
            rows = _dominated_rows_par if (r1 - r0) * sub.shape[1] >= _PAR_ROWS * 16 else _dominated_rows_seq
            rows(store, frow, r0, r1, sub, csize, index.freq, lo, out)
    return out
