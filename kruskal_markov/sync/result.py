"""The outcome of a synchronizing-word search."""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["SyncResult"]


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
