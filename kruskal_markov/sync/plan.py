"""Shortest sensorless plans: the shortest word that orients a part for a target (``state``,
``cell``, ``probability:E``; :mod:`kruskal_markov.sync.targets`), under one model or several at once.

Method
------
1. A *beam search* (width ``beam_width``) over the images of the start support (or over
   distributions) gives a first plan quickly: an upper bound.
2. *Admissible lower bounds* (never above the true length) prune: for set targets, per state the
   cells into which some word of length ``<= r`` drives all its successors (the backward sets grown
   from the cells: Kisielewicz, Kowalski and Szykula 2015, on cells instead of singletons) -- a set
   can reach a cell within ``r`` only if all its states can; for the ``state`` target on small
   automata also the pair-merging distances (every pair must merge; Eppstein 1990); for
   ``probability:E`` the fully observable relaxation (each start state with its own best word:
   an upper bound on the probability any one word reaches, Doyen, Massart and Shirmohammadi 2019).
3. *Iterative deepening depth-first search* (IDA*, Korf 1985) from the root bound upward: pass
   ``D`` explores every word of length ``<= D`` that the bounds do not exclude, so a pass that finds
   nothing proves ``lower_bound = D + 1``. Memory stays bounded: the transposition table (exact
   copies of the images seen, with the depth at which they were expanded, so no false match) stops
   recording when full, and the search goes on depth-first, still exact -- the switch synchrowords
   makes from breadth-first to depth-first (Szykula and Zyzik 2022).

Budgets are counted in images computed (``node_budget``), so that a loaded machine gives the same
answer; ``time_budget`` (seconds) is for users. A budget stop returns the best word found (the beam
word) with ``exact=False`` and the proven ``lower_bound``.

Several models (``robust`` plans): the states of all models form one disjoint union; a word is a
plan when it meets the target under every model (each model's image in one of *its* cells).

References
----------
V. Vorel, "Subset synchronization and careful synchronization of binary finite automata",
Int. J. Found. Comput. Sci. 27 (2016) 557-577.
L. Doyen, T. Massart and M. Shirmohammadi, "The complexity of synchronizing Markov decision
processes", J. Comput. Syst. Sci. 100 (2019) 96-129.
A. Kisielewicz, J. Kowalski and M. Szykula, "Computing the shortest reset words of synchronizing
automata", J. Comb. Optim. 29 (2015) 88-124.
M. Szykula and A. Zyzik, "An improved algorithm for finding the shortest synchronizing words",
ESA 2022, LIPIcs 244, 85:1-85:17.
D. Eppstein, "Reset sequences for monotonic automata", SIAM J. Comput. 19 (1990) 500-510.
R. E. Korf, "Depth-first iterative-deepening: an optimal admissible tree search", Artif. Intell.
27 (1985) 97-109.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from kruskal_markov import _plan_kernels as _pk
from kruskal_markov import _sync_kernels as _sk
from kruskal_markov.sync.automaton import start_set, support_automaton
from kruskal_markov.sync.targets import Target, model_cells, parse_target

__all__ = ["PlanResult", "shortest_plan", "random_word_success", "state_plan"]

#: default budget of images computed by the exact search (about a minute on the key's model)
DEFAULT_NODE_BUDGET = 20_000_000
#: images per kernel call (time and node budgets are checked between calls)
_QUOTA = 200_000
#: a remaining length beyond every bound table: feasibility "at any length"
_ANY_LENGTH = 2 ** 40


@dataclass(frozen=True)
class PlanResult:
    """A plan: the shortest word found for a target, and what is proven about it (immutable).

    Attributes
    ----------
    word : tuple of str or None
        Action names; None when no plan exists (``exact`` True, see ``witness``) or none was found.
    length : int or None
    exact : bool
        True only when the search proved that no shorter word meets the target.
    lower_bound : int or None
        Proven: no word shorter than this meets the target (None when no plan exists).
    target : str
        ``state``, ``cell`` or ``probability:E``.
    method : str
    final_cell : int, list of int or None
        Report cell the plan ends in (one per model when several).
    success_probability : float, list of float or None
        The model's probability of ending in ``final_cell`` (one per model when several).
    nodes : int
        Images computed by the search.
    witness : dict or None
        Why no plan exists, when none does.
    greedy_length : int or None
        The greedy word's length when the subset search found one (:meth:`from_sync`).
    threads : int
        Threads the exact subset search split its kernels over (:meth:`from_sync`; 1 otherwise).

    See Also
    --------
    kruskal_markov.sync.shortest.shortest_word : the entry point that returns it for every search.
    """

    word: tuple | None
    length: int | None
    exact: bool
    lower_bound: int | None
    target: str
    method: str
    final_cell: object = None
    success_probability: object = None
    upper_bound: int | None = None
    nodes: int = 0
    seconds: float = 0.0
    witness: dict | None = None
    notes: tuple = field(default=())
    greedy_length: int | None = None
    threads: int = 1

    def __post_init__(self):
        object.__setattr__(self, "notes", tuple(self.notes))
        if self.word is not None:
            object.__setattr__(self, "word", tuple(self.word))

    def to_dict(self) -> dict:
        """JSON-ready dict with the keys of ``kruskal plan`` (docs/commands.md)."""
        return {"word": None if self.word is None else list(self.word), "length": self.length,
                "exact": self.exact, "lower_bound": self.lower_bound, "target": self.target,
                "method": self.method, "final_cell": self.final_cell,
                "success_probability": self.success_probability, "upper_bound": self.upper_bound,
                "nodes": self.nodes, "witness": self.witness, "notes": list(self.notes), "threads": self.threads}

    @classmethod
    def from_sync(cls, res, actions=None, target: str = "state") -> "PlanResult":
        """The plan of a :class:`~kruskal_markov.sync.result.SyncResult` (letter indices named by
        ``actions``; ``states_explored`` becomes ``nodes``)."""
        word = res.word
        if word is not None and actions is not None:
            word = [actions[a] for a in word]
        return cls(word, res.length, res.exact, res.lower_bound, str(target), res.method, nodes=res.states_explored,
                   seconds=res.seconds, witness=res.witness, notes=res.notes, greedy_length=res.greedy_length,
                   threads=res.threads)

    def sync_dict(self) -> dict:
        """The keys of ``kruskal sync`` (:meth:`SyncResult.as_dict <kruskal_markov.sync.result.SyncResult.as_dict>`)."""
        return {"word": None if self.word is None else list(self.word), "length": self.length, "exact": self.exact,
                "method": self.method, "witness": self.witness, "lower_bound": self.lower_bound,
                "greedy_length": self.greedy_length, "states_explored": self.nodes, "notes": list(self.notes),
                "threads": self.threads}


# ----------------------------------------------------------------------------- the joint problem
class _Problem:
    """The disjoint union of the models' automata, cells and start nodes, as kernel arrays."""

    def __init__(self, models, target: Target, cells, threshold):
        self.models = models
        self.target = target
        self.kind = 1 if target.kind == "probability" else 0
        self.actions = tuple(models[0].actions)
        for m in models[1:]:
            if tuple(m.actions) != self.actions:
                raise ValueError(f"models disagree on their actions: {list(self.actions)} and {list(m.actions)}")
        self.k = len(self.actions)
        self.M = len(models)
        sizes = [m.n_states for m in models]
        self.offsets = np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)
        self.N = int(self.offsets[-1])
        cell_list, ncell_list = [], []
        for i, m in enumerate(models):
            c, nc = model_cells(m, target, None if cells is None else cells[i])
            cell_list.append(c)
            ncell_list.append(nc)
        self.local_cells = cell_list
        self.cell = np.concatenate(cell_list).astype(np.int64)
        self.n_cells = int(max(ncell_list))
        # the cells of the reachability bound: for ``state`` the partition when every model has one
        # (one state lies in one cell, so the bound stays admissible and its tables stay small)
        if target.kind == "state" and all(m.partition is not None for m in models):
            self.bound_cell = np.concatenate([np.asarray(m.partition, dtype=np.int64) for m in models])
            self.n_bound_cells = int(max(m.n_cells for m in models))
        else:
            self.bound_cell, self.n_bound_cells = self.cell, self.n_cells
        self.model_of = np.repeat(np.arange(self.M, dtype=np.int64), sizes)
        # letters: the support automaton (set targets) or the matrices (probability)
        indptr = np.zeros((self.k, self.N + 1), dtype=np.int64)
        idx_parts, prob_parts, offset = [], [], 0
        self.mass_dropped = 0.0
        for a in range(self.k):
            indptr[a, 0] = offset
            row_end = []
            for i, m in enumerate(models):
                if self.kind == 0:
                    aut = m.memo(("support_automaton", float(threshold)), lambda m=m: support_automaton(m, threshold))
                    self.mass_dropped = max(self.mass_dropped, aut.mass_dropped)
                    lo, hi = aut.indptr[a, 0], aut.indptr[a, -1]
                    counts = np.diff(aut.indptr[a])
                    idx_parts.append(aut.indices[lo:hi].astype(np.int32) + np.int32(self.offsets[i]))
                    prob_parts.append(np.ones(hi - lo))
                else:
                    P = sp.csr_matrix(m.matrices[a])
                    P.sort_indices()
                    counts = np.diff(P.indptr)
                    idx_parts.append(P.indices.astype(np.int32) + np.int32(self.offsets[i]))
                    prob_parts.append(P.data.astype(np.float64))
                row_end.append(counts)
            counts = np.concatenate(row_end)
            indptr[a, 1:] = offset + np.cumsum(counts)
            offset = int(indptr[a, -1])
        self.indptr = indptr
        self.indices = np.concatenate(idx_parts) if idx_parts else np.zeros(0, np.int32)
        self.probs = np.concatenate(prob_parts) if prob_parts else np.zeros(0)
        # start node
        starts, vals = [], []
        for i, m in enumerate(models):
            s = start_set(m)
            starts.append(s + self.offsets[i])
            vals.append(np.asarray(m.initial, dtype=np.float64)[s] if self.kind == 1 else np.ones(s.size))
        self.start_idx = np.concatenate(starts).astype(np.int32)
        self.start_val = np.concatenate(vals).astype(np.float64)
        self.thr = target.threshold
        # work arrays
        self.acc = np.zeros(self.N, dtype=np.float64)
        self.mark = np.zeros(self.N, dtype=np.int64)
        self.cellmass = np.zeros((self.M, max(1, self.n_cells)), dtype=np.float64)
        self.out_cells = np.zeros(self.M, dtype=np.int64)
        self.stamp = 1                 # marks in ``mark``: one counter for every kernel call
        self.masks = np.zeros((0, 1, 1), dtype=np.uint64)
        self.msat = -1
        self.V = np.zeros((0, 1, 1), dtype=np.float32)
        self.pd = np.zeros(0, dtype=np.int64)
        self.n_pd = 0
        self.work = np.zeros(1, dtype=np.uint64)

    def image(self, idx, val, a):
        self.stamp += 1
        out_i = np.empty(self.N, dtype=np.int32)
        out_v = np.empty(self.N, dtype=np.float64)
        m = _pk.image(idx, val, idx.size, a, self.kind, self.indptr, self.indices, self.probs, self.acc,
                      self.mark, self.stamp, out_i, out_v)
        return out_i[:m].copy(), out_v[:m].copy()

    def goal(self, idx, val):
        return bool(_pk.goal(idx, val, idx.size, self.kind, self.cell, self.model_of, self.M,
                             max(1, self.n_cells), self.thr, self.cellmass, self.out_cells))

    def feasible(self, idx, val, rem):
        return bool(_pk.feasible(idx, val, idx.size, self.kind, rem, self.model_of, self.M, self.masks,
                                 self.msat, self.V, self.pd, self.n_pd, self.thr, self.work))

    def score(self, idx, val):
        """Beam order: lower is closer to the target."""
        if self.kind == 0:
            pairs = np.unique(self.model_of[idx] * (self.n_cells + 1) + self.cell[idx]).size
            return (pairs - self.M, idx.size)
        self.goal(idx, val)
        mass = self.cellmass.max(axis=1)
        return (-float(mass.min()), idx.size)

    def prepare_bounds(self, R, memory_bytes):
        """Compute the admissible bound tables for lengths up to ``R`` within ``memory_bytes``."""
        notes = []
        if self.kind == 0:
            Wc = (self.n_bound_cells + 63) // 64
            R_fit = int(memory_bytes // max(1, self.N * Wc * 8)) - 2
            R_use = min(R, R_fit)
            if R_use >= 1:
                self.masks, self.msat = _pk.cell_masks(self.indptr, self.indices, self.bound_cell, self.N, Wc,
                                                       R_use)
                self.work = np.zeros(Wc, dtype=np.uint64)
            else:
                notes.append("cell-reachability bound skipped (memory)")
            if self.target.kind == "state" and self.N <= 3000:
                dist, _ = _sk.pair_merge_distance(self.indptr, self.indices, self.N)
                self.pd, self.n_pd = dist, self.N
        else:
            C = max(1, self.n_cells)
            R_fit = int(memory_bytes // max(1, self.N * C * 4)) - 1
            R_use = min(R, R_fit)
            if R_use >= 1:
                self.V = _pk.value_tables(self.indptr, self.indices, self.probs, self.cell, self.N, C, R_use)
            else:
                notes.append("probability bound skipped (memory)")
            if R_use < R:
                notes.append(f"probability bound computed up to length {max(R_use, 0)} only (memory)")
        return notes


def _beam(prob: _Problem, width, max_length, node_budget):
    """Beam search: the best ``width`` distinct nodes per level. Returns ``(word | None, nodes)``."""
    level = [(prob.start_idx, prob.start_val, [])]
    nodes = 0
    for depth in range(1, max_length + 1):
        cand = {}
        for idx, val, w in level:
            for a in range(prob.k):
                i2, v2 = prob.image(idx, val, a)
                nodes += 1
                if prob.goal(i2, v2):
                    return w + [a], nodes
                key = i2.tobytes() + (np.round(v2, 12).tobytes() if prob.kind == 1 else b"")
                if key not in cand:
                    cand[key] = (prob.score(i2, v2), w + [a], i2, v2)
        if not cand or nodes > node_budget:
            return None, nodes
        best = sorted(cand.values(), key=lambda t: (t[0], t[1]))[:width]
        level = [(i2, v2, w) for _, w, i2, v2 in best]
    return None, nodes


def _success(prob: _Problem, word):
    """Per model: the final cell and the model's probability of ending in it."""
    cells, probs = [], []
    for i, m in enumerate(prob.models):
        p = np.asarray(m.initial, dtype=np.float64)
        for a in word:
            p = sp.csr_matrix(m.matrices[a]).T @ p
        mass = np.bincount(prob.local_cells[i], weights=p, minlength=max(1, int(prob.local_cells[i].max()) + 1))
        if prob.target.kind == "state":
            q = int(np.argmax(p))
            c = int(m.partition[q]) if m.partition is not None else q
            cells.append(c)
            probs.append(float(p[q]))
        else:
            c = int(np.argmax(mass))
            cells.append(c)
            probs.append(float(mass[c]))
    return cells, probs


def shortest_plan(models, target="cell", cells=None, node_budget: int = DEFAULT_NODE_BUDGET,
                  time_budget: float | None = None, memory_budget_mb: float = 1024.0,
                  beam_width: int = 64, max_length: int = 64, threshold: float = 0.0,
                  clock=time.perf_counter) -> PlanResult:
    """The shortest word that meets ``target`` under every model given.

    Parameters
    ----------
    models : TransitionModel or list of TransitionModel
        One model, or several sharing their action names (a robust plan).
    target : str or Target
        ``state``, ``cell`` or ``probability:E`` (:func:`~kruskal_markov.sync.targets.parse_target`).
    cells : list of array_like, optional
        Per model, the cell of every state (e.g. a coarser report grid); default the partition.
    node_budget : int
        Images the search may compute (beam and exact search together); the same budget gives the
        same answer on any machine.
    time_budget : float, optional
        Seconds (for users; tests use ``node_budget``).
    memory_budget_mb : float
        Memory for the bound tables and the transposition table.
    beam_width : int
        Width of the beam search that gives the first plan.
    max_length : int
        Longest word considered.
    threshold : float
        Set targets: the support automaton keeps entries ``>= threshold``.
    clock : callable
        Seconds, for ``time_budget`` and ``seconds`` (tests pass a fake one).

    Returns
    -------
    PlanResult

    See Also
    --------
    kruskal_markov.sync.shortest.shortest_word : the one entry point (chooses this search or the subset search).
    kruskal_markov.sync.plan.random_word_success : how often a random word of each length meets the target.

    References
    ----------
    See the module docstring: Vorel 2016; Doyen, Massart and Shirmohammadi 2019; Kisielewicz,
    Kowalski and Szykula 2015; Szykula and Zyzik 2022; Eppstein 1990; Korf 1985.

    Examples
    --------
    >>> from kruskal_markov.automaton_json import model_from_automaton
    >>> cerny4 = model_from_automaton({"states": 4, "actions": {"a": [1, 2, 3, 0], "b": [0, 1, 2, 0]}})
    >>> r = shortest_plan(cerny4, "state")
    >>> r.length, r.exact, r.lower_bound, "".join(r.word)
    (9, True, 9, 'baaabaaab')
    """
    t0 = clock()
    if not isinstance(models, (list, tuple)):
        models = [models]
    target = parse_target(target)
    _check_plan_arguments(models, cells, node_budget, beam_width, max_length, memory_budget_mb, time_budget)
    deadline = None if time_budget is None else t0 + float(time_budget)
    prob = _Problem(list(models), target, cells, threshold)
    name = str(target)
    notes = []
    if prob.mass_dropped > 0:
        notes.append(f"support automaton threshold {threshold}: up to {prob.mass_dropped:.3g} of a row's "
                     f"probability ignored")

    def result(word, exact, lower, method, nodes, witness=None):
        return _plan_result(prob, name, notes, clock() - t0, word, exact, lower, method, nodes, witness)

    if prob.goal(prob.start_idx, prob.start_val):
        return result([], True, 0, "trivial", 0)
    # 1. beam search: an upper bound
    ub_word, nodes = _beam(prob, beam_width, max_length, node_budget)
    R = max_length if ub_word is None else len(ub_word)
    notes += prob.prepare_bounds(R, memory_budget_mb * 2 ** 20 * 0.5)
    # 2. root lower bound
    lower = _root_lower_bound(prob, R)
    # no plan at any length: the saturated cell masks (or a pair that never merges) exclude every
    # length, not only those up to R -- a pair merging only in more than R letters excludes just those
    if lower > R and ub_word is None and _never_meets(prob):
        return result(None, True, None, "cell-reachability", nodes, witness={
            "kind": "bound", "reason": "no cell is reachable by every start state under some word "
                                       "(per model), at any length"})
    if ub_word is not None and lower >= len(ub_word):
        return result(ub_word, True, len(ub_word), "beam+bound", nodes)
    # 3. IDA* passes
    N = prob.N
    Dmax = (len(ub_word) - 1) if ub_word is not None else max_length
    st_idx = np.zeros((Dmax + 2, N), dtype=np.int32)
    st_val = np.zeros((Dmax + 2, N), dtype=np.float64)
    st_len = np.zeros(Dmax + 2, dtype=np.int64)
    letter_at = np.zeros(Dmax + 2, dtype=np.int64)
    word = np.zeros(Dmax + 2, dtype=np.int64)
    m0 = prob.start_idx.size
    entries, pool, table, e_off, e_len, e_depth, pool_i, pool_v = _transposition_table(prob, memory_budget_mb)
    tstate = np.zeros(3, dtype=np.int64)
    full_passes = 0
    D = lower
    while D <= Dmax:
        st_idx[0, :m0] = prob.start_idx
        st_val[0, :m0] = prob.start_val
        st_len[0] = m0
        letter_at[0] = 0
        table[:] = -1
        tstate[:] = 0
        st = np.array([0, nodes, 0, prob.stamp], dtype=np.int64)
        while True:
            quota = min(_QUOTA, node_budget - int(st[1]))
            if quota <= 0 or (deadline is not None and clock() > deadline):
                notes.append(f"budget reached in the depth-{D} pass: no plan is shorter than {D}")
                method = "beam" if ub_word is not None else "none"
                return result(ub_word, False, D, method, int(st[1]))
            status = _pk.dfs_pass(D, prob.kind, prob.indptr, prob.indices, prob.probs, prob.cell,
                                  prob.model_of, prob.M, max(1, prob.n_cells), prob.thr, prob.masks,
                                  prob.msat, prob.V, prob.pd, prob.n_pd, st_idx, st_val, st_len, letter_at,
                                  word, st, quota, prob.acc, prob.mark, prob.cellmass, prob.out_cells,
                                  prob.work, table, e_off, e_len, e_depth, pool_i, pool_v, tstate)
            prob.stamp = int(st[3]) + 1
            if status != -1:
                break
        nodes = int(st[1])
        full_passes += 1
        notes += _table_notes(tstate, D)
        if status == 1:
            w = [int(x) for x in word[:st[0]]]
            return result(w, True, len(w), "ida*", nodes)
        if st[2] == 0 and ub_word is None:
            witness = {"kind": "exhaustive",
                       "reason": f"every reachable image was expanded ({int(tstate[0])} distinct) and none "
                                 f"meets the target {name}" + (" under every model" if prob.M > 1 else "")}
            if prob.M > 1:
                _add_per_model_witness(witness, models, target, cells, node_budget, memory_budget_mb, beam_width,
                                       max_length, threshold)
            return result(None, True, None, "ida*", nodes, witness=witness)
        D += 1
    if ub_word is not None:
        return result(ub_word, True, len(ub_word), "beam+ida*", nodes)
    notes.append(f"no plan of length <= {max_length}")
    return result(None, False, max_length + 1, "ida*", nodes)


def _plan_result(prob: _Problem, name, notes, seconds, word, exact, lower, method, nodes, witness=None) -> PlanResult:
    """The :class:`PlanResult` of ``word`` (letter indices; None: no plan) with its success."""
    fc = sp_ = None
    if word is not None:
        cs, ps = _success(prob, word)
        fc, sp_ = (cs[0], ps[0]) if prob.M == 1 else (cs, ps)
    return PlanResult(None if word is None else [prob.actions[a] for a in word],
                      None if word is None else len(word), exact, lower, name, method, fc, sp_,
                      None if word is None else len(word), nodes, seconds, witness, notes)


def _never_meets(prob: _Problem) -> bool:
    """A set target no word of any length meets: the saturated cell masks exclude every length."""
    return (prob.kind == 0 and 0 <= prob.msat <= prob.masks.shape[0] - 1
            and not prob.feasible(prob.start_idx, prob.start_val, _ANY_LENGTH))


def _table_notes(tstate, depth: int) -> list[str]:
    """A note when the transposition table had no room for a node during the depth-``depth`` pass
    (a table that holds exactly every image it met is not full)."""
    if tstate[2]:
        return [f"transposition table full in the depth-{depth} pass (depth-first without it)"]
    return []


def _root_lower_bound(prob: _Problem, R: int) -> int:
    """The smallest length up to ``R + 1`` that the bounds do not exclude from the start."""
    lower = 1
    while lower <= R and not prob.feasible(prob.start_idx, prob.start_val, lower):
        lower += 1
    return lower


def _transposition_table(prob: _Problem, memory_budget_mb: float):
    """The IDA* transposition table sized from half the memory budget: ``entries``, ``pool`` and the
    kernel's arrays (hash slots, entry offsets, lengths and depths, the pooled images)."""
    tt_bytes = memory_budget_mb * 2 ** 20 * 0.5
    per_entry = 16 * 2 + 8 + 4 + 4
    per_elem = 4 + (8 if prob.kind == 1 else 0)
    entries = max(1024, int(tt_bytes / 2 / per_entry))
    pool = max(1024, int(tt_bytes / 2 / per_elem))
    return (entries, pool, np.full(_pow2(2 * entries), -1, dtype=np.int64), np.zeros(entries, dtype=np.int64),
            np.zeros(entries, dtype=np.int32), np.zeros(entries, dtype=np.int32), np.zeros(pool, dtype=np.int32),
            np.zeros(pool if prob.kind == 1 else 1, dtype=np.int64))


def _check_plan_arguments(models, cells, node_budget, beam_width, max_length, memory_budget_mb, time_budget):
    """ValueError naming the first argument of :func:`shortest_plan` that is out of range."""
    if not models:
        raise ValueError("at least one model is needed")
    if cells is not None and len(cells) != len(models):
        raise ValueError(f"{len(cells)} cell maps for {len(models)} models")
    for name, v in (("node_budget", node_budget), ("beam_width", beam_width), ("max_length", max_length)):
        if int(v) != v or v < 1:
            raise ValueError(f"{name} must be a positive integer, got {v!r}")
    if memory_budget_mb <= 0 or (time_budget is not None and not time_budget > 0):
        raise ValueError("memory and time budgets must be positive")


def _add_per_model_witness(witness, models, target, cells, node_budget, memory_budget_mb, beam_width, max_length,
                           threshold):
    """No word serves every model: say whether each model alone has a plan, and how long."""
    alone = [shortest_plan(m, target, None if cells is None else [cells[i]], node_budget,
                           None, memory_budget_mb, beam_width, max_length, threshold)
             for i, m in enumerate(models)]
    witness["per_model_lengths"] = [r.length for r in alone]
    missing = [i for i, r in enumerate(alone) if r.word is None]
    witness["reason"] += (f"; model(s) {missing} alone have no plan" if missing else
                          "; every model alone has a plan "
                          f"(lengths {[r.length for r in alone]}), but no one word serves all")


def state_plan(model, threshold: float = 0.0, time_budget: float | None = 60.0,
               node_budget: int = DEFAULT_NODE_BUDGET, clock=time.perf_counter):
    """The ``state`` target of a built model as a :class:`~kruskal_markov.sync.result.SyncResult`
    (the fields ``kruskal sync`` and the ranking show), searched by :func:`shortest_plan`.

    Parameters
    ----------
    model : TransitionModel
        Synchronized from its start set (:func:`~kruskal_markov.sync.automaton.start_set`).
    threshold : float
        Support automaton threshold.
    time_budget : float or None
    node_budget : int
    clock : callable
        Seconds (:func:`shortest_plan`).

    Returns
    -------
    SyncResult
        ``word`` as letter indices; ``method`` prefixed ``plan-`` (e.g. ``plan-ida*``).

    References
    ----------
    As :func:`shortest_plan`.
    """
    from kruskal_markov.sync.result import SyncResult

    r = shortest_plan(model, "state", node_budget=node_budget, time_budget=time_budget, threshold=threshold,
                      clock=clock)
    word = None if r.word is None else [model.actions.index(a) for a in r.word]
    return SyncResult(word, r.length, r.exact, "plan-" + r.method, witness=r.witness, lower_bound=r.lower_bound,
                      states_explored=r.nodes, seconds=r.seconds, notes=r.notes)


def _pow2(x):
    return 1 << max(4, int(x - 1).bit_length())


def random_word_success(model, target="cell", max_length: int = 50, words: int = 2000, seed=0,
                        cells=None, threshold: float = 0.0) -> dict:
    """The probability that a uniformly random word of length ``L`` meets ``target``, L = 0..max_length.

    Monte Carlo over ``words`` random words (letters uniform and independent); the first ``L``
    letters of a random word are a random word of length ``L``, so one sample serves every length.

    Parameters
    ----------
    model : TransitionModel
    target : str or Target
    max_length : int
    words : int
        Random words drawn.
    seed : int or sequence
        Seed of :func:`numpy.random.default_rng`.
    cells : array_like of int, optional
        Cell of every state (default the partition).
    threshold : float
        Set targets: support automaton threshold.

    Returns
    -------
    dict
        ``lengths`` (0..max_length), ``probability`` (share of words meeting the target at each
        length), ``ci95`` (normal-approximation 95% intervals, clipped to [0, 1]), ``words``,
        ``target``.

    References
    ----------
    The paper's claim "converging plans are common, optimal plans are rare" measured; compare with
    :func:`shortest_plan`.
    """
    target = parse_target(target)
    if int(max_length) != max_length or max_length < 0 or int(words) != words or words < 1:
        raise ValueError("max_length must be >= 0 and words >= 1 (integers)")
    prob = _Problem([model], target, None if cells is None else [cells], threshold)
    rng = np.random.default_rng(seed)
    w = rng.integers(0, prob.k, size=(int(words), int(max_length)))
    out = np.zeros((int(words), int(max_length) + 1), dtype=np.int8)
    _pk.random_words_success(prob.start_idx, prob.start_val, prob.start_idx.size, prob.kind, prob.indptr,
                             prob.indices, prob.probs, prob.cell, prob.model_of, prob.M,
                             max(1, prob.n_cells), prob.thr, w, prob.acc, prob.mark, prob.cellmass,
                             prob.out_cells, out)
    p = out.mean(axis=0)
    se = np.sqrt(p * (1 - p) / words)
    return {"lengths": list(range(int(max_length) + 1)), "probability": p.tolist(),
            "ci95": np.clip(np.stack([p - 1.96 * se, p + 1.96 * se], axis=1), 0, 1).tolist(),
            "words": int(words), "target": str(target)}
