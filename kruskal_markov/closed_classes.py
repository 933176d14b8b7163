"""Structure of a model's support graph: closed (recurrent) classes and what they imply for entropy.

The support graph has an edge ``i -> j`` when some action moves state ``i`` to ``j`` with
positive probability (the union over actions). A *closed class* is a strongly connected
component that no edge leaves: once probability mass is in it, no sequence of actions takes it
out. Hence, if the initial distribution puts mass on two or more closed classes, that mass stays
split forever and the entropy on the states can never reach zero, whatever the sequence
(Kemeny & Snell, *Finite Markov Chains*, 1960, ch. II, on closed and transient classes; the
union graph makes this hold for every action sequence at once). On a report partition the
entropy can still reach zero only if the cells of all those classes share a common cell.

One closed class carrying all the mass is necessary, not sufficient, for zero entropy (e.g. a
permutation has one class and never contracts): whether a word actually collapses the
distribution is the synchronization question (:mod:`kruskal_markov.sync`).
"""
from __future__ import annotations

import dataclasses

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from kruskal_markov.model import TransitionModel
from kruskal_markov.validation import distribution

__all__ = ["StructureReport", "support_graph", "closed_classes", "analyze_structure"]


def support_graph(model: TransitionModel) -> sp.csr_matrix:
    """Boolean-pattern CSR adjacency of the support graph (union over actions)."""
    n = model.n_states
    rows = np.concatenate([np.repeat(np.arange(n), np.diff(m.indptr)) for m in model.matrices])
    cols = np.concatenate([m.indices for m in model.matrices])
    g = sp.csr_matrix((np.ones(rows.size, dtype=np.int8), (rows, cols)), shape=(n, n))
    g.sum_duplicates()
    g.data[:] = 1
    return g


def closed_classes(graph: sp.spmatrix) -> list[np.ndarray]:
    """Closed strongly connected components of a directed graph, each a sorted state array.

    Classes are listed by their smallest state.

    >>> import scipy.sparse as sp
    >>> g = sp.csr_matrix(np.array([[0, 1, 0], [0, 1, 0], [0, 0, 1]]))
    >>> [c.tolist() for c in closed_classes(g)]
    [[1], [2]]
    """
    graph = sp.csr_matrix(graph)
    ncomp, labels = csgraph.connected_components(graph, directed=True, connection="strong")
    coo = graph.tocoo()
    leaving = labels[coo.row] != labels[coo.col]
    has_exit = np.zeros(ncomp, dtype=bool)
    has_exit[labels[coo.row[leaving]]] = True
    members = np.argsort(labels, kind="stable")
    bounds = np.searchsorted(labels[members], np.arange(ncomp + 1))
    out = [members[bounds[c]:bounds[c + 1]] for c in range(ncomp) if not has_exit[c]]
    out.sort(key=lambda a: int(a[0]))
    return [np.sort(a).astype(np.int64) for a in out]


def _reachable(graph: sp.csr_matrix, sources: np.ndarray) -> np.ndarray:
    """Boolean mask of the states reachable from ``sources`` (sources included).

    Breadth-first search from a virtual extra node with an edge to every source."""
    n = graph.shape[0]
    sources = np.asarray(sources, dtype=np.int64)
    extra = sp.csr_matrix((np.ones(sources.size, dtype=np.int8), (np.full(sources.size, n), sources)),
                          shape=(n + 1, n + 1))
    g = sp.bmat([[graph, None], [None, sp.csr_matrix((1, 1), dtype=np.int8)]], format="csr") + extra
    order = csgraph.breadth_first_order(g, n, directed=True, return_predecessors=False)
    seen = np.zeros(n + 1, dtype=bool)
    seen[order] = True
    return seen[:n]


@dataclasses.dataclass(frozen=True)
class StructureReport:
    """Closed classes of the support graph and their consequences for the entropy.

    Attributes
    ----------
    closed_classes : list of ndarray
        Every closed class of the support graph (sorted states), by smallest state.
    reachable_classes : list of int
        Indices (into ``closed_classes``) of the classes reachable from the initial support.
    holding_classes : list of int
        Indices of the classes that already hold initial mass (mass that can never leave).
    class_mass : list of float
        Initial mass in each class of ``holding_classes``.
    zero_entropy_excluded : bool
        True when two or more closed classes hold initial mass: the entropy on the states can
        never reach zero.
    zero_cell_entropy_excluded : bool
        The same on the report partition (the holding classes have no report cell in common);
        equals ``zero_entropy_excluded`` for a model without partition.
    message : str
        One-paragraph explanation naming the classes.
    """

    closed_classes: list
    reachable_classes: list
    holding_classes: list
    class_mass: list
    zero_entropy_excluded: bool
    zero_cell_entropy_excluded: bool
    message: str

    def to_dict(self, max_states: int = 20) -> dict:
        """JSON-ready summary (each class listed by size and its first ``max_states`` states)."""
        def show(c):
            return {"size": int(c.size), "states": c[:max_states].tolist(),
                    "truncated": bool(c.size > max_states)}
        return {"closed_classes": [show(c) for c in self.closed_classes],
                "reachable_classes": list(self.reachable_classes),
                "holding_classes": list(self.holding_classes),
                "class_mass": list(self.class_mass),
                "zero_entropy_excluded": self.zero_entropy_excluded,
                "zero_cell_entropy_excluded": self.zero_cell_entropy_excluded,
                "message": self.message}


def _describe(c: np.ndarray, k: int = 5) -> str:
    head = ", ".join(str(int(s)) for s in c[:k])
    return f"{{{head}{', ...' if c.size > k else ''}}} ({c.size} state{'s' if c.size != 1 else ''})"


def analyze_structure(model: TransitionModel, initial=None) -> StructureReport:
    """Closed classes of ``model``'s support graph reachable from the initial support.

    Parameters
    ----------
    model : TransitionModel
    initial : array_like, optional
        Start distribution (default ``model.initial``).

    Returns
    -------
    StructureReport
        The closed classes reachable from the start support, and whether entropy can reach zero.
    """
    p = model.initial if initial is None else distribution(initial, model.n_states, model.tol)
    graph = support_graph(model)
    classes = closed_classes(graph)
    support = np.flatnonzero(p > 0)
    reach = _reachable(graph, support)
    reachable = [k for k, c in enumerate(classes) if reach[c[0]]]
    holding, masses = [], []
    for k in reachable:
        mass = float(p[classes[k]].sum())
        if mass > 0:
            holding.append(k)
            masses.append(mass)
    excluded = len(holding) >= 2
    if model.partition is None:
        cell_excluded = excluded
    else:
        common = None
        for k in holding:
            cells = set(np.unique(model.partition[classes[k]]).tolist())
            common = cells if common is None else common & cells
        cell_excluded = bool(excluded and not common)
    names = [f"class {k} = {_describe(classes[k])}" for k in reachable]
    if excluded:
        held = "; ".join(f"class {k} holds mass {m:.6g}" for k, m in zip(holding, masses))
        msg = (f"{len(holding)} closed classes hold initial mass ({held}); mass never leaves a closed "
               f"class, so the entropy on the states cannot reach zero")
        if model.partition is not None:
            msg += (" and neither can the report-grid entropy (the classes share no report cell)"
                    if cell_excluded else
                    ", but the report-grid entropy could (the classes share a report cell)")
        msg += ". Reachable closed classes: " + "; ".join(names) + "."
    elif len(reachable) > 1:
        msg = (f"{len(reachable)} closed classes are reachable ({'; '.join(names)}) but at most one "
               f"holds initial mass: which one the mass ends in depends on the sequence; zero entropy "
               f"is not excluded.")
    else:
        msg = (f"one closed class is reachable ({names[0]}): zero entropy is not excluded by the "
               f"class structure (whether a sequence reaches it is a synchronization question).")
    return StructureReport(closed_classes=classes, reachable_classes=reachable,
                           holding_classes=holding, class_mass=masses,
                           zero_entropy_excluded=excluded, zero_cell_entropy_excluded=cell_excluded,
                           message=msg)
