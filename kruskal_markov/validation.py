"""Validation of inputs shared by every package: one home, one rule, one set of messages.

Scalars and settings tables: :func:`check_int` ("an integer, not a bool, in range"),
:func:`check_number` ("a finite number in range") and :func:`check_fields` (the keys of a settings
table read from a file)::

    check_int(v, "samples", lo=1, hi=10_000)          # "samples must be an integer in 1..10000, got 0"
    check_number(v, "heavy_weight", lo=0, hi=1, lo_open=True)   # "... must be a number in (0, 1], got 0.0"

Both return the value converted (``int`` / ``float``), raise ``ValueError`` (or ``error``), and
refuse ``bool`` (a ``True`` is not a count) and, for numbers, NaN and the infinities.

A model's inputs: :func:`distribution` (a probability vector over the states), :func:`action_weights`
(probabilities of the actions) and :func:`action_position` (an action's name to its index); these
raise :class:`~kruskal_markov.errors.ModelError`.
"""
from __future__ import annotations

import dataclasses
import math
import numbers

import numpy as np

from kruskal_markov.errors import ModelError

__all__ = ["check_int", "check_number", "check_fields", "is_int", "is_number",
           "action_position", "action_weights", "beyond", "distribution"]


def is_int(value) -> bool:
    """True for Python and NumPy integers, False for ``bool`` and everything else."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool) and type(value).__name__ != "bool_"


def is_number(value) -> bool:
    """True for finite real numbers (integers included), False for ``bool``, NaN and infinities."""
    return (isinstance(value, numbers.Real) and not isinstance(value, bool) and type(value).__name__ != "bool_"
            and math.isfinite(value))


def _describe(kind: str, lo, hi, lo_open: bool, hi_open: bool) -> str:
    if kind == "integer":
        if lo is not None and hi is not None:
            return f"an integer in {lo}..{hi}"
        if lo == 1:
            return "a positive integer"
        if lo == 0:
            return "a non-negative integer"
        return f"an integer >= {lo}" if lo is not None else (f"an integer <= {hi}" if hi is not None else "an integer")
    if lo is not None and hi is not None:
        return f"a number in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
    if lo is not None:
        if lo == 0:
            return "a positive number" if lo_open else "a non-negative finite number"
        return f"a number {'>' if lo_open else '>='} {lo:g}"
    if hi is not None:
        return f"a number {'<' if hi_open else '<='} {hi:g}"
    return "a finite number"


def check_int(value, name: str, *, lo: int | None = None, hi: int | None = None, error=ValueError) -> int:
    """``value`` as an ``int`` if it is an integer (not a bool) in ``lo..hi`` (inclusive; None: open).

    Parameters
    ----------
    value : object
        What was given.
    name : str
        How the message names it (e.g. ``"build setting samples"`` or ``"--count"``).
    lo, hi : int, optional
        Inclusive bounds.
    error : type, default ValueError
        The exception class raised.

    Returns
    -------
    int

    Examples
    --------
    >>> check_int(3, "count", lo=1)
    3
    >>> check_int(True, "count", lo=1)
    Traceback (most recent call last):
    ...
    ValueError: count must be a positive integer, got True
    """
    if not is_int(value) or (lo is not None and value < lo) or (hi is not None and value > hi):
        raise error(f"{name} must be {_describe('integer', lo, hi, False, False)}, got {value!r}")
    return int(value)


def check_number(value, name: str, *, lo: float | None = None, hi: float | None = None, lo_open: bool = False,
                 hi_open: bool = False, error=ValueError) -> float:
    """``value`` as a ``float`` if it is a finite real number (not a bool) within the bounds.

    Parameters
    ----------
    value : object
        What was given.
    name : str
        How the message names it.
    lo, hi : float, optional
        Bounds (None: none).
    lo_open, hi_open : bool, default False
        Exclude the bound itself.
    error : type, default ValueError
        The exception class raised.

    Returns
    -------
    float

    Examples
    --------
    >>> check_number(0.5, "weight", lo=0, hi=1, hi_open=True)
    0.5
    >>> check_number(float("nan"), "weight", lo=0, hi=1, hi_open=True)
    Traceback (most recent call last):
    ...
    ValueError: weight must be a number in [0, 1), got nan
    """
    ok = is_number(value)
    if ok and lo is not None:
        ok = value > lo if lo_open else value >= lo
    if ok and hi is not None:
        ok = value < hi if hi_open else value <= hi
    if not ok:
        raise error(f"{name} must be {_describe('number', lo, hi, lo_open, hi_open)}, got {value!r}")
    return float(value)


def check_fields(data, cls, what: str) -> dict:
    """``data`` if it is a dict whose keys are all fields of the dataclass ``cls``.

    Parameters
    ----------
    data : object
        What was read (e.g. the ``sim`` table of a scene file).
    cls : type
        A dataclass.
    what : str
        How the message names one key (``"sim setting"``).

    Returns
    -------
    dict
        ``data`` itself.

    Examples
    --------
    >>> from dataclasses import dataclass
    >>> @dataclass
    ... class Point:
    ...     x: float = 0.0
    >>> check_fields({"y": 1}, Point, "point setting")
    Traceback (most recent call last):
    ...
    ValueError: unknown point setting(s) y; known: x
    """
    if not isinstance(data, dict):
        raise ValueError(f"{what}s must be a table/object, got {type(data).__name__}")
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - known)
    if unknown:
        raise ValueError(f"unknown {what}(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
    return data


def action_weights(n_actions: int, weights=None) -> np.ndarray:
    """Action probabilities from ``weights`` (non-negative, up to a factor; None: uniform).

    Raises :class:`~kruskal_markov.model.ModelError` (a ``ValueError``) naming what is wrong.

    >>> action_weights(4, [1, 1, 2, 0]).tolist()
    [0.25, 0.25, 0.5, 0.0]
    """
    if weights is None:
        return np.full(n_actions, 1.0 / n_actions)
    try:
        w = np.asarray(weights, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise ModelError("action weights must be numbers") from None
    if w.size != n_actions:
        raise ModelError(f"{w.size} action weights given for {n_actions} actions")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise ModelError("action weights must be finite and non-negative")
    if w.sum() <= 0:
        raise ModelError("action weights must not all be zero")
    return w / w.sum()


def beyond(deviation: float, tol: float) -> str:
    """``deviation`` signed, with as many digits as it takes to read as larger than ``tol``.

    >>> beyond(1.0000000001e-9, 1e-9)
    '+1.0000000001e-09'
    """
    for digits in range(6, 18):
        text = f"{deviation:+.{digits}g}"
        if f"{abs(deviation):.{digits}g}" != f"{tol:.{digits}g}":
            return text
    return f"{deviation:+.17g}"


def distribution(values, n_states: int, tol: float, what: str = "initial distribution") -> np.ndarray:
    """``values`` as a probability vector over ``n_states`` states (a new float64 array).

    Raises :class:`~kruskal_markov.errors.ModelError` naming the first problem: not numeric, the
    wrong length, a non-finite or negative entry (with its state), or a sum off 1 by more than
    ``tol``. The vector is not renormalised.

    >>> distribution([0.25, 0.75], 2, 1e-9).tolist()
    [0.25, 0.75]
    >>> distribution([0.5, 0.6], 2, 1e-9)
    Traceback (most recent call last):
    ...
    kruskal_markov.errors.ModelError: initial distribution sums to 1.1, off by +0.1, more than the tolerance 1e-09
    """
    try:
        p = np.array(values, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise ModelError(f"{what} must be a numeric vector") from None
    if p.shape != (n_states,):
        raise ModelError(f"{what} has {p.size} entries, the model has {n_states} states")
    if not np.all(np.isfinite(p)):
        raise ModelError(f"{what} has a non-finite entry at state {int(np.flatnonzero(~np.isfinite(p))[0])}")
    if np.any(p < 0):
        i = int(np.argmin(p))
        raise ModelError(f"{what} has a negative entry {p[i]:.6g} at state {i}")
    total = p.sum()
    if abs(total - 1.0) > tol:
        raise ModelError(f"{what} sums to {float(total)!r}, off by "
                         f"{beyond(float(total) - 1.0, tol)}, more than the tolerance {tol:g}")
    return p


def action_position(actions, name, context: str = "") -> int:
    """Index of the action called ``name`` in ``actions``: the exact name first, else the one name
    equal to it ignoring case and surrounding spaces. The one way every layer (model, scene, command
    line) turns an action name into an index.

    Raises :class:`~kruskal_markov.errors.ModelError` (a ``ValueError``) naming the unknown action
    and the known ones; ``context`` (e.g. ``" in sequence"``) says where it was met.

    >>> action_position(("N", "NE", "E"), " ne ")
    1
    """
    names = tuple(str(a) for a in actions)
    text = str(name)
    if text in names:
        return names.index(text)
    key = text.strip().upper()
    for i, a in enumerate(names):
        if a.strip().upper() == key:
            return i
    raise ModelError(f"unknown action {name!r}{context}; known actions: {','.join(names)}")
