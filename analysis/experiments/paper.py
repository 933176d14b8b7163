"""The paper's own figures (Mannam et al., Sec. V A-C), for the side-by-side table.

A leaf module: it imports nothing of the project, so every experiment can cite it without a cycle.
"""
from __future__ import annotations

__all__ = ["PAPER"]

#: the paper's figures: experiment A (43 random 50-tilt sequences on the allen key), B (15 random
#: triangles), C (20 friction maps, as converged of maps per level) and Erdmann and Mason's hand plan.
PAPER = {
    "A": {"sequences": 43, "converged": 29, "near_zero_by": 20, "best_length": 8, "trials": 10_000},
    "B": {"parts": 15, "converged": 10, "near_zero_by": 27, "trials": 10_000},
    "C": {"low": (10, 13), "medium": (0, 3), "high": (0, 4), "trials": 1_000},
    "erdmann_mason_plan_length": 5,
}
