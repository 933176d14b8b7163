"""The model-error interval's variants compared on kept fits, without a new build (docs/fit.md).

Reads fits kept by ``benchmarks.bench_fit`` (their criterion at every grid point and the replicate
builds' differences) and recomputes the 90% interval's model part four ways: A pooled replicate and
residual variance (version 1), B the residual variance alone, C = A plus the grid's resolution
term, D = B plus the resolution term (close to version 2, which carries the larger of the residual
and the replicate variance). The trials' share is left out (20-100 times smaller on the key's logs).

``python -m benchmarks.bench_fit_variants [FIT.json ...]`` (default: the tuning logs' and the first
validation's kept fits), a few seconds.
"""
from __future__ import annotations

import glob
import json
import sys

import numpy as np

from analysis.fit.model_error import model_error, weighted_vertex

DEFAULT = ("benchmarks/results/fit_tuning/fit_tuning?_rep1.json", "benchmarks/results/fit_report_log/fit_report_rep1.json",
           "benchmarks/results/fit_methodA/fit?.json")


def _curve(r: dict):
    x = np.array([c["mu"] for c in r["criterion"]])
    y = np.array([c["loglik"] for c in r["criterion"]])
    me = r["model_error"]
    n, ym = np.ones(len(x)), y.copy()
    for p, d in zip(me["replicated_points"], me["replicate_differences"]):
        k = int(np.argmin(np.abs(x - p)))
        ym[k], n[k] = y[k] - d / 2, 2.0            # the mean of the build and its replicate (y - d)
    return x, ym, n, me["replicate_differences"]


def _kept_fit(path: str):
    """A kept fit's truth, its criterion curve (:func:`_curve`), the best point ``j`` and the grid's
    spacing ``h`` beside it."""
    with open(path) as f:
        r = json.load(f)
    x, y, n, diffs = _curve(r)
    j = int(np.argmax(y))
    return r["truth"], x, y, n, diffs, j, float(min(np.diff(x)[max(0, j - 1):j + 1]))


def _interval(x, y, n, var, dof, rng, half, count=2000, est=weighted_vertex):
    """The 90% interval of ``est`` under the model-error bootstrap: a scaled-inverse-chi-square
    variance, normal noise on the curve, and the resolution term ``U(-half, half)``."""
    out = np.empty(count)
    for b in range(count):
        v = var * dof / rng.chisquare(dof) if var else 0.0
        yy = y + rng.normal(0.0, 1.0, len(x)) * np.sqrt(v / n)
        out[b] = est(x, yy, n, int(np.argmax(yy)))
    return np.quantile(out + rng.uniform(-half, half, count), [0.05, 0.95])


def main(paths) -> dict:
    files = [f for p in paths for f in sorted(glob.glob(p))]
    table = {k: [] for k in "ABCD"}
    for f in files:
        t, x, y, n, diffs, j, h = _kept_fit(f)
        pooled, resid = model_error(x, y, n, j, []), model_error(x, y, n, j, [])
        d = np.asarray(diffs)
        if len(d):                                  # version 1's pooling
            ss = float(np.sum(d ** 2) / 2) + (resid.var or 0.0) * resid.dof
            pooled.var, pooled.dof = ss / (len(d) + resid.dof), len(d) + resid.dof
        rng = np.random.default_rng(0)
        line = f"{f}: truth {t:.3f} estimate {weighted_vertex(x, y, n, j):.4f}"
        for k, (e, half) in {"A": (pooled, 0.0), "B": (resid, 0.0), "C": (pooled, h / 2), "D": (resid, h / 2)}.items():
            lo, hi = _interval(x, y, n, e.var, e.dof, rng, half)
            table[k].append({"file": f, "interval": [float(lo), float(hi)], "covered": bool(lo <= t <= hi)})
            line += f" | {k} {lo:.4f}..{hi:.4f} {'covers' if lo <= t <= hi else 'MISSES'}"
        print(line)
    summary = {k: {"covered": sum(v["covered"] for v in rows), "logs": len(rows),
                   "mean_width": float(np.mean([v["interval"][1] - v["interval"][0] for v in rows]))}
               for k, rows in table.items()}
    print(json.dumps(summary))
    return summary


if __name__ == "__main__":
    main(sys.argv[1:] or DEFAULT)
