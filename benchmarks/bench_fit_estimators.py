"""The 1-D fit's estimators compared on the spent logs' kept fits, without a new build (docs/fit.md).

Reads the criterion curves kept by ``benchmarks.bench_fit`` (the tuning logs, the first and the
second validation sets: all spent, so this is tuning) and recomputes, for each estimator, the
estimate and the version-2 interval's model part with that estimator inside the resamples (the
residual variance, the scaled-inverse-chi-square draw and the ``U(-h/2, h/2)`` resolution term;
the trials' share is left out, 20-100 times smaller on the key's logs). Estimators:
``vertex`` (version 2: weighted quadratic through the best point and two neighbours each side),
``grid`` (the best grid point), ``q3`` (the parabola through the best point and its two
neighbours) and ``vertex_clipped`` (the vertex kept within half a spacing of the best point).

``python -m benchmarks.bench_fit_estimators`` (a few seconds).
"""
from __future__ import annotations

import numpy as np

from analysis.fit.model_error import best_point, model_error, weighted_vertex
from benchmarks.bench_fit_variants import _interval, _kept_fit

SETS = {"tuning": [f"benchmarks/results/fit_tuning/fit_tuning{i}_rep1.json" for i in range(3)]
        + ["benchmarks/results/fit_report_log/fit_report_rep1.json"],
        "validation 1 (4100-4109)": [f"benchmarks/results/fit_methodA/fit{i}.json" for i in range(10)],
        "validation 2 (4500-4509)": [f"benchmarks/results/fit_validation2/fit{i}.json" for i in range(10)]}


def q3(x, y, n, j) -> float:
    """The vertex of the parabola through the best point and its two neighbours."""
    if 0 < j < len(x) - 1:
        a, b, _ = np.polyfit(x[j - 1:j + 2] - x[j], y[j - 1:j + 2] - y[j], 2)
        if a < 0:
            v = x[j] - b / (2 * a)
            if x[j - 1] <= v <= x[j + 1]:
                return float(v)
    return float(x[j])


def vertex_clipped(x, y, n, j) -> float:
    """The weighted vertex kept within half a spacing of the best point."""
    v = weighted_vertex(x, y, n, j)
    if 0 < j < len(x) - 1:
        return float(np.clip(v, (x[j - 1] + x[j]) / 2, (x[j] + x[j + 1]) / 2))
    return v


ESTIMATORS = {"vertex": weighted_vertex, "grid": best_point, "q3": q3, "vertex_clipped": vertex_clipped}


def main() -> dict:
    summary = {}
    for name, files in SETS.items():
        rows = {k: [] for k in ESTIMATORS}
        for f in files:
            t, x, y, n, diffs, j, h = _kept_fit(f)
            err = model_error(x, y, n, j, diffs, resolution=h)
            for k, e in ESTIMATORS.items():
                lo, hi = _interval(x, y, n, err.var, err.dof, np.random.default_rng(0), h / 2, est=e)
                rows[k].append((e(x, y, n, j) - t, bool(lo <= t <= hi), float(hi - lo)))
        for k, v in rows.items():
            e = np.abs([a for a, _, _ in v])
            summary[f"{name} {k}"] = {"logs": len(v), "max_abs_error": float(e.max()), "mean_abs_error": float(e.mean()),
                                      "within_0_02": int((e <= 0.02).sum()), "covered": sum(c for _, c, _ in v),
                                      "mean_width": float(np.mean([w for *_, w in v]))}
    print("| set | estimator | max abs. error | mean abs. error | within 0.02 | covered | mean width |")
    print("|---|---|---|---|---|---|---|")
    for key, s in summary.items():
        name, k = key.rsplit(" ", 1)
        print(f"| {name} | {k} | {s['max_abs_error']:.4f} | {s['mean_abs_error']:.4f} | {s['within_0_02']}/{s['logs']} | "
              f"{s['covered']}/{s['logs']} | {s['mean_width']:.3f} |")
    return summary


if __name__ == "__main__":
    main()
