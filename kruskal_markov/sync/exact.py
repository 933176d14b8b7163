"""Exact shortest synchronizing words: bidirectional breadth-first subset search, then a
memory-bounded depth-first phase.

References
----------
A. Kisielewicz, J. Kowalski and M. Szykula, "Computing the shortest reset words of synchronizing
automata", J. Comb. Optim. 29 (2015) 88-124.
M. Szykula and A. Zyzik, "An improved algorithm for finding the shortest synchronizing words",
ESA 2022, LIPIcs 244, 85:1-85:17 (synchrowords).
"""
from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from kruskal_markov import _sync_kernels as _k
from kruskal_markov._subsets import SubsetStore, as_start
from kruskal_markov.sync import _countfilter, _forked, _leaves, _relabel, _trie
from kruskal_markov.sync.automaton import SyncAutomaton, as_automaton, is_synchronizing_word
from kruskal_markov.sync.beam import beam_width_schedule, inverse_beam_word
from kruskal_markov.sync.greedy import greedy_synchronizing_word
from kruskal_markov.sync.options import ExactSearchOptions
from kruskal_markov.sync.pairs import _eppstein_fits, eppstein_memory_mb, pair_check_memory_mb, synchronizability
from kruskal_markov.sync.result import SyncResult

if TYPE_CHECKING:
    from kruskal_markov.model import TransitionModel

__all__ = ["shortest_synchronizing_word"]

#: share of ``time_budget`` the greedy word may use before the exact search starts.
_GREEDY_SHARE = 0.4
#: forward sets per call of the meet test in the depth-first phase
_MEET_SLICE = 2048
#: groups of forward sets (by rarest member) per call of the breadth-first meet test (the time
#: budget is checked between calls)
_MEET_GROUPS = 32
#: automata up to this many states get the pair-distance pruning (the pair table has n^2 / 2 entries)
_PRUNE_MAX_N = 2048
#: a dominance check (:class:`~kruskal_markov.sync.options.ExactSearchOptions`, off by default) runs
#: only while the sets it is checked against number at most this many (its cost grows like
#: queries x stored^0.5..0.8; docs/plans.md, issue 43)
_DOMINANCE_MAX_ROWS = 50_000
#: cost units of the model (about half a nanosecond: one node of a trie walk, synchrowords'
#: ``get_trie_evn``): a generated set (images or preimages, hashed), a forward set sorted for the
#: meet test's trie. synchrowords uses 512 for a set (no sorting term: its lists stay sorted);
#: ours measured: about 0.3 us a generated set, 0.1 us a sorted row (random 8 x 100, seed 1)
_SET_COST = 512.0
_SORT_COST = 200.0
#: the inverse depth-first phase's sets and meet queries, relative to the breadth-first ones
_DFS_SET_WEIGHT = 1.0
_DFS_CHECK_WEIGHT = 1.0
#: the last level's generated sets per slice (:func:`_last_level`)
_LAST_SLICE = 1 << 21
#: share of the memory budget the beam's level store may use
_BEAM_MEMORY_SHARE = 0.25


def _beam_upper(aut, s, best, memory_budget_mb, deadline, node_budget, opts, clock):
    """The shorter of ``best`` (the greedy word, or None) and the words of two inverse beam searches
    (:func:`~kruskal_markov.sync.beam.inverse_beam_word`): width ``n log2 n``, then synchrowords'
    dynamic width for the length found, capped so that a level fits a quarter of the memory budget.
    Returns ``(word, from_beam)``."""
    if not opts.use_beam or best is None:       # without a first word the beam has no length to stop at
        return best, False
    sbits = aut.bits(s)
    row_bytes = 8 * aut.n_words + 60
    cap = max(16, int(memory_budget_mb * 2 ** 20 * _BEAM_MEMORY_SHARE / row_bytes / (aut.k + 1)))
    from_beam = False
    width = min(cap, beam_width_schedule(aut.n, aut.k, None))
    for attempt in range(2):
        limit = None if best is None else len(best) - 1
        if limit is not None and limit < 1:
            break
        w = inverse_beam_word(aut, sbits, width, limit, node_budget, deadline, clock=clock)
        opts.emit("beam", -1 if w is None else len(w))
        if w is not None and (best is None or len(w) < len(best)):
            best, from_beam = w, True
        wider = min(cap, beam_width_schedule(aut.n, aut.k, None if best is None else len(best)))
        if wider <= width:
            break
        width = wider
    return best, from_beam


_BLOCK = 1 << 16


def _choose_forward(fwd, bwd, k):
    """Which side to expand: the one with the smaller newest level (forward on a tie)."""
    (flo, fhi), (blo, bhi) = fwd.levels[-1], bwd.levels[-1]
    return (fhi - flo) <= (bhi - blo)


def _trie_evn(m, p, q, n):
    """Expected trie nodes visited by one query of density ``p`` against ``m`` stored sets of
    density ``q`` ("does the query contain a stored set"), capped at ``m n``: synchrowords'
    ``get_trie_evn`` (Szykula and Zyzik 2022)."""
    m = max(float(m), 1.0)
    p = min(max(p, 1e-3), 1 - 1e-3)
    q = min(max(q, 1e-3), 1 - 1e-3)
    e = ((1 + p) / p + 1 / (q - p * q)) * m ** (np.log(1 + p) / np.log((1 + p) / (1 + p * q - q)))
    return e if 0 <= e < m * n else m * n


def _density(aut, store):
    """Mean share of the states in the newest level's sets."""
    lo, hi = store.levels[-1]
    if hi <= lo:
        return 0.0
    return float(_k._level_sizes(store.rows, lo, hi).mean()) / aut.n


def _retained(store, k):
    """Sets kept per set generated in the direction's last step (duplicates and earlier sets
    removed), 1 before any step."""
    if len(store.levels) < 2:
        return 1.0
    (plo, phi), (lo, hi) = store.levels[-2], store.levels[-1]
    return min(1.0, (hi - lo) / max(1, k * (phi - plo)))


def _dfs_factor(b, depth):
    """Sets generated by a depth-first search of ``depth`` levels with branching ``b`` per set."""
    if depth <= 0:
        return 0.0
    if abs(b - 1.0) < 1e-9:
        return float(depth)
    return b * (b ** depth - 1.0) / (b - 1.0)


def _decide(aut, fwd, bwd, total, upper, step_by_cost=False):
    """The next step: ``"forward"``, ``"backward"`` (a breadth-first level) or ``"idfs"`` (the
    inverse depth-first phase to the end), by synchrowords' cost model
    (``MeetInTheMiddle::calculate_decision``, Szykula and Zyzik 2022; our own code and units):
    each choice's cost is its step (sets generated, the forward level sorted, the meet test's trie
    walks estimated by :func:`_trie_evn`) plus an inverse depth-first search over the lengths
    still to test from the state it leaves; the depth-first phase is chosen when it alone is
    cheapest, otherwise the cheaper step. Small levels (at most ``n k`` sets) or a direction not
    yet stepped: the smaller newest level, as before."""
    k, n = aut.k, aut.n
    (flo, fhi), (blo, bhi) = fwd.levels[-1], bwd.levels[-1]
    F, B = fhi - flo, bhi - blo
    if F <= n * k or B <= n * k or len(fwd.levels) < 2 or len(bwd.levels) < 2:
        return "forward" if F <= B else "backward"
    dF, dB = _density(aut, fwd), _density(aut, bwd)
    bf, bb = k * _retained(fwd, k), k * _retained(bwd, k)
    rem = upper - 1 - total         # lengths still to test: total + 1 .. upper - 1
    b_dfs = max(1.0, bb)
    dset = _SET_COST * _DFS_SET_WEIGHT
    ev_now = _trie_evn(F, dB, dF, n)
    ev_next = _trie_evn(bf * F, dB, dF, n)
    cost_f = _SET_COST * k * F + _SORT_COST * bf * F + B * ev_next
    cost_b = _SET_COST * k * B + bb * B * ev_now
    pred_f = cost_f + B * _dfs_factor(b_dfs, rem - 1) * (dset + _DFS_CHECK_WEIGHT * ev_next)
    pred_b = cost_b + bb * B * _dfs_factor(b_dfs, rem - 1) * (dset + _DFS_CHECK_WEIGHT * ev_now)
    pred_d = B * _dfs_factor(b_dfs, rem) * (dset + _DFS_CHECK_WEIGHT * ev_now)
    if pred_d < min(pred_f, pred_b):
        return "idfs"
    if not step_by_cost:
        return "forward" if F <= B else "backward"
    return "backward" if cost_b < cost_f else "forward"


def _dominance(aut, store, forward, opts):
    """Drop the newest level's sets that a stored set dominates (forward: a proper subset is stored;
    backward: a proper superset), within the level and, with ``opts.forward_visited``
    (``opts.backward_visited``), the earlier levels. Returns how many were dropped."""
    lo, hi = store.levels[-1]
    visited = opts.forward_visited if forward else opts.backward_visited
    ylo = 0 if visited and hi <= _DOMINANCE_MAX_ROWS else lo
    if hi - ylo < 2 or hi - ylo > _DOMINANCE_MAX_ROWS:
        return 0
    stored, query = store.rows[ylo:hi], store.rows[lo:hi]
    if forward:
        dominated = _trie.superset_mask(stored, query, proper=True, tasks=opts.tasks)
    else:
        dominated = _trie.subset_mask(stored, query, aut.n, proper=True, tasks=opts.tasks)
    return store.keep_last(~dominated)


def _backward_roots(aut, start, restrict=True):
    """The states a shortest word can end in: with a start set of two states or more, the last
    letter ``a`` merges at least two states into the final state ``q``, so ``a^-1({q})`` holds
    two states or more for some letter (synchrowords' initial inverse list, Szykula and Zyzik
    2022). Every state for a start set of one state (the empty word), or when ``restrict``
    is off."""
    if not restrict or len(start) < 2:
        return range(aut.n)
    keep = np.zeros(aut.n, dtype=bool)
    for a in range(aut.k):
        deg = np.diff(aut.indptr[a])
        single = np.flatnonzero(deg == 1)
        pre = np.bincount(aut.indices[aut.indptr[a, single]], minlength=aut.n)
        pre += int(np.count_nonzero(deg == 0))      # an empty support lies in every set
        keep |= pre >= 2
    return np.flatnonzero(keep)


def _sorted_forward(fwd, cache):
    """The newest forward level in :func:`~kruskal_markov.sync._trie.lex_order` (the meet test's
    trie), sorted once per level and kept in ``cache`` while the backward side steps (with its
    :class:`~kruskal_markov.sync._trie.SizeSplit`, ``cache["split"]``)."""
    lo, hi = fwd.levels[-1]
    if cache.get("level") != (lo, hi):
        cache["level"] = (lo, hi)
        cache["rows"] = fwd.rows[lo:hi][_trie.lex_order(fwd.rows[lo:hi])]
        cache["split"] = _trie.SizeSplit(cache["rows"])
    return cache["rows"]


def _meet_levels(aut, fwd, bwd, total, deadline, cache=None, trie_meet=True, clock=time.perf_counter, tasks=1):
    """The meet test of the newest levels: ``(f, b)`` (store rows, forward set inside backward set),
    ``(-1, -1)`` when none meets, ``(-2, -2)`` when the deadline passed."""
    (flo, fhi), (blo, bhi) = fwd.levels[-1], bwd.levels[-1]
    if trie_meet:
        if total and deadline is not None and clock() > deadline:
            return -2, -2
        cache = {} if cache is None else cache
        fs = _sorted_forward(fwd, cache)
        hits = np.flatnonzero(_trie.superset_mask(fs, bwd.rows[blo:bhi], sorted_stored=True, tasks=tasks,
                                                  split=cache["split"]))
        if hits.size == 0:
            return -1, -1
        q = int(hits[0])
        inside = ~np.any(fwd.rows[flo:fhi] & ~bwd.rows[blo + q], axis=1)
        return flo + int(np.flatnonzero(inside)[0]), blo + q
    index = _k.RarestMeetIndex(bwd.rows, blo, bhi, aut.n)     # built once per level pair
    grouped = index.groups(fwd.rows, flo, fhi)
    ng = grouped[2].shape[0]
    for g in range(0, max(ng, 1), _MEET_GROUPS):
        if total and deadline is not None and clock() > deadline:
            return -2, -2
        f, b = index.query_groups(fwd.rows, grouped, g, min(ng, g + _MEET_GROUPS))
        if f >= 0:
            return f, b
    return -1, -1


def _last_level(aut, fwd, bwd, forward, cache, deadline, clock=time.perf_counter, tasks=1):
    """The last length to test (``total + 1 = upper - 1``): the next level of one direction is
    generated unhashed (:func:`~kruskal_markov._sync_kernels.level_images`), slice by slice, and
    only met against the other direction's newest level -- it is never expanded again, so it needs
    no store, parents or duplicate removal (synchrowords likewise tests its last inverse level
    without keeping it). Forward: each slice of images is sorted as the trie and the newest
    backward level queried against it; backward: the preimages are queried against the sorted
    newest forward level. Returns ``(word | None, generated)``, or ``(None, -1)`` at the deadline."""
    k = aut.k
    store = fwd if forward else bwd
    lo, hi = store.levels[-1]
    (flo, fhi), (blo, bhi) = fwd.levels[-1], bwd.levels[-1]
    inv_ptr, inv_idx, supcount = aut.inverse
    step = max(1, _LAST_SLICE // k)
    fs = None if forward else _sorted_forward(fwd, cache)
    generated = 0
    for a in range(lo, hi, step):
        if deadline is not None and clock() > deadline:
            return None, -1
        b = min(hi, a + step)
        im = _k.level_images(store.rows, a, b, aut.delta, aut.step_table(forward), aut.deterministic, forward, inv_ptr,
                             inv_idx,
                             supcount, tasks=tasks)
        generated += im.shape[0]
        if forward:
            ims = im[_trie.lex_order(im)]
            mask = _trie.superset_mask(ims, bwd.rows[blo:bhi], sorted_stored=True, tasks=tasks,
                                       split=_trie.SizeSplit(ims))
            hits = np.flatnonzero(mask)
            if hits.size:
                q = blo + int(hits[0])
                i = int(np.flatnonzero(~np.any(im & ~bwd.rows[q], axis=1))[0])
                u, _ = fwd.path(a + i // k)
                v, _ = bwd.path(q)
                return u[::-1] + [i % k] + v, generated
        else:
            hits = np.flatnonzero(_trie.superset_mask(fs, im, sorted_stored=True, tasks=tasks, split=cache["split"]))
            if hits.size:
                i = int(hits[0])
                f = flo + int(np.flatnonzero(~np.any(fwd.rows[flo:fhi] & ~im[i], axis=1))[0])
                u, _ = fwd.path(f)
                v, _ = bwd.path(a + i // k)
                return u[::-1] + [i % k] + v, generated
    return None, generated


def _exact_search(aut: SyncAutomaton, start, time_budget, memory_budget_mb, node_budget=None, upper=None,
                  strict=False, options: ExactSearchOptions | None = None, clock=time.perf_counter):
    """Bidirectional BFS, then (when memory runs out) a depth-first phase.

    Returns ``(word | None, status, explored, lower_bound)`` with status 'found', 'none' (proven:
    no word), 'upper' (proven: no word shorter than ``upper``) or 'budget' (time or node budget;
    ``lower_bound`` proven). ``time_budget`` None: no time limit; ``node_budget`` counts the subsets
    generated (the same budget gives the same answer on any machine); ``strict``: stop before a
    level whose expansion could pass it (the small-search fast path), not after. ``options``: the
    design switches (:class:`~kruskal_markov.sync.options.ExactSearchOptions`, default when None);
    ``clock``: the seconds the time budget is measured on.
    """
    opts = (ExactSearchOptions() if options is None else options).resolved()
    W = aut.n_words
    row_bytes = 8 * W + 8 + 4 + 16 * 2      # rows + parent + letter + hash table (load <= 1/2, x2 growth)
    # three eighths of the memory per direction; the last quarter for the depth-first phase
    max_rows = max(1024, int(memory_budget_mb * 2 ** 20 / row_bytes * 3 / 8))
    if aut.n >= max_rows:       # not even the n backward roots fit: no exact search in this budget
        return None, "budget", 0, 1
    return _Bidirectional(aut, start, time_budget, memory_budget_mb, max_rows, node_budget, upper, strict, opts,
                          clock).run()


class _Bidirectional:
    """One bidirectional breadth-first search (:func:`_exact_search`): the two stores, the lengths
    met so far and the measured rates that predict the next level's time. :meth:`run` steps until
    a step returns ``(word | None, status, explored, lower_bound)``."""

    def __init__(self, aut, start, time_budget, memory_budget_mb, max_rows, node_budget, upper, strict, opts, clock):
        self.aut, self.opts, self.clock = aut, opts, clock
        self.node_budget, self.upper, self.strict = node_budget, upper, strict
        self.memory_budget_mb = memory_budget_mb
        self.deadline = None if time_budget is None else clock() + time_budget
        W = aut.n_words
        self.fwd = SubsetStore(W, 1024, max_rows)
        self.bwd = SubsetStore(W, max(1024, aut.n), max_rows)
        self.fwd.add_roots([aut.bits(start)])
        singletons = []
        for q in _backward_roots(aut, start, opts.restrict_roots):
            b = np.zeros(W, dtype=np.uint64)
            b[q >> 6] = np.uint64(1) << np.uint64(q & 63)
            singletons.append(b)
        self.bwd.add_roots(singletons)
        self.total = 0
        self.pruned = 0
        self.dist = aut.pair_distances()[0] if (upper is not None and aut.n <= _PRUNE_MAX_N) else None
        self.dmax = -1 if self.dist is None else int(self.dist.max())  # pruning bites only below this length
        self.full = {True: False, False: False}      # forward / backward store full
        # first guesses (updated from measurements); both grow with the bitset width W
        self.rate_row = 2e-7 * max(1.0, W / 16)     # seconds per generated row
        self.rate_pair = 5e-11 * max(1.0, W / 4)    # seconds per (forward set x backward set) pair in the meet test
        self.tested = -1                             # the largest total whose meet test is done
        self.cache = {}                              # the newest forward level, sorted for the meet test

    @property
    def count(self):
        """Sets generated so far (both stores)."""
        return self.fwd.count + self.bwd.count

    def run(self):
        while True:
            res = self._step()
            if res is not None:
                return res

    def _step(self):
        """One round: the meet test of the newest levels (once per total), then one level grown;
        None when the search goes on."""
        if self.tested < self.total:
            res = self._meet()
            if res is not None:
                return res
        if self.upper is not None and self.total + 1 >= self.upper:
            return None, "upper", self.count, self.upper
        if self.node_budget is not None and self.count >= self.node_budget:
            return None, "budget", self.count, self.total + 1
        forward, res = self._direction()
        if res is not None:
            return res
        if self.full[forward]:
            forward = not forward
        if self.full[forward]:
            return self._depth_first()
        res = self._before_level(forward)
        if res is not None:
            return res
        return self._level(forward)

    def _meet(self):
        """The meet test of the newest levels (in slices, the budget checked between them)."""
        (flo, fhi), (blo, bhi) = self.fwd.levels[-1], self.bwd.levels[-1]
        tm = self.clock()
        f, b = _meet_levels(self.aut, self.fwd, self.bwd, self.total, self.deadline, self.cache, self.opts.trie_meet,
                            self.clock, self.opts.tasks)
        if f == -2:
            return None, "budget", self.count, self.total
        pairs = (fhi - flo) * (bhi - blo)
        if pairs > 10_000_000:
            self.rate_pair = (self.clock() - tm) / pairs
        self.opts.emit("meet", self.total)
        if f >= 0:
            u, _ = self.fwd.path(f)
            v, _ = self.bwd.path(b)
            return u[::-1] + v, "found", self.count, self.total
        self.tested = self.total
        return None

    def _direction(self):
        """``(forward, None)``: the side to expand -- the one with the smaller newest level (inverse
        steps cost ~ n per set), or the one synchrowords' cost model picks -- or ``(None, result)``
        when the cost model's choice (the inverse depth-first phase, or the last level met
        unhashed) answers the search."""
        fwd, bwd, opts = self.fwd, self.bwd, self.opts
        if not (opts.cost_model and opts.inverse_dfs and self.upper is not None and not any(self.full.values())):
            return _choose_forward(fwd, bwd, self.aut.k), None
        step = _decide(self.aut, fwd, bwd, self.total, self.upper, opts.step_by_cost)
        if step == "idfs":
            return None, _inverse_depth_first_phase(self.aut, fwd, bwd, self.total, self.deadline, self.node_budget,
                                                    self.upper, self.memory_budget_mb / 4, opts, self.clock,
                                                    self.cache)
        forward = step == "forward"
        if not (opts.last_unhashed and self.total + 2 == self.upper and not self.full[forward]):
            return forward, None
        lo, hi = (fwd if forward else bwd).levels[-1]
        if self.node_budget is not None and self.count + self.aut.k * (hi - lo) > self.node_budget:
            return forward, None
        if opts.last_side is not None:
            forward = opts.last_side == "forward"
        word, generated = _last_level(self.aut, fwd, bwd, forward, self.cache, self.deadline, self.clock, opts.tasks)
        opts.emit("last-level", generated)
        if generated < 0:
            return None, (None, "budget", self.count, self.total + 1)
        if word is not None:
            return None, (word, "found", self.count + generated, self.total + 1)
        return None, (None, "upper", self.count + generated, self.upper)

    def _depth_first(self):
        self.opts.emit("depth-first", self.total)
        return _depth_first_phase(self.aut, self.fwd, self.bwd, self.total, self.deadline, self.node_budget,
                                  self.upper, self.memory_budget_mb / 4, _BLOCK, self.opts, self.clock, self.cache)

    def _before_level(self, forward):
        """A result when the next level of ``forward``'s side should not be grown breadth-first:
        the node budget (``strict``), ``dfs_switch_rows``, or a predicted time (expansion + meet
        test) past the deadline -- then the level is tested streaming, depth-first, so that a word
        at it is still found in time. None: grow it."""
        aut, store = self.aut, self.fwd if forward else self.bwd
        lo, hi = store.levels[-1]
        if self.strict and self.node_budget is not None and self.count + aut.k * (hi - lo) > self.node_budget:
            return None, "budget", self.count, self.total + 1
        growth = aut.k if len(store.levels) < 2 else \
            max(1.0, (hi - lo) / max(1, store.levels[-2][1] - store.levels[-2][0]))
        new_rows = (hi - lo) * min(growth, aut.k)
        olo, ohi = (self.bwd if forward else self.fwd).levels[-1]
        predicted = new_rows * self.rate_row + new_rows * (ohi - olo) * self.rate_pair
        if self.opts.dfs_switch_rows is not None and self.upper is not None and new_rows > self.opts.dfs_switch_rows:
            return self._depth_first()
        if self.deadline is not None and self.clock() + predicted > self.deadline:
            if self.upper is None and not aut.deterministic:     # no bound on the streaming phase's length
                return None, "budget", self.count, self.total + 1
            return self._depth_first()
        return None

    def _level(self, forward):
        """Grow the next level of ``forward``'s side (dominance and pair-distance pruning after);
        a result when that ends the search, else None."""
        store = self.fwd if forward else self.bwd
        te = self.clock()
        grown = store.expand(self.aut, forward, self.opts.tasks)
        if grown is None:
            self.full[forward] = True
            return None
        if grown > 10_000:
            self.rate_row = max(1e-9, (self.clock() - te) / grown)
        if grown == 0:      # a direction exhausted: no word (shorter than ``upper``, once sets were pruned)
            if self.upper is not None:
                return None, "upper", self.count, self.upper
            return None, "none", self.count, self.total
        self.total += 1
        self.opts.emit("forward-level" if forward else "backward-level", grown)
        if self.opts.forward_dominance if forward else self.opts.backward_dominance:
            self.pruned += _dominance(self.aut, store, forward, self.opts)
        if forward and self.dist is not None and self.upper - 1 - (len(self.fwd.levels) - 1) < self.dmax:
            return self._prune_forward()
        return None

    def _prune_forward(self):
        """Drop the newest forward level's sets whose largest pair-merging distance exceeds
        ``upper - 1 - i`` at depth ``i``: they cannot start a word shorter than ``upper``
        (admissible). A result ('upper') when none is left."""
        fwd, upper = self.fwd, self.upper
        lo, hi = fwd.levels[-1]
        h = np.empty(hi - lo, dtype=np.int64)
        _k.max_pair_distance_rows(fwd.rows[lo:hi], self.dist, self.aut.n, h)
        self.pruned += fwd.keep_last((h >= 0) & (h <= upper - 1 - (len(fwd.levels) - 1)))
        if fwd.levels[-1][0] == fwd.levels[-1][1]:
            return None, "upper", self.count, upper
        return None


def _depth_first_phase(aut, fwd, bwd, total, deadline, node_budget, upper, memory_mb, block, opts, clock, cache=None):
    """Both stores are full: words of length ``t = total + 1, total + 2, ...`` are tested by expanding
    the forward frontier ``t - total`` more levels chunk by chunk (depth-first over chunks, memory
    bounded) and meeting the newest backward level, as synchrowords does after its breadth-first
    phase (Szykula and Zyzik 2022). Sets whose largest pair-merging distance exceeds the remaining
    length are pruned (admissible). ``cache``: the breadth-first search's sorted newest forward
    level (:func:`_sorted_forward`), reused by the inverse phase. Returns like :func:`_exact_search`."""
    flo, fhi = fwd.levels[-1]
    blo, bhi = bwd.levels[-1]
    if opts.inverse_dfs and upper is not None and fhi - flo >= bhi - blo:
        return _inverse_depth_first_phase(aut, fwd, bwd, total, deadline, node_budget, upper, memory_mb, opts, clock,
                                          cache, deepen=opts.deepen)
    dfs = _ForwardDepthFirst(aut, fwd, bwd, deadline, node_budget, memory_mb, opts, clock)
    if dfs.no_word():
        return None, "none", dfs.used[0], total
    t = total + 1
    while upper is None or t < upper:
        res = dfs.length(t - total)
        if res == "budget":
            return None, "budget", dfs.used[0], t
        if res is not None:
            f, extra, b = res
            u, _ = fwd.path(f)
            v, _ = bwd.path(b)
            return u[::-1] + extra + v, "found-dfs", dfs.used[0], t
        t += 1
    return None, "upper", dfs.used[0], upper


class _ForwardDepthFirst:
    """The forward depth-first phase of :func:`_depth_first_phase`: the newest forward level grown
    ``x`` more levels, chunk by chunk, and met against the newest backward level (its rarest-member
    index, built once). ``used[0]`` counts the sets generated (both stores' included)."""

    def __init__(self, aut, fwd, bwd, deadline, node_budget, memory_mb, opts, clock):
        self.aut, self.fwd, self.opts, self.clock = aut, fwd, opts, clock
        self.deadline, self.node_budget = deadline, node_budget
        self.i_b = len(bwd.levels) - 1
        row_bytes = 8 * aut.n_words + 8 + 4 + 32
        self.cap = max(4 * aut.k, int(memory_mb * 2 ** 20 / row_bytes / 12))
        self.dist = aut.pair_distances()[0] if aut.n <= 4096 else None
        self.used = [fwd.count + bwd.count]
        blo, bhi = bwd.levels[-1]
        self.index = _k.RarestMeetIndex(bwd.rows, blo, bhi, aut.n)     # the newest backward level, for every chunk

    def no_word(self):
        """Every frontier set holds a pair no word merges: no word at any length."""
        if self.dist is None:
            return False
        flo, fhi = self.fwd.levels[-1]
        h = np.empty(fhi - flo, dtype=np.int64)
        _k.max_pair_distance_rows(self.fwd.rows[flo:fhi], self.dist, self.aut.n, h)
        return bool((h < 0).all())

    def over_budget(self):
        return (self.node_budget is not None and self.used[0] >= self.node_budget) or \
            (self.deadline is not None and self.clock() > self.deadline)

    def length(self, x):
        """Words ``x`` letters longer than the breadth-first total: ``(frontier row, extra letters,
        backward row)`` of the first found, "budget", or None."""
        flo, fhi = self.fwd.levels[-1]
        for lo in range(flo, fhi, self.opts.dfs_chunk):
            hi = min(fhi, lo + self.opts.dfs_chunk)
            res = self.rec(self.fwd.rows[lo:hi].copy(), np.arange(lo, hi), np.zeros((hi - lo, 0), dtype=np.int16), x)
            if res is not None:
                return res
        return None

    def _prune(self, rows, rid, words, x):
        """The rows whose largest pair-merging distance is at most the remaining length."""
        if self.dist is None:
            return rows, rid, words
        h = np.empty(rows.shape[0], dtype=np.int64)
        _k.max_pair_distance_rows(rows, self.dist, self.aut.n, h)
        keep = (h >= 0) & (h <= x + self.i_b)
        if keep.all():
            return rows, rid, words
        return rows[keep], rid[keep], words[keep]

    def rec(self, rows, rid, words, x):
        """Rows (forward sets ``x`` levels above the meet depth), their frontier rows and extra letters."""
        if self.over_budget():
            return "budget"
        rows, rid, words = self._prune(rows, rid, words, x)
        if rows.shape[0] == 0:
            return None
        if x > 0:
            return _descend(self.rec, self.aut, self.cap, True, self.used, rows, rid, words, x, emit=self.opts.emit)
        for lo in range(0, rows.shape[0], _MEET_SLICE):
            f, b = self.index.query(rows, lo, min(rows.shape[0], lo + _MEET_SLICE))
            if f >= 0:
                return int(rid[f]), [int(a) for a in words[f]], int(b)
            if self.over_budget():
                return "budget"
        return None


def _descend(rec, aut, cap, forward, used, rows, rid, words, x, split=None, x_child=None, emit=None):
    """One step down a depth-first phase: ``rows`` (with the frontier rows ``rid`` they grew from and
    their letters ``words``) expanded by one level of images (``forward``) or preimages in a fresh
    store, and ``rec`` called on the new level at ``x_child`` (default ``x - 1``); a chunk whose
    expansion would pass ``cap`` rows is split in halves first, each half passed to ``split``
    (default ``rec``) at ``x`` (memory bounded). ``used[0]`` counts the sets generated; ``emit``
    (if given) is told ``("dfs-batch", sets expanded together)``.
    Returns ``rec``'s first answer that is not None (None when nothing new grows)."""
    m = rows.shape[0]
    if m * aut.k > cap and m > 1:
        for part in (slice(0, m // 2), slice(m // 2, m)):
            r = (rec if split is None else split)(rows[part], rid[part], words[part], x)
            if r is not None:
                return r
        return None
    if emit is not None:
        emit("dfs-batch", m)
    st = SubsetStore(aut.n_words, m * aut.k + m, m * aut.k + m)
    st.add_roots(list(rows))
    grown = st.expand(aut, forward)
    lo2, hi2 = st.levels[-1]
    used[0] += hi2 - lo2
    par = st.parent[lo2:hi2]
    nrows = st.rows[lo2:hi2].copy()
    nwords = np.concatenate([words[par], st.letter[lo2:hi2, None].astype(np.int16)], axis=1)
    nrid = rid[par]
    del st
    if not grown:
        return None
    return rec(nrows, nrid, nwords, x - 1 if x_child is None else x_child)


def _inverse_depth_first_phase(aut, fwd, bwd, total, deadline, node_budget, upper, memory_mb, opts, clock,
                               cache=None, deepen=False):
    """The depth-first phase from the backward side (synchrowords' inverse DFS, Szykula and Zyzik
    2022): the newest backward level is extended by preimages, chunk by chunk and depth-first
    (memory bounded), up to ``upper - 1 - total`` more levels, and every generated level asks the
    implicit subset trie of the newest forward level (sorted once) whether a set contains a forward
    set -- the trie's cheap direction (the forward sets are stored, the generated sets queried);
    a set at depth ``x`` tests words of length ``total + x``. A hit at depth ``x`` is kept and
    the rest of the search only goes to depth ``x - 1``, so the last word kept is a shortest one.
    Sets of at most one state are dropped (a word through one is never shortest: the
    singleton's own root already gives a shorter one; synchrowords does the same). Entered when
    the forward level is the larger one, or when :func:`_decide` predicts it cheapest. Returns like
    :func:`_exact_search`; at a budget stop the word is the shortest found so far (or None), with
    the lower bound ``total + 1``.

    With ``deepen`` the lengths are tested one at a time instead (iterative deepening): every
    chunk is grown to depth 1 and tested, then every chunk to depth 2 (the shallower levels grown
    again, not tested), and so on; the first hit is a shortest word, and a budget stop at depth
    ``m`` has proven the lower bound ``total + m``. It regenerates the shallower levels (about
    ``1 / k`` more sets) but never grows a level deeper than the shortest word, and its bound
    rises as it goes (used when the stores are full: :func:`_depth_first_phase`)."""
    flo, fhi = fwd.levels[-1]
    cache = {} if cache is None else cache
    dfs = _InverseDepthFirst(aut, fwd, bwd, deadline, node_budget, memory_mb, opts, clock, cache)
    depths = range(1, upper - total) if deepen else (upper - 1 - total,)
    res, lower = None, total + 1
    for m in depths:
        res = dfs.run(m, m if deepen else 0)
        if res is not None or dfs.limit < 1:
            break
        if deepen:
            opts.emit("deepened", total + m)
            lower = total + m + 1
    word = None
    if dfs.best is not None:
        x, f, extra, b = dfs.best
        u, _ = fwd.path(f)
        v, _ = bwd.path(b)
        word = u[::-1] + extra + v
    opts.emit("inverse-dfs", word is not None)
    if res == "budget":
        return word, "budget", dfs.used[0], lower
    if word is not None:
        return word, "found-dfs", dfs.used[0], len(word)
    return None, "upper", dfs.used[0], upper


class _InverseDepthFirst:
    """The preimage descent of :func:`_inverse_depth_first_phase` from the newest backward level,
    tested against the newest forward level's trie. ``used[0]`` counts the sets generated (both
    stores' included); ``best`` is ``(depth, forward row, extra letters, backward row)`` of the
    shortest hit so far; ``limit`` the deepest level still worth generating."""

    def __init__(self, aut, fwd, bwd, deadline, node_budget, memory_mb, opts, clock, cache):
        self.aut, self.fwd, self.bwd, self.opts, self.clock = aut, fwd, bwd, opts, clock
        self.deadline, self.node_budget = deadline, node_budget
        self.fsorted = _sorted_forward(fwd, cache)
        self.fsplit = cache["split"]
        self.perm = None
        flo, fhi = fwd.levels[-1]
        if opts.relabel_rows is not None and aut.deterministic and fhi - flo >= opts.relabel_rows:
            self.perm, self.aut, self.fsorted, self.fsplit = _relabel.for_phase(aut, fwd, cache)
        # the deepest level's count filter (sync/_countfilter), in the trie's labels
        self.cfilter = None
        self.batched = opts.leaf_batch is not None and opts.leaf_batch_rows is not None and \
            fhi - flo >= opts.leaf_batch_rows
        if opts.leaf_images and self.batched and opts.count_blocks is not None:
            self.cfilter = _countfilter.CountFilter(self.fsorted, aut.n, opts.count_blocks)
        blo, bhi = bwd.levels[-1]
        # both cores: the deepening phase's chunks dealt to two processes (sync/_forked), one thread each
        self.forked = bool(opts.parallel) and node_budget is None and opts.fork_rows is not None and \
            bhi - blo >= opts.fork_rows and _forked.can_fork()
        self.tasks = 1 if self.forked else opts.tasks
        row_bytes = 8 * aut.n_words + 8 + 4 + 32
        self.cap = max(4 * aut.k, int(memory_mb * 2 ** 20 / row_bytes / (24 if self.forked else 12)))
        self.used = [fwd.count + bwd.count]
        self.best = None
        self.limit = 0
        self.test_from = 0

    def over_budget(self):
        return (self.node_budget is not None and self.used[0] >= self.node_budget) or \
            (self.deadline is not None and self.clock() > self.deadline)

    def run(self, limit, test_from):
        """Every chunk of the newest backward level grown to depth ``limit``, the levels from
        ``test_from`` on tested; "budget", "hit" (a hit while deepening), or None."""
        self.limit, self.test_from = limit, test_from
        blo, bhi = self.bwd.levels[-1]
        starts = range(blo, bhi, self.opts.dfs_chunk)
        if self.forked and test_from > 0 and len(starts) > 1:
            return self.run_forked(starts)
        for lo in starts:
            res = self.chunk(lo)
            if res is not None or self.limit < 1:
                return res
        return None

    def chunk(self, lo):
        """The chunk of the newest backward level starting at row ``lo``, grown and tested."""
        hi = min(self.bwd.levels[-1][1], lo + self.opts.dfs_chunk)
        rows = self.bwd.rows[lo:hi].copy() if self.perm is None else _relabel.permute_rows(self.bwd.rows[lo:hi],
                                                                                            self.perm[0])
        return self.grow(rows, np.arange(lo, hi), np.zeros((hi - lo, 0), dtype=np.int16), 0)

    def run_forked(self, starts):
        """:meth:`run` while deepening, the chunks dealt alternately to this process and a forked
        child (:func:`~kruskal_markov.sync._forked.split_two`); the first hit ends both."""
        used0 = self.used[0]

        def task(part, stop):
            for lo in starts[part::2]:
                if stop():
                    break
                res = self.chunk(lo)
                if res is not None:
                    return res, (self.best if res == "hit" else None, self.used[0] - used0)
            return None, (None, self.used[0] - used0)

        mine, child = _forked.split_two(task)
        if child[1] is not None:
            self.used[0] += child[1][1]
        if mine[0] == "hit":
            return "hit"
        if child[0] == "hit":
            self.best = child[1][0]
            self.limit = self.best[0] - 1
            return "hit"
        return "budget" if "budget" in (mine[0], child[0]) else None

    def grow(self, rows, rid, words, x):
        """Extend sets at depth ``x`` by one level (or split them), unless ``x`` is the limit."""
        if x >= self.limit:
            return None
        if self.opts.leaf_images and x + 1 == self.limit and x + 1 >= self.test_from:
            return self.leaves(rows, rid, words, x)
        return _descend(self.rec, self.aut, self.cap, False, self.used, rows, rid, words, x, split=self.grow,
                        x_child=x + 1, emit=self.opts.emit)

    def leaves(self, rows, rid, words, x):
        """The preimages of ``rows`` (depth ``x``) at the deepest level, tested unstored
        (:func:`~kruskal_markov.sync._leaves.first_leaf_hit`); like :meth:`rec`."""
        slice_rows = min(_leaves.SLICE, self.cap)
        if self.batched:     # batched, rows moved, count filter (sync/_rowtrie)
            res = _leaves.first_leaf_hit_batched(self.aut, rows, self.fsorted, self.fsplit, self.opts.leaf_batch,
                                                 self.cfilter, self.tasks, self.over_budget, self.used,
                                                 slice_rows=slice_rows, emit=self.opts.emit)
        else:
            res = _leaves.first_leaf_hit(self.aut, rows, self.fsorted, self.fsplit, self.tasks, self.over_budget,
                                         self.used, slice_rows=slice_rows, emit=self.opts.emit)
        if res is None or res == "budget":
            return res
        i, a = res
        pre = _leaves.preimage(self.aut, rows[i], a)
        return self.hit(pre, int(rid[i]), [a] + [int(b) for b in words[i][::-1]], x + 1)

    def hit(self, row, b, extra, x):
        """Keep a hit: backward set ``row`` at depth ``x`` (grown from backward row ``b`` by the
        preimage letters whose reverse is ``extra``) contains a forward set."""
        if self.perm is not None:
            row = _relabel.permute_rows(row[None, :], self.perm[1])[0]
        flo, fhi = self.fwd.levels[-1]
        inside = ~np.any(self.fwd.rows[flo:fhi] & ~row, axis=1)
        self.best = (x, flo + int(np.flatnonzero(inside)[0]), extra, b)
        self.limit = x - 1
        return "hit" if self.test_from > 0 else None

    def rec(self, rows, rid, words, x):
        """Backward sets ``x`` levels below the newest backward level, the rows they grew from and
        the letters of their preimage steps in the order taken (reversed, they are the word from
        the set to that row): tested against the forward trie (from depth ``test_from`` on), then
        grown."""
        if self.over_budget():
            return "budget"
        keep = _k._level_sizes(rows, 0, rows.shape[0]) >= 2
        if not keep.all():
            rows, rid, words = rows[keep], rid[keep], words[keep]
        if rows.shape[0] == 0:
            return None
        if x >= self.test_from:
            hit = np.flatnonzero(_trie.superset_mask(self.fsorted, rows, sorted_stored=True, tasks=self.tasks,
                                                     split=self.fsplit))
            if hit.size:
                q = int(hit[0])
                return self.hit(rows[q], int(rid[q]), [int(a) for a in words[q][::-1]], x)
        return self.grow(rows, rid, words, x)


def _budget_notes(aut, lower, pair_mb, eppstein, no_greedy):
    """The notes of a search stopped by its budget: the proven bound, the pair-graph check skipped
    (``pair_mb``: the memory it would have needed, or None when it ran), the slower greedy used
    (Eppstein's tables did not fit), no greedy word found."""
    notes = [f"exact search stopped by its budget; no synchronizing word is shorter than {lower}"]
    if pair_mb is not None:
        notes.append(f"pair-graph synchronizability check skipped: {aut.n} states would need about "
                     f"{pair_mb:,.0f} MB (over half the memory budget)")
    if aut.deterministic and not eppstein:
        notes.append(f"greedy by merging one pair at a time (pair graph searched from each pair): Eppstein's "
                     f"tables would need about {eppstein_memory_mb(aut.n):,.0f} MB (over the memory budget)")
    if no_greedy:
        notes.append(f"greedy word not found within {_GREEDY_SHARE:.0%} of the time budget")
    return notes


def shortest_synchronizing_word(aut: SyncAutomaton | TransitionModel, start=None, time_budget: float | None = 60.0,
                                memory_budget_mb: float = 2048.0, node_budget: int | None = None, *,
                                options: ExactSearchOptions | None = None, clock=time.perf_counter) -> SyncResult:
    """The shortest word synchronizing ``start`` (default: all states).

    Exact bidirectional subset search (Kisielewicz, Kowalski and Szykula 2015): forward images of
    the start set and inverse images of singletons, breadth-first, hashed bitsets, meeting when a
    forward set lies inside a backward one; totals ``i + j`` are checked in increasing order, so
    the first meeting is a shortest word. The search only has to prove that no word is shorter than
    the best word known: Eppstein's greedy word, improved by inverse beam searches
    (:func:`~kruskal_markov.sync.beam.inverse_beam_word`, synchrowords' first phase) within the
    greedy's share of the time. If a direction is exhausted without meeting, no word
    exists. When a direction's store fills ``memory_budget_mb``, the other direction goes on; when
    both are full the search continues depth-first (the forward frontier expanded chunk by chunk
    against the newest backward level, pairs' merging distances pruning; Szykula and Zyzik 2022),
    so memory never costs exactness. Past ``time_budget`` seconds (None: no limit) or
    ``node_budget`` subsets generated (None: no limit; tests use this, not seconds) the result is
    the best word known (greedy or beam, found first within 40% of the time) with ``exact=False``
    and a proven ``lower_bound``; once the search proves that no word is shorter than that word,
    it is exact (method ``beam+lower-bound`` or ``greedy-eppstein+lower-bound``). A breadth-first
    level predicted to overrun the time budget is tested streaming (the depth-first phase), so a
    word at that level is still found if the time allows.

    Parameters
    ----------
    aut : SyncAutomaton or TransitionModel
        The automaton, or a model standing for its support automaton and start set.
    start : array_like of int, optional
        The set to synchronize (default: all states of an automaton, the start set of a model); a
        single state gives the empty word (``method`` ``trivial``).
    time_budget : float or None, default 60.0
        Seconds; None: no limit.
    memory_budget_mb : float, default 2048.0
        Memory of the subset stores.
    node_budget : int or None, default None
        Subsets generated before the search stops (None: no limit).
    options : ExactSearchOptions, optional
        The search's design switches (:class:`~kruskal_markov.sync.options.ExactSearchOptions`;
        None: the defaults, the measured best). They change the work done, never a proven answer.
    clock : callable, default time.perf_counter
        Seconds for the time budget and ``seconds`` (tests pass a fake clock).

    Returns
    -------
    SyncResult
        ``word`` as letter indices; ``exact`` True with the shortest word (or with ``word`` None
        and a ``witness`` when none exists); otherwise the greedy word with a ``lower_bound``.

    References
    ----------
    A. Kisielewicz, J. Kowalski and M. Szykula, "Computing the shortest reset words of
    synchronizing automata", J. Comb. Optim. 29 (2015) 88-124. M. Szykula and A. Zyzik, "An
    improved algorithm for finding the shortest synchronizing words", ESA 2022.

    Examples
    --------
    >>> a = SyncAutomaton.from_table([[1, 2, 0], [0, 1, 0]])   # Cerny C_3
    >>> r = shortest_synchronizing_word(a)
    >>> r.length, r.exact
    (4, True)
    """
    aut, start = as_automaton(aut, start)
    opts = (ExactSearchOptions() if options is None else options).resolved()
    if (time_budget is not None and not time_budget > 0) or memory_budget_mb <= 0:
        raise ValueError("time and memory budgets must be positive")
    if node_budget is not None and (int(node_budget) != node_budget or node_budget < 1):
        raise ValueError(f"node_budget must be a positive integer, got {node_budget!r}")
    t0 = clock()
    s = as_start(aut, start)
    if s.size == 1:
        return SyncResult([], 0, True, "trivial", seconds=clock() - t0)
    # a greedy word first (within a share of the time): it answers if the exact search stops, and
    # it proves synchronizability, so the quadratic pair-graph check runs only without one (to
    # find a witness that no word exists); the exact search then has the rest of the time
    eppstein = _eppstein_fits(aut, memory_budget_mb)
    greedy = greedy_synchronizing_word(aut, s, memory_budget_mb=memory_budget_mb,
                                       deadline=None if time_budget is None else t0 + _GREEDY_SHARE * time_budget,
                                       clock=clock)
    pair_mb = pair_check_memory_mb(aut.n)
    skipped = greedy is None and pair_mb > 0.5 * memory_budget_mb
    if greedy is None and not skipped:
        check = synchronizability(aut, s)
        if check["synchronizing"] is False:
            return SyncResult(None, None, True, "pair-graph", witness=check["witness"],
                              seconds=clock() - t0)
    status, spent = "budget", 0
    if opts.fast_nodes and node_budget is None and greedy is not None:
        # small searches first: an exact search capped at ``opts.fast_nodes`` sets, below the greedy
        # word, answers small automata before the beam would have run (the beam is most of their time)
        word, status, spent, lower = _exact_search(aut, s, time_budget, memory_budget_mb, opts.fast_nodes, len(greedy),
                                                   strict=True, options=opts, clock=clock)
        opts.emit("fast-path", spent)
        best, from_beam = greedy, False
    if status == "budget":
        best, from_beam = _beam_upper(aut, s, greedy, memory_budget_mb,
                                      None if time_budget is None else t0 + _GREEDY_SHARE * time_budget, node_budget,
                                      opts, clock)
        remaining = None if time_budget is None else max(time_budget - (clock() - t0), 1e-3)
        word, status, explored, lower = _exact_search(aut, s, remaining, memory_budget_mb, node_budget,
                                                      None if best is None else len(best), options=opts, clock=clock)
        explored += spent
    else:
        explored = spent
    if status in ("found", "found-dfs"):
        if not is_synchronizing_word(aut, word, s):
            raise AssertionError("internal error: exact search returned a non-synchronizing word")
        return SyncResult(word, len(word), True,
                          "bidirectional-bfs" + ("+dfs" if status == "found-dfs" else ""), states_explored=explored,
                          lower_bound=len(word), seconds=clock() - t0, threads=opts.threads)
    if status == "none":
        return SyncResult(None, None, True, "bidirectional-bfs", states_explored=explored,
                          witness={"kind": "exhaustive", "subsets_explored": explored,
                                   "reason": "exhaustive subset search: no image of the start set "
                                             "is a single state"},
                          seconds=clock() - t0, threads=opts.threads)
    method = "beam" if from_beam else "greedy-eppstein" if eppstein else "greedy"
    if status == "budget" and word is not None and (best is None or len(word) < len(best)):
        best, method = word, "bidirectional-bfs+dfs"   # a word the inverse depth-first phase found, unproven
    if status == "upper":       # proven: nothing shorter than the beam's or the greedy word
        return SyncResult(best, len(best), True, method + "+lower-bound", lower_bound=len(best),
                          states_explored=explored, greedy_length=None if greedy is None else len(greedy),
                          seconds=clock() - t0, threads=opts.threads)
    notes = _budget_notes(aut, lower, pair_mb if skipped else None, eppstein, greedy is None)
    meets_bound = best is not None and len(best) <= lower   # the best word meets the proven lower bound
    return SyncResult(best, None if best is None else len(best), meets_bound,
                      method + "+lower-bound" if meets_bound else method,
                      lower_bound=lower, states_explored=explored,
                      greedy_length=None if greedy is None else len(greedy),
                      seconds=clock() - t0, notes=notes, threads=opts.threads)
