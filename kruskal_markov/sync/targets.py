"""Plan targets: what "the part is oriented" means, with one meaning in the Python API and the
command line.

* ``state`` -- every start state driven to one model state (a reset word of the support automaton;
  the ``kruskal sync`` question; a pose known to the model's tolerance, as in Erdmann and Mason).
* ``cell`` -- every start state driven into one report cell (the paper's "all poses in one voxel"),
  on the model's partition or on given cells (e.g. a coarser grid).
* ``probability:E`` -- from the initial distribution, at least ``1 - E`` of the probability in one
  report cell.

Deciding whether a word drives a set into a subset is PSPACE-complete in general (Vorel 2016), as
is threshold synchronization of Markov decision processes (Doyen, Massart and Shirmohammadi 2019):
the search (:mod:`kruskal_markov.sync.plan`) is exact but exponential in the worst case.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Target", "parse_target", "model_cells"]

_KINDS = ("state", "cell", "probability")


@dataclass(frozen=True)
class Target:
    """A plan target.

    Parameters
    ----------
    kind : {"state", "cell", "probability"}
    epsilon : float
        For ``probability``: the allowed miss probability ``E`` (success >= 1 - E), in [0, 1).

    Examples
    --------
    >>> parse_target("probability:0.001")
    Target(kind='probability', epsilon=0.001)
    >>> str(parse_target("cell"))
    'cell'
    """

    kind: str
    epsilon: float = 0.0

    def __post_init__(self):
        if self.kind not in _KINDS:
            raise ValueError(f"unknown plan target {self.kind!r}: expected state, cell or probability:E")
        e = float(self.epsilon)
        if not (0.0 <= e < 1.0) or math.isnan(e):
            raise ValueError(f"probability target: E must lie in [0, 1), got {self.epsilon!r}")
        if self.kind != "probability" and e != 0.0:
            raise ValueError(f"target {self.kind} takes no epsilon")
        object.__setattr__(self, "epsilon", e)

    def __str__(self) -> str:
        return f"probability:{self.epsilon:g}" if self.kind == "probability" else self.kind

    @property
    def threshold(self) -> float:
        """The probability a plan must reach in one cell (1 for ``state`` and ``cell``)."""
        return 1.0 - self.epsilon


def parse_target(text) -> Target:
    """Parse ``state``, ``cell`` or ``probability:E`` (a :class:`Target` passes through).

    Parameters
    ----------
    text : str or Target

    Returns
    -------
    Target

    Raises
    ------
    ValueError
        One line naming what is wrong.
    """
    if isinstance(text, Target):
        return text
    if not isinstance(text, str):
        raise ValueError(f"bad plan target {text!r}: expected state, cell or probability:E")
    t = text.strip()
    if t in ("state", "cell"):
        return Target(t)
    if t.startswith("probability:"):
        raw = t.split(":", 1)[1]
        try:
            e = float(raw)
        except ValueError:
            raise ValueError(f"bad plan target {text!r}: E in probability:E must be a number in [0, 1)") from None
        return Target("probability", e)
    raise ValueError(f"unknown plan target {text!r}: expected state, cell or probability:E")


def model_cells(model, target: Target, cells=None) -> tuple[np.ndarray, int]:
    """The cell of every state for ``target`` and the number of cells.

    ``state``: every state its own cell. ``cell`` and ``probability``: ``cells`` if given (e.g. a
    coarser report grid), else the model's partition, else the states themselves (an automaton
    without a partition, where the entropy is taken on the states too).

    Parameters
    ----------
    model : TransitionModel
    target : Target
    cells : array_like of int, optional
        ``cells[q]`` = cell of state ``q`` (non-negative).

    Returns
    -------
    cells : ndarray of int64
    n_cells : int
    """
    n = model.n_states
    if target.kind == "state":
        return np.arange(n, dtype=np.int64), n
    if cells is not None:
        c = np.asarray(cells)
        if c.shape != (n,) or not np.issubdtype(c.dtype, np.integer):
            raise ValueError(f"cells must be {n} integers (one per state), got shape {c.shape}")
        if n and c.min() < 0:
            raise ValueError("cells must be non-negative")
        c = c.astype(np.int64)
        return c, int(c.max()) + 1 if n else 0
    if model.partition is not None:
        return np.asarray(model.partition, dtype=np.int64), int(model.n_cells)
    return np.arange(n, dtype=np.int64), n
