"""Instance generators: Černý automata, seeded random automata and random stochastic models.

One home for the test models that the tests, the benchmarks and users share (like QuantEcon's
``quantecon.markov.random``). Every random generator takes ``seed``: an int, a sequence of ints or
a :class:`numpy.random.Generator` (used as is, so several calls can share one stream); the same
seed gives the same instance on every machine.

Deterministic automata
    :func:`cerny_table`, :func:`cerny_automaton`, :func:`cerny_model`, :func:`random_table`,
    :func:`random_automaton`, :func:`contracting_table`
Stochastic models
    :func:`random_stochastic_matrix`, :func:`random_model`, :func:`tray_like_model`,
    :func:`set_valued_tray_model`

Examples
--------
>>> from kruskal_markov.generators import cerny_automaton, random_model
>>> from kruskal_markov.sync import shortest_synchronizing_word
>>> shortest_synchronizing_word(cerny_automaton(4)).length     # (n - 1)^2
9
>>> random_model(5, 2, seed=1).n_states
5
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = [
    "cerny_table",
    "cerny_automaton",
    "cerny_model",
    "random_table",
    "random_automaton",
    "contracting_table",
    "random_stochastic_matrix",
    "random_model",
    "tray_like_model",
    "set_valued_tray_model",
]


def _rng(seed) -> np.random.Generator:
    return np.random.default_rng(seed)


def _positive_int(name: str, value, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


# ----------------------------------------------------------------------------- deterministic automata
def cerny_table(n: int) -> np.ndarray:
    """Transition table of the Černý automaton :math:`C_n`.

    Parameters
    ----------
    n : int
        Number of states (>= 1).

    Returns
    -------
    ndarray of int64, shape (2, n)
        Row 0, letter ``a``: the cyclic shift ``q -> q + 1 mod n``; row 1, letter ``b``: the
        identity except ``n - 1 -> 0``. Its shortest synchronizing word has length ``(n - 1)^2``.

    References
    ----------
    J. Černý, "Poznámka k homogénnym experimentom s konečnými automatmi", Matematicko-fyzikálny
    časopis 14 (1964) 208-216.

    Examples
    --------
    >>> cerny_table(3).tolist()
    [[1, 2, 0], [0, 1, 0]]
    """
    n = _positive_int("n", n)
    a = [(i + 1) % n for i in range(n)]
    b = [i if i != n - 1 else 0 for i in range(n)]
    return np.array([a, b], dtype=np.int64)


def cerny_automaton(n: int):
    """The Černý automaton :math:`C_n` as a :class:`~kruskal_markov.sync.SyncAutomaton`.

    Parameters
    ----------
    n : int
        Number of states.

    Returns
    -------
    SyncAutomaton
        Letters ``a`` (cyclic shift) and ``b`` (merges ``n - 1`` into ``0``); see :func:`cerny_table`.
    """
    from kruskal_markov.sync import SyncAutomaton

    return SyncAutomaton.from_table(cerny_table(n), actions=["a", "b"])


def cerny_model(n: int):
    """The Černý automaton :math:`C_n` as a deterministic :class:`~kruskal_markov.model.TransitionModel`.

    Parameters
    ----------
    n : int
        Number of states.

    Returns
    -------
    TransitionModel
        Actions ``a`` and ``b`` (:func:`cerny_table`), uniform initial distribution, no partition.
    """
    from kruskal_markov.automaton_json import model_from_automaton

    t = cerny_table(n)
    return model_from_automaton({"states": int(n), "actions": {"a": t[0].tolist(), "b": t[1].tolist()}})


def random_table(n: int, k: int, seed=None) -> np.ndarray:
    """A uniformly random deterministic automaton on ``n`` states and ``k`` letters.

    Parameters
    ----------
    n, k : int
        States and letters.
    seed : int, sequence of int or numpy.random.Generator, optional

    Returns
    -------
    ndarray of int64, shape (k, n)
        ``table[a, q]`` is the successor of state ``q`` under letter ``a``, each drawn uniformly.
    """
    n, k = _positive_int("n", n), _positive_int("k", k)
    return _rng(seed).integers(0, n, size=(k, n))


def random_automaton(n: int, k: int, seed=None):
    """:func:`random_table` as a :class:`~kruskal_markov.sync.SyncAutomaton`.

    Parameters
    ----------
    n, k : int
        States and letters.
    seed : int, sequence of int or numpy.random.Generator, optional

    Returns
    -------
    SyncAutomaton
    """
    from kruskal_markov.sync import SyncAutomaton

    return SyncAutomaton.from_table(random_table(n, k, seed))


def contracting_table(n: int, k: int = 8, seed=None) -> np.ndarray:
    """A tray-like contracting automaton: every letter maps all states into a random eighth of them.

    Parameters
    ----------
    n, k : int
        States and letters.
    seed : int, sequence of int or numpy.random.Generator, optional

    Returns
    -------
    ndarray of int64, shape (k, n)
        Letter ``a`` draws an image of ``max(1, n // 8)`` distinct states, then sends every state
        to a uniformly chosen member of it.
    """
    n, k = _positive_int("n", n), _positive_int("k", k)
    rng = _rng(seed)
    table = np.empty((k, n), dtype=np.int64)
    m = max(1, n // 8)
    for a in range(k):
        image = rng.choice(n, size=m, replace=False)
        table[a] = image[rng.integers(0, m, size=n)]
    return table


# ----------------------------------------------------------------------------- stochastic models
def random_stochastic_matrix(n: int, density: float = 0.3, seed=None, dense: bool = False,
                             floor: float = 0.1):
    """A random row-stochastic matrix with at least one non-zero entry per row.

    Parameters
    ----------
    n : int
        Size.
    density : float
        Probability that an entry is drawn non-zero (uniform weight in [0, 1)).
    seed : int, sequence of int or numpy.random.Generator, optional
    dense : bool
        Return a dense ndarray instead of a CSR matrix.
    floor : float
        Every row also gets weight ``U[0, 1) + floor`` at one uniformly chosen column, so that no
        row is empty.

    Returns
    -------
    scipy.sparse.csr_matrix or ndarray, shape (n, n)
        Rows normalised to sum 1.
    """
    n = _positive_int("n", n)
    rng = _rng(seed)
    a = rng.random((n, n)) * (rng.random((n, n)) < density)
    a[np.arange(n), rng.integers(0, n, size=n)] += rng.random(n) + floor
    a /= a.sum(axis=1, keepdims=True)
    return a if dense else sp.csr_matrix(a)


def random_model(n: int, k: int, density: float = 0.3, cells: int | None = None, dense: bool = False,
                 initial: str = "random", seed=None, floor: float = 0.05):
    """A random :class:`~kruskal_markov.model.TransitionModel` (:func:`random_stochastic_matrix` per action).

    Parameters
    ----------
    n, k : int
        States and actions (named ``a0``, ``a1``, ...).
    density, dense, floor
        As in :func:`random_stochastic_matrix`.
    cells : int, optional
        A uniformly random partition into this many report cells.
    initial : {"random", "uniform"}
        ``"random"``: about 70% of the states get a uniform random weight (at least one state is
        weighted); ``"uniform"``: the model's default, uniform over all states.
    seed : int, sequence of int or numpy.random.Generator, optional

    Returns
    -------
    TransitionModel
    """
    from kruskal_markov.model import TransitionModel

    if initial not in ("random", "uniform"):
        raise ValueError(f"initial must be 'random' or 'uniform', got {initial!r}")
    k = _positive_int("k", k)
    rng = _rng(seed)
    mats = [random_stochastic_matrix(n, density, rng, dense, floor) for _ in range(k)]
    init = None
    if initial == "random":
        init = rng.random(n) * (rng.random(n) < 0.7)
        init[rng.integers(0, n)] += 0.1
        init /= init.sum()
    part = rng.integers(0, cells, n) if cells else None
    return TransitionModel([f"a{i}" for i in range(k)], mats, initial=init, partition=part,
                           n_cells=cells if cells else None)


def tray_like_model(n: int = 2000, k: int = 8, nnz: int = 5, cells: int = 64, seed=0):
    """A contracting random model shaped like a built tray model (the entropy benchmarks' instance).

    Parameters
    ----------
    n, k : int
        States and actions.
    nnz : int
        Successors per row.
    cells : int
        Report cells of a uniformly random partition.
    seed : int, sequence of int or numpy.random.Generator

    Returns
    -------
    TransitionModel
        Action ``a`` sends every state to ``nnz`` random states of its own target set (an eighth
        of the states) with Dirichlet(1) probabilities.
    """
    from kruskal_markov.model import TransitionModel

    n, k, nnz = _positive_int("n", n), _positive_int("k", k), _positive_int("nnz", nnz)
    rng = _rng(seed)
    mats = []
    for _ in range(k):
        targets = rng.choice(n, size=max(1, n // 8), replace=False)
        cols = targets[rng.integers(0, targets.size, size=(n, nnz))]
        probs = rng.dirichlet(np.ones(nnz), size=n)
        rows = np.repeat(np.arange(n), nnz)
        mats.append(sp.csr_matrix((probs.ravel(), (rows, cols.ravel())), shape=(n, n)))
    return TransitionModel([f"a{i}" for i in range(k)], mats,
                           partition=rng.integers(0, cells, size=n), n_cells=cells)


def set_valued_tray_model(n: int, k: int = 8, shrink: int = 64, noise: float = 0.02, seed=None):
    """A tray-like model whose support automaton is set-valued (the synchronization benchmarks').

    Parameters
    ----------
    n, k : int
        States and actions (named ``"0"``, ``"1"``, ...).
    shrink : int
        Every action pushes all states into a random ``1 / shrink`` of them (at least 2).
    noise : float
        Share of the rows that split 0.6 / 0.4 between two landing states.
    seed : int, sequence of int or numpy.random.Generator, optional

    Returns
    -------
    TransitionModel
        Pass it to :func:`kruskal_markov.sync.support_automaton` for the set-valued automaton.
    """
    from kruskal_markov.model import TransitionModel

    n, k = _positive_int("n", n, 2), _positive_int("k", k)
    rng = _rng(seed)
    m = max(2, n // shrink)
    mats = []
    for _ in range(k):
        image = rng.choice(n, size=m, replace=False)
        rows, cols, vals = [], [], []
        for q in range(n):
            if rng.random() < noise:
                c = rng.choice(image, size=2, replace=False)
                rows += [q, q]
                cols += [int(c[0]), int(c[1])]
                vals += [0.6, 0.4]
            else:
                rows.append(q)
                cols.append(int(image[rng.integers(0, m)]))
                vals.append(1.0)
        mats.append(sp.csr_matrix((vals, (rows, cols)), shape=(n, n)))
    return TransitionModel([str(a) for a in range(k)], mats)
