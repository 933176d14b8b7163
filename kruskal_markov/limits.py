"""Memory limits: sizes asked for by the user are checked against the machine *before* allocating.

A command asked for something the machine cannot hold (``--count 10**12``, an automaton claiming
10^11 states, a poses CSV with step 99999999999) fails with one line that says what was asked,
what it would need, what the machine has, and which option changes it -- never a MemoryError
after the system started swapping, and never a process killed by the kernel.
"""
from __future__ import annotations

import os

from kruskal_markov.model import ModelError

__all__ = ["available_memory_bytes", "check_memory", "format_bytes"]

#: share of the available memory one request may take.
MEMORY_SHARE = 0.8


def available_memory_bytes() -> int:
    """Memory available to this process: ``MemAvailable`` (Linux), else the physical memory."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        return 8 << 30


def format_bytes(n: float) -> str:
    """``1.5 GB`` style."""
    for unit in ("B", "KB", "MB", "GB", "TB", "PB"):
        if abs(n) < 1024 or unit == "PB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} EB"  # pragma: no cover


def check_memory(nbytes: float, what: str, hint: str = "") -> None:
    """Raise :class:`ModelError` (a ValueError: one line, exit 2 on the command line) if
    ``nbytes`` exceeds ``MEMORY_SHARE`` of the available memory.

    >>> check_memory(1024, "a tiny array")
    >>> try:
    ...     check_memory(1e30, "10^30 bytes", "use fewer")
    ... except ValueError as exc:
    ...     print(str(exc).split(" needs")[0])
    10^30 bytes
    """
    avail = available_memory_bytes()
    if nbytes > MEMORY_SHARE * avail:
        raise ModelError(f"{what} needs {format_bytes(nbytes)} of memory, more than this machine has available "
                         f"({format_bytes(avail)})" + (f"; {hint}" if hint else ""))
