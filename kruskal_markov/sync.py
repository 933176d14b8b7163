"""Synchronizing words: support automata, synchronizability, shortest and greedy reset words,
and epsilon-synchronizing words of stochastic models.

A *synchronizing* (reset) word ``w`` drives a start set ``S`` of states to a single state:
``|S . w| = 1``. For a deterministic automaton ``S`` is the whole state set (a reset word); for a
tray model it is the support of the initial distribution. For a stochastic model we work on its
*support automaton* (entries ``>= threshold``), where the image of a set is the union of the
supports of its states: a word that synchronizes the support automaton orients the part with
certainty (up to the dropped probability mass).

Algorithms
----------
* Synchronizability: the pair graph (Cerny 1964; Eppstein 1990): a deterministic automaton is
  synchronizing iff every pair of states can be merged, decided in ``O(k n^2)``.
* Exact shortest word: bidirectional breadth-first search over subsets stored as bitsets --
  images of the start set forward, preimages of singletons backward, meeting when a forward set is
  contained in a backward set -- as in Kisielewicz, Kowalski and Szykula, "Computing the shortest
  reset words of synchronizing automata", J. Comb. Optim. 29 (2015), and Kisielewicz and Szykula,
  "Experiments with synchronizing automata", CIAA 2016. ``exact`` is True only when the search
  proved optimality.
* Greedy: Eppstein, "Reset sequences for monotonic automata", SIAM J. Comput. 19 (1990):
  repeatedly merge the pair with the shortest merging word.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from kruskal_markov import _sync_kernels as _k
from kruskal_markov._subsets import SubsetStore, as_start, pair_index
from kruskal_markov.entropy import distribution_entropy_bits, partition_entropy_bits

if TYPE_CHECKING:
    from kruskal_markov.model import TransitionModel

__all__ = [
    "SyncAutomaton",
    "SyncResult",
    "as_automaton",
    "epsilon_synchronizing_word",
    "greedy_synchronizing_word",
    "is_synchronizing_word",
    "pair_check_memory_mb",
    "shortest_synchronizing_word",
    "start_set",
    "support_automaton",
    "synchronizability",
]


# ----------------------------------------------------------------------------- automata
@dataclass
class SyncAutomaton:
    """A (possibly set-valued) automaton over ``n`` states and ``k`` letters.

    Attributes
    ----------
    actions : tuple of str
    n : int
    deterministic : bool
    indptr, indices : ndarray
        Supports as a packed CSR: row ``q`` of letter ``a`` is
        ``indices[indptr[a, q]:indptr[a, q + 1]]`` (``indptr`` int64 of shape ``(k, n + 1)``).
    mass_dropped : float
        Largest probability mass of one row removed by the threshold (0 for deterministic input).
    """

    actions: tuple
    n: int
    deterministic: bool
    indptr: np.ndarray
    indices: np.ndarray
    mass_dropped: float = 0.0
    mass_dropped_mean: float = 0.0
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def k(self) -> int:
        return len(self.actions)

    @property
    def n_words(self) -> int:
        return (self.n + 63) // 64

    @classmethod
    def from_table(cls, table, actions=None) -> SyncAutomaton:
        """A deterministic automaton from a next-state table ``table[a, q]``.

        >>> SyncAutomaton.from_table([[1, 2, 0], [0, 0, 2]]).deterministic
        True
        """
        t = np.asarray(table)
        if t.ndim != 2 or t.shape[1] == 0 or t.shape[0] == 0:
            raise ValueError("a transition table must have shape (letters, states) with both > 0")
        if not np.issubdtype(t.dtype, np.integer):
            raise ValueError("a transition table must hold integer state indices")
        k, n = t.shape
        if t.min() < 0 or t.max() >= n:
            raise ValueError(f"transition table entries must lie in [0, {n})")
        if actions is None:
            actions = tuple(str(i) for i in range(k))
        if len(actions) != k:
            raise ValueError(f"{len(actions)} action names for {k} letters")
        indptr = (np.arange(n + 1, dtype=np.int64)[None, :] + (np.arange(k, dtype=np.int64) * n)[:, None])
        return cls(tuple(actions), n, True, indptr, t.astype(np.int32).ravel().copy())

    @property
    def delta(self) -> np.ndarray:
        """Next-state table ``(k, n)`` int32; ``-1`` everywhere for set-valued automata."""
        if "delta" not in self._cache:
            if self.deterministic:
                d = self.indices[self.indptr[:, :-1]].astype(np.int32)
            else:
                d = np.full((self.k, self.n), -1, dtype=np.int32)
            self._cache["delta"] = d
        return self._cache["delta"]

    @property
    def sup(self) -> np.ndarray:
        """Support bitsets ``(k, n, words)`` uint64 (a dummy for deterministic automata)."""
        if "sup" not in self._cache:
            if self.deterministic:
                s = np.zeros((1, 1, 1), dtype=np.uint64)
            else:
                s = np.zeros((self.k, self.n, self.n_words), dtype=np.uint64)
                for a in range(self.k):
                    for q in range(self.n):
                        for r in self.indices[self.indptr[a, q]:self.indptr[a, q + 1]]:
                            s[a, q, r >> 6] |= np.uint64(1) << np.uint64(r & 63)
            self._cache["sup"] = s
        return self._cache["sup"]

    @property
    def inverse(self):
        """Inverse adjacency ``(inv_ptr (k, n+1), inv_idx, supcount (k, n))``: the states ``q`` with
        ``r`` in ``supp(q, a)`` are ``inv_idx[inv_ptr[a, r]:inv_ptr[a, r + 1]]``."""
        if "inverse" not in self._cache:
            k, n = self.k, self.n
            inv_ptr = np.zeros((k, n + 1), dtype=np.int64)
            parts = []
            supcount = np.diff(self.indptr, axis=1).astype(np.int64)
            offset = 0
            for a in range(k):
                seg = self.indices[self.indptr[a, 0]:self.indptr[a, n]].astype(np.int64)
                src = np.repeat(np.arange(n, dtype=np.int64), supcount[a])
                order = np.argsort(seg, kind="stable")
                parts.append(src[order].astype(np.int32))
                inv_ptr[a, 1:] = offset + np.cumsum(np.bincount(seg, minlength=n))
                inv_ptr[a, 0] = offset
                offset += seg.size
            inv_idx = np.concatenate(parts) if parts else np.zeros(0, dtype=np.int32)
            self._cache["inverse"] = (inv_ptr, inv_idx, supcount)
        return self._cache["inverse"]

    def bits(self, states) -> np.ndarray:
        """Bitset of a collection of states."""
        out = np.zeros(self.n_words, dtype=np.uint64)
        for q in np.asarray(states, dtype=np.int64).ravel():
            out[q >> 6] |= np.uint64(1) << np.uint64(q & 63)
        return out

    def states_of(self, bits) -> list:
        """The sorted states of a bitset."""
        out = []
        for w, x in enumerate(np.asarray(bits, dtype=np.uint64)):
            x = int(x)
            while x:
                b = (x & -x).bit_length() - 1
                out.append(w * 64 + b)
                x &= x - 1
        return out

    def image(self, states, word) -> list:
        """The image of a set of states under a word (list of letter indices)."""
        w = np.asarray(word, dtype=np.int64)
        if w.size and (w.min() < 0 or w.max() >= self.k):
            raise ValueError(f"letters must lie in [0, {self.k})")
        return self.states_of(_k.apply_word(self.bits(states), w, self.delta, self.sup, self.deterministic))

    def pair_distances(self):
        """Shortest merging length of every pair (``-1``: never), and a first letter of it."""
        if "pairs" not in self._cache:
            self._cache["pairs"] = _k.pair_merge_distance(self.indptr, self.indices, self.n)
        return self._cache["pairs"]


def support_automaton(model, threshold: float = 0.0) -> SyncAutomaton:
    """The support automaton of a :class:`~kruskal_markov.model.TransitionModel`.

    Keeps, per action and row, the entries ``>= threshold`` (always at least the largest entry of
    the row, so no row is empty); ``mass_dropped`` is the largest probability mass removed from
    one row. A model whose kept rows are all single entries gives a deterministic automaton.
    """
    threshold = float(threshold)
    if not (0.0 <= threshold <= 1.0) or math.isnan(threshold):
        raise ValueError(f"threshold must lie in [0, 1], got {threshold}")
    n, k = model.n_states, model.n_actions
    indptr = np.empty((k, n + 1), dtype=np.int64)
    parts = []
    offset = 0
    worst = 0.0
    total = 0.0
    for a, m in enumerate(model.matrices):
        m = sp.csr_matrix(m)
        data = m.data
        keep = data >= threshold if threshold > 0 else data > 0
        # keep the largest entry of every row
        rows = np.repeat(np.arange(n), np.diff(m.indptr))
        if m.nnz:
            order = np.lexsort((-data, rows))
            first = order[np.r_[0, np.flatnonzero(np.diff(rows[order])) + 1]]
            keep[first] = True
        dropped = np.bincount(rows[~keep], weights=data[~keep], minlength=n)
        worst = max(worst, float(dropped.max()) if n else 0.0)
        total += float(dropped.sum())
        counts = np.bincount(rows[keep], minlength=n)
        indptr[a, 0] = offset
        indptr[a, 1:] = offset + np.cumsum(counts)
        parts.append(m.indices[keep].astype(np.int32))
        offset += int(counts.sum())
    indices = np.concatenate(parts) if parts else np.zeros(0, dtype=np.int32)
    det = bool(np.all(np.diff(indptr, axis=1) == 1))
    return SyncAutomaton(tuple(model.actions), n, det, indptr, indices, worst, total / max(1, n * k))


def start_set(model, whole: bool | None = None) -> np.ndarray:
    """The start set: the support of ``model.initial``, or all states when ``whole``.

    ``whole=None`` means: all states for a deterministic automaton, the initial support otherwise.
    """
    if whole is None:
        whole = model.is_deterministic()
    if whole:
        return np.arange(model.n_states)
    return np.flatnonzero(np.asarray(model.initial) > 0)


def as_automaton(aut, start=None):
    """``(automaton, start)`` for the sync and convergence functions, which take a
    :class:`SyncAutomaton` or a :class:`~kruskal_markov.model.TransitionModel` alike: a model
    stands for its support automaton (:func:`support_automaton`, kept on the model) and, when
    ``start`` is None, for its start set (:func:`start_set`)."""
    if isinstance(aut, SyncAutomaton):
        return aut, start
    if hasattr(aut, "matrices") and hasattr(aut, "memo"):
        model = aut
        return (model.memo(("support_automaton", 0.0), lambda: support_automaton(model)),
                start_set(model) if start is None else start)
    raise TypeError(f"expected a SyncAutomaton or a TransitionModel, got {type(aut).__name__}")


def is_synchronizing_word(aut: SyncAutomaton | TransitionModel, word, start=None) -> bool:
    """True if ``word`` maps the start set (default: all states) onto one state."""
    aut, start = as_automaton(aut, start)
    return len(aut.image(as_start(aut, start), word)) == 1


# ----------------------------------------------------------------------------- synchronizability
def synchronizability(aut: SyncAutomaton | TransitionModel, start=None) -> dict:
    """Polynomial synchronizability test via the pair graph.

    Returns ``{"synchronizing": True | False | None, "witness": dict | None}``. ``False`` comes with
    a pair of start states that no word merges; ``None`` means the pair test cannot decide (a proper
    start subset, or a set-valued automaton: those questions are PSPACE-complete in general and
    are settled by the exhaustive search of :func:`shortest_synchronizing_word`).

    >>> a = SyncAutomaton.from_table([[1, 2, 3, 0], [0, 1, 2, 0]])   # Cerny C_4
    >>> synchronizability(a)["synchronizing"]
    True
    """
    aut, start = as_automaton(aut, start)
    s = as_start(aut, start)
    if s.size == 1:
        return {"synchronizing": True, "witness": None}
    dist, _ = aut.pair_distances()
    n = aut.n
    p, q = np.meshgrid(s, s, indexing="ij")
    mask = p < q
    p, q = p[mask], q[mask]
    idx = pair_index(p, q, n)
    bad = np.flatnonzero(dist[idx] < 0)
    if bad.size:
        i = bad[0]
        pair = [int(p[i]), int(q[i])]
        return {"synchronizing": False,
                "witness": {"kind": "pair", "states": pair,
                            "reason": f"no word merges states {pair[0]} and {pair[1]}"}}
    if not aut.deterministic:
        return {"synchronizing": None, "witness": None}
    if s.size == aut.n:
        return {"synchronizing": True, "witness": None}
    # states reachable from the start set: if all their pairs merge, greedy merging succeeds
    reach = _reachable_states(aut, s)
    p, q = np.meshgrid(reach, reach, indexing="ij")
    mask = p < q
    p, q = p[mask], q[mask]
    idx = pair_index(p, q, n)
    if np.all(dist[idx] >= 0):
        return {"synchronizing": True, "witness": None}
    return {"synchronizing": None, "witness": None}


def _reachable_states(aut: SyncAutomaton, s) -> np.ndarray:
    seen = np.zeros(aut.n, dtype=bool)
    seen[s] = True
    frontier = np.asarray(s)
    while frontier.size:
        nxt = []
        for a in range(aut.k):
            lo, hi = aut.indptr[a, frontier], aut.indptr[a, frontier + 1]
            for x, y in zip(lo, hi):
                nxt.append(aut.indices[x:y])
        cand = np.unique(np.concatenate(nxt)) if nxt else np.zeros(0, dtype=np.int64)
        cand = cand[~seen[cand]]
        seen[cand] = True
        frontier = cand.astype(np.int64)
    return np.flatnonzero(seen)


# ----------------------------------------------------------------------------- results
@dataclass(frozen=True)
class SyncResult:
    """Outcome of a synchronizing-word search (immutable).

    ``word`` (letter indices) and ``length`` are None when no word exists (``exact`` True, with a
    ``witness``) or when none was found within the budgets (``exact`` False). ``best_word`` is
    the lowest-entropy word an epsilon search had seen when its budget ran out (else None).
    """

    word: list | None
    length: int | None
    exact: bool
    method: str
    witness: dict | None = None
    lower_bound: int | None = None
    greedy_length: int | None = None
    states_explored: int = 0
    seconds: float = 0.0
    notes: tuple = ()
    best_word: list | None = None

    def __post_init__(self):
        object.__setattr__(self, "notes", tuple(self.notes))

    def as_dict(self, actions=None) -> dict:
        word = self.word
        if word is not None and actions is not None:
            word = [actions[a] for a in word]
        return {"word": word, "length": self.length, "exact": self.exact, "method": self.method,
                "witness": self.witness, "lower_bound": self.lower_bound,
                "greedy_length": self.greedy_length, "states_explored": self.states_explored,
                "notes": list(self.notes)}


_BLOCK = 1 << 16


def _choose_forward(fwd, bwd, k):
    """Which side to expand: the one with the smaller newest level (forward on a tie)."""
    (flo, fhi), (blo, bhi) = fwd.levels[-1], bwd.levels[-1]
    return (fhi - flo) <= (bhi - blo)


def _exact_search(aut: SyncAutomaton, start, time_budget, memory_budget_mb, node_budget=None):
    """Bidirectional BFS. Returns ``(word | None, status, explored, lower_bound)`` with status
    'found', 'none' (proven: no word) or 'budget'. ``node_budget``, when given, caps the subsets
    stored per direction (a budget that does not depend on the machine's speed)."""
    t0 = time.perf_counter()
    W = aut.n_words
    row_bytes = 8 * W + 8 + 4 + 16 * 2      # rows + parent + letter + hash table (load <= 1/2, x2 growth)
    max_rows = max(1024, int(memory_budget_mb * 2 ** 20 / row_bytes / 2))   # per direction
    if node_budget is not None:
        max_rows = min(max_rows, node_budget)
    if aut.n >= max_rows:       # not even the n backward roots fit: no exact search in this budget
        return None, "budget", 0, 1
    fwd = SubsetStore(W, 1024, max_rows)
    bwd = SubsetStore(W, max(1024, aut.n), max_rows)
    fwd.add_roots([aut.bits(start)])
    singletons = []
    for q in range(aut.n):
        b = np.zeros(W, dtype=np.uint64)
        b[q >> 6] = np.uint64(1) << np.uint64(q & 63)
        singletons.append(b)
    bwd.add_roots(singletons)
    total = 0
    block = _BLOCK
    # first guesses (updated from measurements); both grow with the bitset width W
    rate_row = 2e-7 * max(1.0, W / 16)     # seconds per generated row
    rate_pair = 5e-11 * max(1.0, W / 4)    # seconds per (forward set x backward set) pair in the meet test
    while True:
        (flo, fhi), (blo, bhi) = fwd.levels[-1], bwd.levels[-1]
        tm = time.perf_counter()
        # the meet test in slices of the forward level, so that the budget is checked between them
        # (its cost depends on how the set sizes of the two levels overlap, which is hard to predict)
        f = b = -1
        for lo in range(flo, fhi, _MEET_SLICE):
            if total and time.perf_counter() - t0 > time_budget:
                # the meet test of length ``total`` did not finish: only shorter words are excluded
                return None, "budget", fwd.count + bwd.count, total
            f, b = _k.meet(fwd.rows, lo, min(fhi, lo + _MEET_SLICE), bwd.rows, blo, bhi, aut.n, block)
            if f >= 0:
                break
        pairs = (fhi - flo) * (bhi - blo)
        if pairs > 10_000_000:
            rate_pair = (time.perf_counter() - tm) / pairs
        if f >= 0:
            u, _ = fwd.path(f)
            v, _ = bwd.path(b)
            word = u[::-1] + v
            return word, "found", fwd.count + bwd.count, total
        # expand the side with the smaller newest level (inverse steps cost ~ n per set)
        forward = _choose_forward(fwd, bwd, aut.k)
        store = fwd if forward else bwd
        # predicted cost of the next level (expansion + meet test); stop before the budget is blown
        lo, hi = store.levels[-1]
        growth = aut.k if len(store.levels) < 2 else \
            max(1.0, (hi - lo) / max(1, store.levels[-2][1] - store.levels[-2][0]))
        new_rows = (hi - lo) * min(growth, aut.k)
        other = (bhi - blo) if forward else (fhi - flo)
        predicted = new_rows * rate_row + new_rows * other * rate_pair
        if time.perf_counter() - t0 + predicted > time_budget:
            return None, "budget", fwd.count + bwd.count, total + 1
        te = time.perf_counter()
        grown = store.expand(aut, forward)
        if grown is None:
            return None, "budget", fwd.count + bwd.count, total + 1
        if grown > 10_000:
            rate_row = max(1e-9, (time.perf_counter() - te) / grown)
        if grown == 0:
            return None, "none", fwd.count + bwd.count, total
        total += 1


def pair_check_memory_mb(n: int) -> float:
    """Memory (MB) of the pair table on ``n`` states (the pair-graph check and Eppstein's greedy)."""
    return n * (n - 1) / 2 * PAIR_CHECK_BYTES / 2 ** 20


def eppstein_memory_mb(n: int) -> float:
    """Memory (MB) of Eppstein's greedy on ``n`` states: the pair table and the word buffer."""
    return pair_check_memory_mb(n) + 16.0 * n * n / 2 ** 20


def _eppstein_fits(aut: SyncAutomaton, memory_budget_mb: float | None) -> bool:
    """Whether the greedy word is Eppstein's: a deterministic automaton whose tables fit the budget."""
    return aut.deterministic and (memory_budget_mb is None or eppstein_memory_mb(aut.n) <= memory_budget_mb)


def greedy_synchronizing_word(aut: SyncAutomaton | TransitionModel, start=None, node_budget: int = 200_000,
                              memory_budget_mb: float | None = None, deadline: float | None = None):
    """A synchronizing word, not necessarily shortest, or None if none was found.

    Deterministic automata: Eppstein's (1990) greedy pair merging (``O(k n^2)`` pair BFS plus
    ``O(n^3)`` merging), which always succeeds on a synchronizable start set whose reachable pairs
    all merge -- when its quadratic tables (:func:`eppstein_memory_mb`) fit in ``memory_budget_mb``.
    Otherwise, and for set-valued automata, one pair at a time (:func:`_pair_merging_greedy`:
    breadth-first in the pair graph from each pair, no tables); if that fails, greedy descent,
    repeatedly running a breadth-first
    search of at most ``node_budget`` subsets (fewer if ``memory_budget_mb`` says so) from the
    current set to the nearest strictly smaller image, until ``deadline`` (a
    ``time.perf_counter()`` value; None if it passes). The returned word is verified.
    """
    aut, start = as_automaton(aut, start)
    s = as_start(aut, start)
    if s.size == 1:
        return []
    word = None
    if memory_budget_mb is not None:
        row_bytes = 8 * aut.n_words + 8 + 4 + 32
        node_budget = max(1024, min(node_budget, int(memory_budget_mb * 2 ** 20 / row_bytes)))
    if _eppstein_fits(aut, memory_budget_mb):
        dist, nxt = aut.pair_distances()
        out = np.empty(max(16, aut.n ** 3 // 6 + aut.n), dtype=np.int32) if aut.n <= 256 else \
            np.empty(4 * aut.n * aut.n, dtype=np.int32)
        length = _k.eppstein_greedy(aut.delta, s.astype(np.int64), dist, nxt, out)
        if length >= 0:
            word = [int(x) for x in out[:length]]
    if word is None:
        max_pairs = None if memory_budget_mb is None else max(1 << 16, int(memory_budget_mb * 2 ** 20 / 64))
        word = _pair_merging_greedy(aut, s, deadline, max_pairs)
    if word is None:
        word = _greedy_descent(aut, s, node_budget, deadline)
    if word is not None and not is_synchronizing_word(aut, word, s):
        raise AssertionError("internal error: greedy word does not synchronize")
    return word


def _set_image(aut, states, a):
    """Image of the state set ``states`` (int64, sorted) under letter ``a`` (every successor),
    straight from the CSR supports: :meth:`SyncAutomaton.image` would first build the set-valued
    automaton's ``(k, n, n/64)`` support bitsets (10 GB at 100,000 states)."""
    lo, hi = aut.indptr[a][states], aut.indptr[a][states + 1]
    lengths = hi - lo
    idx = np.repeat(lo - np.concatenate(([0], np.cumsum(lengths)[:-1])), lengths) + np.arange(lengths.sum())
    return np.unique(aut.indices[idx].astype(np.int64))


def _pair_merging_greedy(aut, s, deadline=None, max_pairs=None):
    """Greedy pair merging without Eppstein's tables: while the current set has two or more
    states, search breadth-first in the pair graph from two of its states for the shortest word
    that merges them, and apply it to the whole set. The search follows single-valued rows only (a
    set-valued row -- e.g. the uniform start states' first tilt, or a row that member probes
    spread over several landings -- is left out of it; applied to the whole set, the word may still
    take other states through such rows, and the set grows by their images); while the set holds a
    state whose rows are set-valued under every letter (the uniform start states), the letter with
    the smallest image is applied first. Each search visits only the pairs reachable from its start
    pair (at most ``max_pairs``). None if a search exhausts its pairs without merging, exceeds
    ``max_pairs``, the word grows past ``4 n`` letters, or ``deadline`` passes."""
    n, k = aut.n, aut.k
    single = []
    for a in range(k):
        ptr = aut.indptr[a]
        one = np.diff(ptr) == 1
        single.append(np.where(one, aut.indices[np.minimum(ptr[:-1], aut.indices.size - 1)], -1).astype(np.int64))
    multi = np.ones(n, dtype=bool)                        # set-valued under every letter
    for a in range(k):
        multi &= single[a] < 0
    states = np.unique(np.asarray(s, dtype=np.int64))
    word = []
    while states.size > 1:
        if deadline is not None and time.perf_counter() > deadline:
            return None
        if multi[states].any():
            images = [_set_image(aut, states, a) for a in range(k)]
            best = min(range(k), key=lambda a: images[a].size)
            word.append(best)
            states = images[best]
            if len(word) > 4 * n:
                return None
            continue
        u = _merging_word(single, n, int(states[0]), int(states[1]), deadline, max_pairs)
        if u is None:
            return None
        word += u
        if len(word) > 4 * n:
            return None
        for a in u:
            states = _set_image(aut, states, a)
    return word


def _merging_word(single, n, p, q, deadline, max_pairs):
    """Shortest word merging states ``p`` and ``q`` along single-valued rows (breadth-first in the
    pair graph, level by level in numpy); None if there is none within the limits."""
    level_keys = [np.array([min(p, q) * n + max(p, q)], dtype=np.int64)]
    parents, letters = [np.array([-1])], [np.array([-1])]
    seen = level_keys[0]
    while True:
        if deadline is not None and time.perf_counter() > deadline:
            return None
        keys = level_keys[-1]
        if keys.size == 0:
            return None                                   # the pair never merges
        lo, hi = keys // n, keys % n
        nk, npar, nlet = [], [], []
        for a, nxt in enumerate(single):
            x, y = nxt[lo], nxt[hi]
            ok = (x >= 0) & (y >= 0)
            hit = np.flatnonzero(ok & (x == y))
            if hit.size:
                u = [a]
                depth, idx = len(level_keys) - 1, int(hit[0])
                while depth > 0:
                    u.append(int(letters[depth][idx]))
                    idx = int(parents[depth][idx])
                    depth -= 1
                return u[::-1]
            keep = np.flatnonzero(ok)
            nk.append(np.minimum(x[keep], y[keep]) * n + np.maximum(x[keep], y[keep]))
            npar.append(keep)
            nlet.append(np.full(keep.size, a))
        k_all = np.concatenate(nk)
        k_new, first = np.unique(k_all, return_index=True)
        fresh = ~np.isin(k_new, seen, assume_unique=True)
        k_new, first = k_new[fresh], first[fresh]
        seen = np.union1d(seen, k_new)
        if max_pairs is not None and seen.size > max_pairs:
            return None
        level_keys.append(k_new)
        parents.append(np.concatenate(npar)[first])
        letters.append(np.concatenate(nlet)[first])


def _greedy_descent(aut, s, node_budget, deadline=None):
    """Greedy descent: apply the letter whose image of the current set is smallest while one
    shrinks it (deterministic automata), else search breadth-first for the nearest smaller image."""
    W = aut.n_words
    word = []
    if aut.deterministic:
        states = np.unique(np.asarray(s, dtype=np.int64))
        while states.size > 1:
            if deadline is not None and time.perf_counter() > deadline:
                return None
            images = [np.unique(aut.delta[a][states]) for a in range(aut.k)]
            best = min(range(aut.k), key=lambda a: images[a].size)
            if images[best].size >= states.size:
                break
            word.append(best)
            states = images[best].astype(np.int64)
        s = states
    cur = aut.bits(s)
    while True:
        size = len(aut.states_of(cur))
        if size == 1:
            return word
        if deadline is not None and time.perf_counter() > deadline:
            return None
        st = SubsetStore(W, 1024, node_budget)
        st.add_roots([cur])
        found = None
        while found is None:
            if deadline is not None and time.perf_counter() > deadline:
                return None
            grown = st.expand(aut, True)
            if not grown:
                return None
            lo, hi = st.levels[-1]
            best, best_size = -1, size
            for i in range(lo, hi):
                c = _k.set_size(st.rows, i)
                if c < best_size:
                    best, best_size = i, c
            if best >= 0:
                found = best
        u, _ = st.path(found)
        word += u[::-1]
        cur = st.rows[found].copy()


#: bytes per state pair of the pair-graph synchronizability check (distance table and BFS work arrays).
PAIR_CHECK_BYTES = 40
#: share of ``time_budget`` the greedy word may use before the exact search starts.
_GREEDY_SHARE = 0.4
#: forward sets per call of the meet test (the time budget is checked between calls)
_MEET_SLICE = 2048


def shortest_synchronizing_word(aut: SyncAutomaton | TransitionModel, start=None, time_budget: float = 60.0,
                                memory_budget_mb: float = 2048.0, node_budget: int | None = None) -> SyncResult:
    """The shortest word synchronizing ``start`` (default: all states).

    Exact bidirectional subset search (Kisielewicz, Kowalski and Szykula 2015): forward images of
    the start set and inverse images of singletons, breadth-first, hashed bitsets, meeting when a
    forward set lies inside a backward one; totals ``i + j`` are checked in increasing order, so
    the first meeting is a shortest word. If a direction is exhausted without meeting, no word
    exists. Past ``time_budget`` seconds or ``memory_budget_mb`` the result is the greedy word
    (:func:`greedy_synchronizing_word`, found first within 40% of the time) with ``exact=False``
    and a proven ``lower_bound``.

    ``node_budget`` (subsets stored per search direction), when given, replaces ``time_budget``:
    the search then stops after a fixed amount of work, so the answer is the same on a fast and on
    a loaded machine (the greedy word runs to its own subset budget, without a deadline).

    >>> a = SyncAutomaton.from_table([[1, 2, 0], [0, 1, 0]])   # Cerny C_3
    >>> r = shortest_synchronizing_word(a)
    >>> r.length, r.exact
    (4, True)
    """
    aut, start = as_automaton(aut, start)
    if time_budget <= 0 or memory_budget_mb <= 0:
        raise ValueError("time and memory budgets must be positive")
    if node_budget is not None:
        node_budget = _check_node_budget(node_budget)
        time_budget = math.inf          # deterministic: work, not seconds, bounds the search
    t0 = time.perf_counter()
    s = as_start(aut, start)
    if s.size == 1:
        return SyncResult([], 0, True, "trivial", seconds=time.perf_counter() - t0)
    # a greedy word first (within a share of the time): it answers if the exact search stops, and
    # it proves synchronizability, so the quadratic pair-graph check runs only without one (to
    # find a witness that no word exists); the exact search then has the rest of the time
    eppstein = _eppstein_fits(aut, memory_budget_mb)
    greedy = greedy_synchronizing_word(aut, s, memory_budget_mb=memory_budget_mb,
                                       deadline=t0 + _GREEDY_SHARE * time_budget)
    pair_mb = pair_check_memory_mb(aut.n)
    skipped = greedy is None and pair_mb > 0.5 * memory_budget_mb
    if greedy is None and not skipped:
        check = synchronizability(aut, s)
        if check["synchronizing"] is False:
            return SyncResult(None, None, True, "pair-graph", witness=check["witness"],
                              seconds=time.perf_counter() - t0)
    remaining = max(time_budget - (time.perf_counter() - t0), 1e-3)
    word, status, explored, lower = _exact_search(aut, s, remaining, memory_budget_mb, node_budget)
    if status == "found":
        if not is_synchronizing_word(aut, word, s):
            raise AssertionError("internal error: exact search returned a non-synchronizing word")
        return SyncResult(word, len(word), True, "bidirectional-bfs", states_explored=explored,
                          lower_bound=len(word), seconds=time.perf_counter() - t0)
    if status == "none":
        return SyncResult(None, None, True, "bidirectional-bfs", states_explored=explored,
                          witness={"kind": "exhaustive", "subsets_explored": explored,
                                   "reason": "exhaustive subset search: no image of the start set "
                                             "is a single state"},
                          seconds=time.perf_counter() - t0)
    method = "greedy-eppstein" if eppstein else "greedy"
    notes = [f"exact search stopped by its budget; no synchronizing word is shorter than {lower}"]
    if skipped:
        notes.append(f"pair-graph synchronizability check skipped: {aut.n} states would need about "
                     f"{pair_mb:,.0f} MB (over half the memory budget)")
    if aut.deterministic and not eppstein:
        notes.append(f"greedy by merging one pair at a time (pair graph searched from each pair): Eppstein's "
                     f"tables would need about {eppstein_memory_mb(aut.n):,.0f} MB (over the memory budget)")
    if greedy is None:
        notes.append(f"greedy word not found within {_GREEDY_SHARE:.0%} of the time budget")
    meets_bound = greedy is not None and len(greedy) <= lower   # the greedy word meets the proven lower bound
    return SyncResult(greedy, None if greedy is None else len(greedy), meets_bound,
                      method + "+lower-bound" if meets_bound else method,
                      lower_bound=lower, states_explored=explored,
                      greedy_length=None if greedy is None else len(greedy),
                      seconds=time.perf_counter() - t0, notes=notes)


def _check_node_budget(node_budget) -> int:
    """A positive integer subset budget (not a bool), or ValueError."""
    if isinstance(node_budget, bool) or not isinstance(node_budget, (int, np.integer)) or node_budget < 1:
        raise ValueError(f"node_budget must be a positive integer, got {node_budget!r}")
    return int(node_budget)


# ----------------------------------------------------------------------------- epsilon-synchronizing
def _cell_entropy(p, partition, n_cells):
    """Entropy (bits) of ``p`` on the report cells (on the states without a partition)."""
    if partition is None:
        return distribution_entropy_bits(p)
    return partition_entropy_bits(p, partition, n_cells)


def epsilon_synchronizing_word(model, epsilon: float, max_length: int = 30, time_budget: float = 30.0,
                               max_nodes: int = 2_000_000, decimals: int = 12) -> SyncResult:
    """Shortest word whose predicted entropy from ``model.initial`` is ``<= epsilon``.

    Entropy is taken on the report partition (on the states if the model has none), in bits.
    Breadth-first search over the distributions reached by words, with duplicate distributions
    (equal after rounding to ``decimals``) merged. ``exact`` is True only when the search was
    exhaustive up to the returned length (the first level with a hit). If no hit exists and the
    set of reachable distributions is exhausted, the answer is "none" (exact).
    """
    epsilon = float(epsilon)
    if not epsilon >= 0:
        raise ValueError(f"epsilon must be >= 0, got {epsilon}")
    t0 = time.perf_counter()
    mats = [sp.csr_matrix(m).T.tocsr() for m in model.matrices]
    part = None if model.partition is None else np.asarray(model.partition, dtype=np.int64)
    ncells = None if part is None else int(model.n_cells if model.n_cells else part.max() + 1)
    p0 = np.asarray(model.initial, dtype=np.float64)
    h0 = _cell_entropy(p0, part, ncells)
    if h0 <= epsilon:
        return SyncResult([], 0, True, "distribution-bfs", seconds=time.perf_counter() - t0)
    seen = {np.round(p0, decimals).tobytes()}
    frontier = [(p0, [])]
    explored = 1
    best = (h0, [])
    for depth in range(1, max_length + 1):
        nxt = []
        for p, w in frontier:
            for a, m in enumerate(mats):
                q = m @ p
                key = np.round(q, decimals).tobytes()
                if key in seen:
                    continue
                seen.add(key)
                explored += 1
                h = _cell_entropy(q, part, ncells)
                if h < best[0]:
                    best = (h, w + [a])
                if h <= epsilon:
                    return SyncResult(w + [a], depth, True, "distribution-bfs", states_explored=explored,
                                      lower_bound=depth, seconds=time.perf_counter() - t0,
                                      notes=[f"entropy {h:.6g} bits"])
                nxt.append((q, w + [a]))
            if explored > max_nodes or time.perf_counter() - t0 > time_budget:
                return SyncResult(None, None, False, "distribution-bfs", states_explored=explored,
                                  lower_bound=depth, seconds=time.perf_counter() - t0,
                                  greedy_length=len(best[1]), best_word=best[1],
                                  notes=[f"budget reached at depth {depth}; lowest entropy seen "
                                         f"{best[0]:.6g} bits by a word of length {len(best[1])}"])
        if not nxt:
            return SyncResult(None, None, True, "distribution-bfs", states_explored=explored,
                              witness={"kind": "exhaustive",
                                       "reason": f"all {explored} reachable distributions have entropy "
                                                 f"> {epsilon}"},
                              seconds=time.perf_counter() - t0)
        frontier = nxt
    return SyncResult(None, None, False, "distribution-bfs", states_explored=explored,
                      lower_bound=max_length + 1, seconds=time.perf_counter() - t0,
                      notes=[f"no word of length <= {max_length} reaches entropy <= {epsilon}"])
