"""Outcome codes of one simulated tilt (docs/commands.md ``--poses`` column ``status``).

A faulted trial is never returned as a pose: its pose is NaN and its status says why.
"""
from __future__ import annotations

import numpy as np

OK = 0          #: came to rest lying flat inside the tray
TIPPED = 1      #: rotated out of the plane (no longer lying flat)
ESCAPED = 2     #: left the tray (outside the walls or below the floor)
UNSETTLED = 3   #: still moving when the time limit ran out
INVALID = 4     #: NaN or infinite state, or a start pose that is not collision-free

#: status code -> name, in code order (index = code).
STATUS_NAMES = ("ok", "tipped", "escaped", "unsettled", "invalid")
#: the fault names, as used in the ``faults`` JSON object.
FAULT_NAMES = STATUS_NAMES[1:]


def fault_counts(status) -> dict[str, int]:
    """Count every fault kind in an array of status codes: ``{"tipped": .., "escaped": .., ...}``."""
    s = np.asarray(status, dtype=np.int64).ravel()
    counts = np.bincount(s, minlength=len(STATUS_NAMES))
    if counts.size > len(STATUS_NAMES):
        raise ValueError(f"unknown status code(s) {sorted(set(s.tolist()) - set(range(len(STATUS_NAMES))))}")
    return {name: int(counts[code]) for code, name in enumerate(STATUS_NAMES) if code != OK}
