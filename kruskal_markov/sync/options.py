"""The exact reset-word search's design choices, as one frozen value (issue 42).

:func:`~kruskal_markov.sync.exact.shortest_synchronizing_word` takes an :class:`ExactSearchOptions`;
the defaults are the measured best (docs/plans.md, issue 43). The other fields exist to measure what
each technique buys and to let tests reach a phase directly (the depth-first phases on small
automata, the search without the beam's first word); they never change a proven answer, only the
work done to reach it.
"""
from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, replace

__all__ = ["ExactSearchOptions", "default_parallel", "usable_cores"]

_LAST_SIDES = (None, "forward", "backward")


def usable_cores() -> int:
    """CPU cores this process may run on (its affinity set; ``os.cpu_count()`` where the platform
    has no affinity)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:      # not on Linux
        return os.cpu_count() or 1


def default_parallel(cores: int | None = None, threads: int | None = None) -> bool:
    """Whether the exact search splits its kernels over threads by default: with at least two
    ``cores`` (default :func:`usable_cores`) and two Numba ``threads`` (default
    ``numba.get_num_threads()``). Deterministic for given inputs; it replaces a rule on the load
    average (docs/plans.md, issue 43), which turned threads off under other jobs' load even when
    the cores were the search's own.

    Examples
    --------
    >>> default_parallel(cores=1, threads=2), default_parallel(cores=2, threads=2)
    (False, True)
    """
    if cores is None:
        cores = usable_cores()
    if threads is None:
        import numba

        threads = numba.get_num_threads()
    return min(int(cores), int(threads)) >= 2


@dataclass(frozen=True)
class ExactSearchOptions:
    """Switches of the exact search (immutable; the defaults are the ones in use).

    Attributes
    ----------
    use_beam : bool, default True
        Run the inverse beam search for a short first word (synchrowords' ``Beam``, Szykula and
        Zyzik, ESA 2022); off, the search has to find every word itself.
    fast_nodes : int or None, default 32,768
        Sets an exact search may generate below the greedy word before the beam runs (small
        automata are answered without it); None: the beam first. Not used with a node budget.
    forward_dominance, backward_dominance : bool, default False
        Drop a new forward set containing another forward set, or a new backward set inside another
        backward set (Kisielewicz, Kowalski and Szykula, J. Comb. Optim. 29, 2015), found by the
        implicit subset trie. Off: the check costs more than it saves here (docs/plans.md).
    forward_visited, backward_visited : bool, default True
        Dominance against every earlier level of the direction, not only the new level.
    trie_meet : bool, default True
        The meet test by the implicit subset trie; off: by the rarest-member index.
    restrict_roots : bool, default True
        Backward roots only at the states a letter merges two states into.
    inverse_dfs : bool, default True
        The depth-first phase from the backward side when the forward level is the larger.
    dfs_switch_rows : int or None, default None
        Enter the depth-first phase once a breadth-first level would hold more sets than this
        (None: only when memory or time run out, or the cost model says so).
    deepen : bool, default True
        When the breadth-first stores are full (or a level would not fit the time), the inverse
        depth-first phase tests one length at a time (iterative deepening), so that its lower
        bound rises as it goes and no level deeper than the shortest word is grown; off: one
        descent to the longest length, as the cost model's phase does.
    dfs_chunk : int, default 4,096
        Sets of the newest level per chunk of a depth-first phase.
    leaf_images : bool, default True
        The inverse depth-first phase generates its deepest level unstored and only tests it
        (:mod:`kruskal_markov.sync._leaves`); off: that level is stored and deduplicated like the
        others.
    fork_rows : int or None, default 1,048,576
        With :attr:`parallel`, the deepening phase (``deepen``) deals its chunks to two processes
        (this one and a forked child, one thread each; :mod:`kruskal_markov.sync._forked`) when the
        newest backward level holds at least this many sets, and no node budget is set; None:
        never. Which process finds the word first may change the sets counted, never the length.
    leaf_batch : int or None, default 524,288
        With ``leaf_images``, when the newest forward level holds at least ``leaf_batch_rows``
        sets, the deepest level's preimages that may contain a forward set are
        gathered from successive slices into batches of about this many rows, each walking the
        trie with its rows moved in place (:mod:`kruskal_markov.sync._rowtrie`); None: each
        slice walks the trie by indices (:func:`~kruskal_markov.sync._trie.superset_mask`).
    leaf_batch_rows : int or None, default 4,194,304
        The forward level's size from which ``leaf_batch`` and ``count_blocks`` act (on smaller
        tries, random 8 x 100, they cost about 8% more than they save: docs/plans.md); None: never.
    count_blocks : int or None, default 6
        With ``leaf_batch``, a deepest-level preimage walks the trie only if, in each of this many
        blocks of states, it holds at least as many states as some forward set does
        (:mod:`kruskal_markov.sync._countfilter`); None: only the size filter.
    relabel_rows : int or None, default 4,194,304
        The inverse depth-first phase relabels the states by their frequency in the newest
        forward level (the trie branches first on the states most forward sets hold;
        synchrowords' ``Dfs::prepare``, :mod:`kruskal_markov.sync._relabel`) when that level holds
        at least this many sets; None: never.
    cost_model : bool, default True
        synchrowords' cost model decides the switch to the inverse depth-first phase.
    step_by_cost : bool, default False
        The breadth-first step by the cost model's cheaper step, not the smaller newest level.
    last_unhashed : bool, default True
        The last length to test is met without storing its level.
    last_side : {None, "forward", "backward"}, default None
        The direction of that last level (None: the step rule's).
    parallel : bool or None, default None
        Split large levels' images and the meet test's trie walks over Numba's threads (each
        kernel splits only calls large enough: 16,384 sets or more). None: decided by
        :func:`default_parallel`, when the process may run on two cores or more and Numba has two
        threads or more (one core: the threads would only take turns, and a split walk costs about
        1.45 times the CPU of one batch; docs/plans.md). The choice is reported on the result
        (``SyncResult.threads``).
    observe : callable or None, default None
        Called as ``observe(event, value)`` when the search reaches a stage: ``"fast-path"`` (sets
        generated), ``"beam"`` (the word's length, or -1), ``"inverse-dfs"`` (1 if it found a word,
        else 0), ``"dfs-batch"`` (sets expanded together in a depth-first phase),
        ``"forward-level"`` / ``"backward-level"`` (sets of a new breadth-first level), ``"meet"``
        (the length whose breadth-first meet test is done), ``"last-level"`` (sets of the last
        level, generated unhashed; -1 at the deadline), ``"depth-first"`` (the length the
        depth-first phase starts after), ``"deepened"`` (a length the deepening phase has ruled
        out), ``"cost-model"`` (the only event whose value is not an int: the
        :class:`~kruskal_markov.sync.cost_model.StepCosts` of a step priced by the cost model,
        its inputs, predicted costs and choice). For measurements and tests; it does not change
        the search.

    Examples
    --------
    >>> ExactSearchOptions().use_beam
    True
    >>> ExactSearchOptions(use_beam=False, dfs_chunk=3).dfs_chunk
    3
    """

    use_beam: bool = True
    fast_nodes: int | None = 1 << 15
    forward_dominance: bool = False
    backward_dominance: bool = False
    forward_visited: bool = True
    backward_visited: bool = True
    trie_meet: bool = True
    restrict_roots: bool = True
    inverse_dfs: bool = True
    dfs_switch_rows: int | None = None
    deepen: bool = True
    dfs_chunk: int = 4096
    leaf_images: bool = True
    leaf_batch: int | None = 1 << 19
    leaf_batch_rows: int | None = 1 << 22
    count_blocks: int | None = 6
    fork_rows: int | None = 1 << 20
    relabel_rows: int | None = 1 << 22
    cost_model: bool = True
    step_by_cost: bool = False
    last_unhashed: bool = True
    last_side: str | None = None
    parallel: bool | None = None
    observe: Callable[[str, int], None] | None = None

    def __post_init__(self):
        if self.last_side not in _LAST_SIDES:
            raise ValueError(f"last_side must be one of {_LAST_SIDES}, got {self.last_side!r}")
        if int(self.dfs_chunk) != self.dfs_chunk or self.dfs_chunk < 1:
            raise ValueError(f"dfs_chunk must be a positive integer, got {self.dfs_chunk!r}")
        for name in ("fast_nodes", "dfs_switch_rows", "relabel_rows", "fork_rows", "leaf_batch", "count_blocks",
                     "leaf_batch_rows"):
            v = getattr(self, name)
            if v is not None and (int(v) != v or v < 1):
                raise ValueError(f"{name} must be a positive integer or None, got {v!r}")

    @property
    def tasks(self) -> int:
        """Slices per parallel kernel call: 8 with :attr:`parallel`, else 1 (one thread)."""
        return 8 if self.parallel else 1

    @property
    def threads(self) -> int:
        """Threads the kernels are split over: Numba's thread count with :attr:`parallel`, else 1."""
        if not self.parallel:
            return 1
        import numba

        return int(numba.get_num_threads())

    def resolved(self, cores: int | None = None) -> ExactSearchOptions:
        """These options with ``parallel`` decided (None: :func:`default_parallel` for ``cores``,
        default the cores this process may run on)."""
        if self.parallel is not None:
            return self
        return replace(self, parallel=default_parallel(cores))

    def emit(self, event: str, value: int) -> None:
        """Pass ``(event, value)`` to :attr:`observe`, if set."""
        if self.observe is not None:
            self.observe(event, int(value))
