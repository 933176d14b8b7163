"""``kruskal fit --fit mu_s,mu_k`` on the synthetic pair family: error and interval coverage (docs/fit.md).

The family is the tests' (``tests/**/test_fit.py``: under every tilt a state goes to a second
successor with probability ``mu_k``, to a third with ``mu_s - mu_k`` and to the first with
``1 - mu_s``), so this measures the pair's grid, refinement, estimate and bootstrap, not the physics.
20 logs of 200 trials x 15 tilts, camera noise 0.5 mm / 0.5 degree (given to the fit), range
0.1..0.5, 6 points per coefficient. Truths: ``mu_k = default_rng(SET).uniform(0.15, 0.35, 20)``, then
``mu_s = mu_k + uniform(0, 0.12, 20)`` from the same generator; log *i* has seed ``BASE + i``, its fit
seed *i*. The tuning set is SET 99, BASE 50; the validation set, named before it ran, SET 2043,
BASE 500 (the default).

``python -m benchmarks.bench_fit_pair [SET BASE [REFINE [WINDOW]]]`` (about 15 s, no lock needed):
WINDOW scales the estimate's window (1 = one finest spacing, the default).
"""
from __future__ import annotations

import importlib.util
import pathlib
import sys
import tempfile
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent


def _family():
    """The tests' synthetic family (wherever the test tree keeps ``test_fit.py``)."""
    path = sorted(ROOT.glob("tests/**/test_fit.py"))[0]
    spec = importlib.util.spec_from_file_location("_bench_test_fit", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def run(set_seed: int = 2043, base: int = 500, refine: int = 2, window: float = 1.0) -> dict:
    """Fit the 20 logs of one set; errors, interval widths and coverage."""
    import analysis.fit.core as core
    from analysis.fit import FitSettings, fit_log, read_fit_log
    from transition_builder.scene import scene_from_options

    fam = _family()
    scene = scene_from_options(fam.SHAPE)
    rng = np.random.default_rng(set_seed)
    mks, gaps = rng.uniform(0.15, 0.35, 20), rng.uniform(0, 0.12, 20)
    summary = core.pair_summary
    core.pair_summary = lambda P, y, L, ranges, half, *a: summary(P, y, L, ranges, half * window, *a)
    rows = []
    t0 = time.perf_counter()
    try:
        with tempfile.TemporaryDirectory() as d:
            for i, (mk, gap) in enumerate(zip(mks, gaps)):
                path = pathlib.Path(d) / f"log{i}.csv"
                fam.synthetic_log(scene, path, mk, trials=200, tilts=15, seed=base + i, noise=gap)
                log = read_fit_log(path, scene.actions, (scene.tray_x_mm, scene.tray_y_mm))
                st = FitSettings(params=("mu_s", "mu_k"), ranges={"mu_s": (0.1, 0.5), "mu_k": (0.1, 0.5)},
                                 points={"mu_s": 6, "mu_k": 6}, camera=(0.5, 0.5), bootstrap=400, seed=i,
                                 refine=refine)
                r = fit_log(scene, log, st, build=fam._pair_build)
                truth = {"mu_s": mk + gap, "mu_k": mk}
                iv = r.interval_90 or {}
                rows.append({n: {"truth": truth[n], "estimate": r.estimate[n], "interval": iv.get(n),
                                 "covered": bool(iv.get(n) and iv[n][0] <= truth[n] <= iv[n][1])}
                             for n in ("mu_s", "mu_k")})
    finally:
        core.pair_summary = summary
    err = np.array([[abs(row[n]["estimate"] - row[n]["truth"]) for n in ("mu_s", "mu_k")] for row in rows])
    cov = {n: sum(row[n]["covered"] for row in rows) for n in ("mu_s", "mu_k")}
    both = sum(row["mu_s"]["covered"] and row["mu_k"]["covered"] for row in rows)
    out = {"set": set_seed, "base": base, "refine": refine, "window": window,
           "mean_abs_error": err.mean(axis=0).round(4).tolist(), "max_abs_error": round(float(err.max()), 4),
           "covered": cov, "covered_both": both, "logs": len(rows), "seconds": time.perf_counter() - t0}
    print(out, flush=True)
    return out


def main(argv=()) -> None:
    args = [float(a) for a in argv]
    names = ("set_seed", "base", "refine", "window")
    kw = {n: (int(v) if n != "window" else v) for n, v in zip(names, args)}
    run(**kw)


if __name__ == "__main__":
    main(sys.argv[1:])
