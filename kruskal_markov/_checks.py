"""The shared input checks: one home for "an integer, not a bool" and "a finite number in range".

Every package checks its inputs with these two functions, so that the rule and the wording of its
one-line error are the same everywhere::

    check_int(v, "samples", lo=1, hi=10_000)          # "samples must be an integer in 1..10000, got 0"
    check_number(v, "heavy_weight", lo=0, hi=1, lo_open=True)   # "... must be a number in (0, 1], got 0.0"

Both return the value converted (``int`` / ``float``), raise ``ValueError`` (or ``error``), and
refuse ``bool`` (a ``True`` is not a count) and, for numbers, NaN and the infinities.
:func:`check_fields` checks the keys of a settings table read from a file.
"""
from __future__ import annotations

import dataclasses
import math
import numbers

__all__ = ["check_int", "check_number", "check_fields", "is_int", "is_number"]


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
