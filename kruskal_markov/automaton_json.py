"""Plain JSON automata in and out (the ``--automaton`` format of docs/commands.md).

Deterministic::

    {"states": 3, "actions": {"a": [1, 2, 0], "b": [0, 0, 2]}}

Stochastic (per action, a coordinate list; repeated ``(row, col)`` pairs are summed)::

    {"states": 2, "actions": {"a": {"rows": [0, 0, 1], "cols": [0, 1, 1], "probs": [0.5, 0.5, 1.0]}},
     "initial": [0.5, 0.5]}

The two forms may be mixed action by action. ``initial`` is optional (default uniform). As
extensions, ``"partition"`` (state -> report cell), ``"cells"`` (number of cells) and
``"metadata"`` (any JSON object) are read and written too. Rows must sum to 1 within ``tol``
(default 1e-9).
"""
from __future__ import annotations

import json
import math
import os

import numpy as np
import scipy.sparse as sp

from kruskal_markov.model import ModelError, TransitionModel
from kruskal_markov.validation import check_int

__all__ = ["model_from_automaton", "automaton_from_model", "load_automaton_dict"]

_KNOWN_KEYS = {"states", "actions", "initial", "partition", "cells", "metadata"}


def load_automaton_dict(source) -> tuple[dict, str]:
    """Return ``(dict, label)`` from a path, a JSON text or an already parsed dict.

    Parameters
    ----------
    source : str, path-like or dict
        A file path, JSON text, or a parsed dict.

    Returns
    -------
    data : dict
        The automaton object.
    label : str
        Where it came from, for messages.
    """
    if isinstance(source, dict):
        return source, "automaton"
    if isinstance(source, (str, os.PathLike)):
        text_source = os.fspath(source)
        if isinstance(source, str) and source.lstrip().startswith("{"):
            text, label = source, "automaton"
        else:
            if not os.path.exists(text_source):
                raise ModelError(f"automaton file not found: {text_source}")
            try:
                with open(text_source, "r", encoding="utf-8") as fh:
                    text = fh.read()
            except (OSError, UnicodeDecodeError) as exc:
                raise ModelError(f"cannot read automaton file {text_source}: {exc}") from None
            label = f"automaton {text_source}"
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ModelError(f"{label}: not valid JSON ({exc})") from None
        except RecursionError:
            raise ModelError(f"{label}: JSON nested too deeply") from None
        if not isinstance(data, dict):
            raise ModelError(f"{label}: expected a JSON object with 'states' and 'actions'")
        return data, label
    raise ModelError(f"automaton must be a path, a JSON string or a dict, got {type(source).__name__}")


def _int_list(values, what: str, label: str) -> np.ndarray:
    if not isinstance(values, list):
        raise ModelError(f"{label}: {what} must be a list of integers")
    for i, v in enumerate(values):
        if isinstance(v, float) and not math.isfinite(v):
            raise ModelError(f"{label}: {what} has a non-finite entry {v!r} at position {i}")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or (isinstance(v, float) and v != int(v)):
            raise ModelError(f"{label}: {what} must contain integers only, found {v!r} at position {i}")
    try:
        return np.asarray(values, dtype=np.int64) if values else np.zeros(0, dtype=np.int64)
    except OverflowError:
        big = next(v for v in values if not -2 ** 63 <= v < 2 ** 63)
        raise ModelError(f"{label}: {what} has an entry {big!r} beyond any state index") from None


def _action_matrix(spec, n: int, where: str) -> sp.csr_matrix:
    """One action of the automaton JSON: a next-state list or a stochastic ``rows/cols/probs``."""
    if isinstance(spec, list):
        nxt = _int_list(spec, "next-state list", where)
        if nxt.size != n:
            raise ModelError(f"{where}: next-state list has {nxt.size} entries, expected {n}")
        if nxt.size and (nxt.min() < 0 or nxt.max() >= n):
            i = int(np.flatnonzero((nxt < 0) | (nxt >= n))[0])
            raise ModelError(f"{where}: state {i} goes to {int(nxt[i])}, out of range [0, {n})")
        m = sp.csr_matrix((np.ones(n), nxt, np.arange(n + 1)), shape=(n, n))
    elif isinstance(spec, dict):
        missing = {"rows", "cols", "probs"} - set(spec)
        extra = set(spec) - {"rows", "cols", "probs"}
        if missing or extra:
            raise ModelError(f"{where}: a stochastic action needs exactly 'rows', 'cols', 'probs' "
                             f"(missing {sorted(missing)}, unexpected {sorted(extra)})")
        rows = _int_list(spec["rows"], "'rows'", where)
        cols = _int_list(spec["cols"], "'cols'", where)
        probs = spec["probs"]
        if not isinstance(probs, list) or any(isinstance(p, bool) or not isinstance(p, (int, float))
                                              for p in probs):
            raise ModelError(f"{where}: 'probs' must be a list of numbers")
        probs = np.asarray(probs, dtype=np.float64)
        if not (rows.size == cols.size == probs.size):
            raise ModelError(f"{where}: 'rows', 'cols', 'probs' have different lengths "
                             f"({rows.size}, {cols.size}, {probs.size})")
        for arr, what in ((rows, "row"), (cols, "column")):
            if arr.size and (arr.min() < 0 or arr.max() >= n):
                bad = int(arr[(arr < 0) | (arr >= n)][0])
                raise ModelError(f"{where}: {what} index {bad} out of range [0, {n})")
        m = sp.coo_matrix((probs, (rows, cols)), shape=(n, n)).tocsr()
    else:
        raise ModelError(f"{where}: expected a next-state list or an object with rows/cols/probs")
    return m


def model_from_automaton(source, tol: float = 1e-9) -> TransitionModel:
    """Build a :class:`TransitionModel` from the docs/commands.md automaton JSON.

    Parameters
    ----------
    source : path, JSON string or dict
    tol : float
        Row-sum tolerance (docs/commands.md: 1e-9).
    Returns
    -------
    TransitionModel
        A :class:`~kruskal_markov.errors.ModelError` names what is wrong and where.


    Examples
    --------
    >>> m = model_from_automaton({"states": 2, "actions": {"a": [1, 1]}})
    >>> m.deterministic_table().tolist()
    [[1, 1]]
    """
    data, label = load_automaton_dict(source)
    unknown = set(data) - _KNOWN_KEYS
    if unknown:
        raise ModelError(f"{label}: unknown key(s) {sorted(unknown)}; expected {sorted(_KNOWN_KEYS)}")
    n = data.get("states")
    check_int(n, f"{label}: 'states'", lo=1, error=ModelError)
    actions = data.get("actions")
    if isinstance(actions, dict):
        from kruskal_markov.limits import check_memory

        check_memory(float(n) * 8 * (3 * len(actions) + 4), f"{label}: an automaton of {n:,} states",
                     "is 'states' right?")
    if not isinstance(actions, dict) or not actions:
        raise ModelError(f"{label}: 'actions' must be a non-empty object mapping action names to "
                         f"transitions")
    names = list(actions)
    mats = [_action_matrix(spec, n, f"{label}: action {name!r}") for name, spec in actions.items()]
    initial = data.get("initial")
    if initial is not None and (not isinstance(initial, list)
                                or any(isinstance(p, bool) or not isinstance(p, (int, float)) for p in initial)):
        raise ModelError(f"{label}: 'initial' must be a list of {n} numbers")
    partition = data.get("partition")
    if partition is not None:
        partition = _int_list(partition, "'partition'", label)
    cells = data.get("cells")
    metadata = data.get("metadata")
    try:
        return TransitionModel(names, mats, initial=initial, partition=partition, n_cells=cells,
                               metadata=metadata, tol=tol)
    except ModelError as exc:
        raise ModelError(f"{label}: {exc}") from None


def automaton_from_model(model: TransitionModel) -> dict:
    """The docs/commands.md JSON object for ``model`` (deterministic lists when every row is a point mass).

    ``initial`` is written only when it is not uniform; ``partition``/``cells``/``metadata`` only
    when present. ``model_from_automaton(automaton_from_model(m))`` reproduces ``m`` exactly
    (floats are written with full precision by :mod:`json`).

    Parameters
    ----------
    model : TransitionModel
        Any model.

    Returns
    -------
    dict
        JSON-ready.
    """
    n = model.n_states
    out: dict = {"states": n, "actions": {}}
    det = model.is_deterministic()
    for name, m in zip(model.actions, model.matrices):
        if det:
            out["actions"][name] = [int(j) for j in m.indices]
        else:
            coo = m.tocoo()
            out["actions"][name] = {"rows": coo.row.astype(int).tolist(),
                                    "cols": coo.col.astype(int).tolist(),
                                    "probs": coo.data.astype(float).tolist()}
    if not np.array_equal(model.initial, np.full(n, 1.0 / n)):
        out["initial"] = model.initial.astype(float).tolist()
    if model.partition is not None:
        out["partition"] = model.partition.astype(int).tolist()
        out["cells"] = int(model.n_cells)
    if model.metadata:
        out["metadata"] = model.metadata
    return out
