"""Direct simulation of a kit under one tilt sequence (``kruskal simulate --kit``), and a kit plan
replayed against its models' predictions.

Every compartment is simulated on its own (the parts never touch), all under the same sequence.
Compartment 0 draws its start poses from ``seed`` itself (so a one-compartment kit is exactly
``kruskal simulate --shape`` with that seed); compartment ``i > 0`` from a seed derived from
``(seed, i)`` (:func:`compartment_seed`), so the compartments' starts are independent draws.
"""
from __future__ import annotations

import numpy as np

from kruskal_markov.kit import wilson_interval

__all__ = ["compartment_seed", "simulate_kit", "final_cell_counts", "replay_plan"]


def compartment_seed(seed: int, i: int) -> int:
    """The start-pose seed of compartment ``i`` under the run's ``seed`` (``seed`` itself for ``i = 0``).

    >>> compartment_seed(5, 0), compartment_seed(5, 1) == compartment_seed(5, 1) != compartment_seed(6, 1)
    (5, True)
    """
    if i == 0:
        return int(seed)
    from analysis.streams import SALTS
    salt = SALTS["kit.compartment"]
    return int(np.random.SeedSequence([int(seed), int(i), salt]).generate_state(1, np.uint32)[0] >> 1)


def simulate_kit(scenes, sequence, trials: int, seed: int = 0, workers: int | None = None, grid: str = "4x4x4") -> list:
    """:func:`~analysis.montecarlo.run_direct` of every compartment under ``sequence``.

    Parameters
    ----------
    scenes : list of Scene
        One per compartment.
    sequence : sequence of str or int
        Action names or indices (shared by every compartment).
    trials : int
        Trials per compartment.
    seed : int
        Seed of the run (:func:`compartment_seed`).
    workers : int, optional
        Worker processes.
    grid : str
        Report grid of every compartment (on its own tray).

    Returns
    -------
    list of DirectResult
    """
    from analysis.montecarlo import run_direct

    return [run_direct(scene, sequence, trials, seed=compartment_seed(seed, i), workers=workers, grid=grid)
            for i, scene in enumerate(scenes)]


def final_cell_counts(result) -> dict:
    """``{report cell: trials}`` of the surviving trials after the last tilt of a DirectResult."""
    last = result.poses[:, -1, :]
    ok = np.all(np.isfinite(last), axis=1)
    cells, counts = np.unique(result.grid.voxel_index(last[ok]), return_counts=True)
    return {int(c): int(n) for c, n in zip(cells, counts)}


def replay_plan(scenes, names, word, final_cells, success, trials: int, seed: int = 0,
                workers: int | None = None) -> dict:
    """Replay a kit plan in direct simulation: per compartment the share of trials in the model's
    predicted final cell, its 95% (Wilson) interval and whether the model's success probability
    lies in it (within 1e-9: a model's probability of 1 can be a rounding above it); the kit's share (every compartment in its cell, estimated as the product of the
    compartments' shares: they are simulated independently) beside the model's joint success.

    Parameters
    ----------
    scenes : list of Scene
    names : list of str
        Compartment names.
    word : list of str
        The plan.
    final_cells, success : list
        Per compartment the predicted final cell and the model's probability of ending in it.
    trials, seed, workers
        As for :func:`simulate_kit`.

    Returns
    -------
    dict
        ``compartments`` (``name``, ``predicted_cell``, ``model_success``, ``share``,
        ``share_ci95``, ``within``, ``faults``, ``entropy_bits``), ``joint_share``,
        ``joint_model_success``, ``trials``, ``sequence``.
    """
    results = simulate_kit(scenes, word, trials, seed=seed, workers=workers)
    rows = []
    for name, res, cell, p in zip(names, results, final_cells, success):
        hits = final_cell_counts(res).get(int(cell), 0)
        lo, hi = wilson_interval(hits, trials)
        rows.append({"name": name, "predicted_cell": int(cell), "model_success": float(p), "share": hits / trials,
                     "share_ci95": [lo, hi], "within": bool(lo - 1e-9 <= p <= hi + 1e-9), "faults": dict(res.faults),
                     "entropy_bits": float(res.entropy_bits[-1])})
    return {"compartments": rows, "joint_share": float(np.prod([r["share"] for r in rows])),
            "joint_model_success": float(np.prod([r["model_success"] for r in rows])), "trials": int(trials),
            "sequence": list(word), "results": results}
