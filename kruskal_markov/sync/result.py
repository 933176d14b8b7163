"""The outcome of a synchronizing-word search."""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["SyncResult"]


@dataclass(frozen=True)
class SyncResult:
    """Outcome of a synchronizing-word search (immutable).

    .. deprecated::
        The letter-index view of one search. New code asks
        :func:`~kruskal_markov.sync.shortest.shortest_word`, which returns a
        :class:`~kruskal_markov.sync.plan.PlanResult` (action names, ``to_dict``) for every search;
        :meth:`PlanResult.from_sync <kruskal_markov.sync.plan.PlanResult.from_sync>` converts.

    Attributes
    ----------
    word : list of int or None
        The word, as letter indices; None when no word exists (``exact`` True, with a ``witness``)
        or when none was found within the budgets (``exact`` False).
    length : int or None
        ``len(word)``.
    exact : bool
        True only when the search proved that no shorter word exists (or that none exists).
    method : str
        The search that answered (``bidirectional-bfs``, ``greedy``, ``pair-graph``, ...).
    witness : dict or None
        Why no word exists, when none does (e.g. a pair of states that no word merges).
    lower_bound : int or None
        Proven: no synchronizing word is shorter than this.
    greedy_length : int or None
        Length of the greedy word found on the way, if any.
    states_explored : int
        Subsets (or distributions) the search generated.
    seconds : float
        Wall time of the search.
    notes : tuple of str
        What else the search has to say (budgets hit, entropies reached).
    best_word : list of int or None
        The lowest-entropy word an epsilon search had seen when its budget ran out (else None).
    threads : int
        Threads the exact search split its large kernels over (1: one thread; the rule is
        :func:`~kruskal_markov.sync.options.default_parallel`). It never changes the answer.
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
    threads: int = 1

    def __post_init__(self):
        object.__setattr__(self, "notes", tuple(self.notes))

    def as_dict(self, actions=None) -> dict:
        """JSON-ready dict (the keys of ``kruskal sync``); ``actions`` names the letters of ``word``."""
        word = self.word
        if word is not None and actions is not None:
            word = [actions[a] for a in word]
        return {"word": word, "length": self.length, "exact": self.exact, "method": self.method,
                "witness": self.witness, "lower_bound": self.lower_bound,
                "greedy_length": self.greedy_length, "states_explored": self.states_explored,
                "notes": list(self.notes), "threads": self.threads}
