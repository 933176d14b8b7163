"""The support automaton of a model: states, letters and set-valued rows as a packed CSR, with
bitset images (the object every synchronizing search works on)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from kruskal_markov import _sync_kernels as _k
from kruskal_markov._subsets import as_start

if TYPE_CHECKING:
    from kruskal_markov.model import TransitionModel

__all__ = ["SyncAutomaton", "as_automaton", "is_synchronizing_word", "start_set", "support_automaton"]


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

    def step_table(self, forward: bool) -> np.ndarray:
        """The kernels' ``sup`` argument for image (``forward``) or preimage steps: for a deterministic
        automaton whose tables fit 8 MB, byte tables ``T[a, 256 j + v]`` = the image (preimage) of
        the states ``8 j + b`` with bit ``b`` set in ``v`` -- a step ORs one table row per non-zero
        byte of the set instead of a row per member (synchrowords' bit-parallel transition
        tables); otherwise :attr:`sup` (a set-valued automaton's supports, or a deterministic
        automaton's dummy)."""
        key = "step_table_f" if forward else "step_table_b"
        if key not in self._cache:
            nbytes = (self.n + 7) // 8
            W = self.n_words
            if not self.deterministic or self.k * nbytes * 256 * W * 8 > 8 * 2 ** 20:
                self._cache[key] = self.sup
            else:
                per = np.zeros((self.k, nbytes * 8, W), dtype=np.uint64)    # one state's image / preimage
                one = np.uint64(1)
                for a in range(self.k):
                    d = self.delta[a]
                    src, dst = (np.arange(self.n), d) if forward else (d, np.arange(self.n))
                    np.bitwise_or.at(per[a], (src, dst >> 6), one << (dst & 63).astype(np.uint64))
                tab = np.zeros((self.k, nbytes, 256, W), dtype=np.uint64)
                per = per.reshape(self.k, nbytes, 8, W)
                for v in range(1, 256):
                    low = (v & -v).bit_length() - 1
                    tab[:, :, v] = tab[:, :, v & (v - 1)] | per[:, :, low]
                self._cache[key] = tab.reshape(self.k, nbytes * 256, W)
        return self._cache[key]

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

    Parameters
    ----------
    model : TransitionModel
        The model; its actions become the letters.
    threshold : float, default 0.0
        Entries below this are dropped (0: keep every non-zero entry); in [0, 1].

    Returns
    -------
    SyncAutomaton
        Set-valued unless every kept row is a single entry; ``mass_dropped`` and
        ``mass_dropped_mean`` say how much probability the threshold removed.

    Examples
    --------
    >>> from kruskal_markov.generators import cerny_model
    >>> aut = support_automaton(cerny_model(3))
    >>> aut.n, aut.k, aut.deterministic
    (3, 2, True)
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

    Parameters
    ----------
    model : TransitionModel
        The model.
    whole : bool or None, default None
        True: every state; False: the support of ``model.initial``; None: every state for a
        deterministic model, the initial support otherwise.

    Returns
    -------
    ndarray of int
        The start states, increasing.
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
    ``start`` is None, for its start set (:func:`start_set`).

    Parameters
    ----------
    aut : SyncAutomaton or TransitionModel
        What the caller was given.
    start : array_like of int, optional
        Start states; None: all states of an automaton, the start set of a model.

    Returns
    -------
    tuple of (SyncAutomaton, array_like of int or None)
        The automaton and the start states (None still means all states).

    Raises
    ------
    TypeError
        For anything else.
    """
    if isinstance(aut, SyncAutomaton):
        return aut, start
    if hasattr(aut, "matrices") and hasattr(aut, "memo"):
        model = aut
        return (model.memo(("support_automaton", 0.0), lambda: support_automaton(model)),
                start_set(model) if start is None else start)
    raise TypeError(f"expected a SyncAutomaton or a TransitionModel, got {type(aut).__name__}")


def is_synchronizing_word(aut: SyncAutomaton | TransitionModel, word, start=None) -> bool:
    """True if ``word`` maps the start set (default: all states) onto one state.

    Parameters
    ----------
    aut : SyncAutomaton or TransitionModel
        The automaton, or a model standing for its support automaton (:func:`as_automaton`).
    word : sequence of int
        Letter indices.
    start : array_like of int, optional
        Start states (default: all states of an automaton, the start set of a model).

    Returns
    -------
    bool
        Whether the image of the start set under ``word`` is a single state.

    Examples
    --------
    >>> a = SyncAutomaton.from_table([[1, 2, 0], [0, 1, 0]])   # Cerny C_3
    >>> is_synchronizing_word(a, [1, 0, 0, 1]), is_synchronizing_word(a, [1])
    (True, False)
    """
    aut, start = as_automaton(aut, start)
    return len(aut.image(as_start(aut, start), word)) == 1
