"""Number formatting shared by the experiments' markdown (one rule per kind of number)."""
from __future__ import annotations

__all__ = ["fmt", "interval", "expected_text"]


def fmt(x, spec=".2f", none="-") -> str:
    """``x`` formatted with ``spec``, or ``none`` when it is None.

    >>> fmt(None), fmt(1.23456), fmt(3, "d"), fmt(None, none="never")
    ('-', '1.23', '3', 'never')
    """
    return none if x is None else format(x, spec)


def interval(x, f=".3g") -> str:
    """An interval ``(lo, hi)`` as ``lo to hi`` (``-`` when missing or open).

    >>> interval((0.1, 0.25)), interval(None), interval((None, 1.0))
    ('0.1 to 0.25', '-', '-')
    """
    return "-" if x is None or None in x else f"{x[0]:{f}} to {x[1]:{f}}"


def expected_text(metrics: dict, key: str, ci_key: str, lower_key: str) -> str:
    """A Monte Carlo mean with its 95% interval, or "at least" its lower bound when runs were
    censored (older results without the bound: the mean as recorded)."""
    lower = metrics.get(lower_key)
    if metrics.get(key) is None and lower is not None:
        return f"at least {lower:.1f} (censored runs counted at 1,000: no mean)"
    ci = metrics.get(ci_key) or [None, None]
    return f"{fmt(metrics.get(key), '.1f')} (95% interval {fmt(ci[0], '.1f')}-{fmt(ci[1], '.1f')})"
