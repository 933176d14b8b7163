"""``kruskal fit`` with the planar engine: estimates finer than the grid, camera misreads, other physics.

Protocols named here (truths, seeds, sizes) and committed before any of their logs was made
(docs/fit.md, "Finer than the grid"). Every log is the allen key, one random 50-tilt sequence
(``--sequence random:50 --seed SEED``), camera noise 0.5 mm / 0.5 degree, made once and kept under
``benchmarks/results/fit_fine/``; smaller logs are the first trials of the 1,000-trial log.

- ``TUNING_FINE``: truths ``default_rng(5656).uniform(0.175, 0.425, 3)`` rounded (0.267, 0.312,
  0.211), seeds 5600-5602, planar physics: the local grid's settings are chosen on these.
- ``VALID_FINE``: truths ``default_rng(5757).uniform(0.175, 0.425, 8)`` rounded, seeds 5700-5707,
  planar physics: the validation of the estimate at 100 / 200 / 500 / 1,000 trials.
- ``PYBULLET``: truths ``default_rng(5858).uniform(0.175, 0.425, 3)`` rounded, seeds 5800-5802,
  PyBullet physics (200 trials; slower), fitted by planar models.
- ``MAP``: truths ``default_rng(5959).uniform(0.175, 0.425, 3)`` rounded, seeds 5900-5902, planar
  physics on a mild friction map ``map:low:SEED:TRUTH`` (the mean is the truth), fitted by uniform
  planar models.

Misreads (``MISREAD_SHARE`` = 3% of the ``ok`` rows of a log replaced by a pose drawn uniformly over the
tray, ``default_rng([log seed, 3])``): the same logs' misread copies, ``SET`` ``tuning-misread`` or
``valid-misread`` (500 trials).

- ``PAIR`` (named 2026-11-28 before any of its logs): kinetic truths
  ``g = default_rng(6060); g.uniform(0.15, 0.35, 3)`` rounded (0.281, 0.188, 0.189), static
  ``mu_k + g.uniform(0, 0.15, 3)`` (the next draw: gaps 0.136, 0.101) for logs 0 and 1, and log 2
  with no gap (0.189/0.189); seeds 6000-6002, 500 trials, planar physics ``MU_S/MU_K``; fitted with
  ``--fit mu_s,mu_k --range 0.15..0.5`` (``python -m benchmarks.bench_fit_fine pair``).

- ``DESIGN_CHECK`` (named 2026-11-28 before any of its logs): truths
  ``default_rng(6363).uniform(0.2, 0.4, 3)`` rounded (0.39, 0.351, 0.355), seeds 6300-6302; for
  each, a 200-trial planar log of the sequence ``kruskal fit --design --shape allen-key --engine
  planar --sequences 4 --seed 0`` recommends and one of its first random candidate, both fitted as
  the validation logs are (``python -m benchmarks.bench_fit_fine designcheck``); the design then
  was made at the single point 0.3 (``--at 0.3``).
- ``DESIGN_CHECK2`` (named 2026-11-28, after the first check failed and the design became maximin
  over ``--at 0.2,0.3,0.4``, before any of its logs): truths ``default_rng(6464).uniform(0.2, 0.4,
  3)`` rounded, seeds 6400-6402, otherwise as ``DESIGN_CHECK`` with the maximin design
  (``python -m benchmarks.bench_fit_fine designcheck2``).

- ``PAIR2`` (named 2026-11-28 after PAIR's three were fitted, before any of its logs): 7 more,
  ``g = default_rng(6666)``, kinetic ``g.uniform(0.15, 0.35, 7)``, static ``mu_k + g.uniform(0, 0.15,
  7)``, both rounded; seeds 6600-6606 (``python -m benchmarks.bench_fit_fine pair2``).

Named 2026-11-29 (the ninth session), before any of their logs was made or any method of that
session was tried; the sets above are spent (tuning for what follows):

- ``VALID_CAL``: truths ``default_rng(7070).uniform(0.175, 0.425, 10)`` rounded, seeds 7000-7009,
  1,000 trials, planar physics: the validation of the single coefficient's final method at 100 /
  200 / 500 / 1,000 trials (``fit valid3``).
- ``PAIR3``: ``g = default_rng(7171)``, kinetic ``g.uniform(0.15, 0.35, 10)``, gaps
  ``g.uniform(0, 0.15, 10)`` with logs 3 and 7 set to no gap, both rounded; seeds 7100-7109, 500
  trials, planar physics (``pair3``).
- ``NOISE``: ``g = default_rng(7272)``, floor ``g.uniform(0.2, 0.4, 10)`` (3 decimals), process noise
  ``g.uniform(0.1, 0.4, 10)`` (2 decimals; ``pose:S,S``, mm and degrees) applied before every tilt;
  seeds 7200-7209, 500 trials, planar physics; fitted with ``--fit mu,noise`` (``noise``).
- ``FINESTEP``: truths ``default_rng(7373).uniform(0.175, 0.425, 3)`` rounded, seeds 7300-7302, 500
  trials, planar physics at a quarter of the time step (``time_step_s`` / 4, ``substeps`` x 4),
  fitted by models at the default step (``fit finestep``).

``python -m benchmarks.bench_fit_fine logs|fit|summary SET [SIZES...]`` (SET: tuning, valid,
pybullet, map); extra ``kruskal fit`` options after ``--``.
"""
from __future__ import annotations

import json
import os
import pathlib
import sys
import time
from dataclasses import dataclass, replace

import numpy as np

HERE = pathlib.Path(__file__).parent
OUT = HERE / "results" / "fit_fine"
SIZES = (100, 200, 500, 1000)
CAMERA = (0.5, 0.5)
TILTS = 50
#: the fit's options shared by every set (the grid before refinement: 0.15..0.5, 8 points).
FIT_OPTIONS = ("--engine", "planar", "--workers", "1", "--range", "0.15..0.5", "--points", "8")


@dataclass(frozen=True)
class FineSet:
    """A named set of logs: truths, first seed, trials of the full log, physics."""

    name: str
    truths: tuple
    seed0: int
    trials: int = 1000
    engine: str = "planar"
    friction: str = "{mu}"          # the log's friction spec; ``{mu}`` the truth, ``{seed}`` the log's seed
    noise: tuple = ()               # process noise of each log's physics (mm = degrees), () none
    settings: tuple = ()            # SimSettings changes of the log's physics, as (name, value) pairs


TUNING_FINE = FineSet("tuning", (0.267, 0.312, 0.211), 5600)
VALID_FINE = FineSet("valid", (0.239, 0.242, 0.216, 0.333, 0.184, 0.35, 0.299, 0.208), 5700)
PYBULLET = FineSet("pybullet", (0.374, 0.205, 0.392), 5800, trials=200, engine="pybullet")
MAP = FineSet("map", (0.35, 0.276, 0.237), 5900, friction="map:low:{seed}:{mu}")
PAIR_STATIC = (0.417, 0.289, 0.189)
PAIR = FineSet("pair", (0.281, 0.188, 0.189), 6000, trials=500, friction="{mus}/{mu}")
PAIR2 = FineSet("pair2", (0.168, 0.214, 0.176, 0.277, 0.18, 0.29, 0.235), 6600, trials=500, friction="{mus}/{mu}")
STATIC = {"pair": PAIR_STATIC, "pair2": (0.244, 0.306, 0.253, 0.381, 0.318, 0.384, 0.338)}
VALID_CAL = FineSet("valid3", (0.259, 0.349, 0.291, 0.384, 0.344, 0.232, 0.284, 0.355, 0.417, 0.202), 7000)
PAIR3 = FineSet("pair3", (0.18, 0.162, 0.336, 0.243, 0.289, 0.223, 0.261, 0.302, 0.301, 0.229), 7100, trials=500,
                friction="{mus}/{mu}")
STATIC["pair3"] = (0.322, 0.189, 0.486, 0.243, 0.326, 0.242, 0.325, 0.302, 0.361, 0.331)
NOISE = FineSet("noise", (0.238, 0.203, 0.222, 0.344, 0.37, 0.325, 0.272, 0.334, 0.208, 0.392), 7200, trials=500,
                noise=(0.11, 0.2, 0.13, 0.24, 0.32, 0.32, 0.16, 0.18, 0.29, 0.39))
FINESTEP = FineSet("finestep", (0.345, 0.211, 0.212), 7300, trials=500,
                   settings=(("time_step_s", 1.0 / 1920.0), ("substeps", 32)))
SETS = {s.name: s for s in (TUNING_FINE, VALID_FINE, PYBULLET, MAP, PAIR, PAIR2, VALID_CAL, PAIR3, NOISE, FINESTEP)}


def _names(seed: int) -> list:
    from analysis.commands._common import parse_sequence, sequence_rng
    from transition_builder.scene import scene_from_options

    scene = scene_from_options("allen-key")
    return [scene.actions[a] for a in parse_sequence(f"random:{TILTS}", scene.actions, sequence_rng(seed))]


def make_log(fs: FineSet, i: int, trials: int | None = None) -> tuple[str, list]:
    """Log ``i`` of ``fs`` cut to ``trials`` (made once, kept): its path and action names."""
    from analysis.montecarlo import run_direct, write_poses_csv
    from benchmarks.bench_fit import _cut_log
    from transition_builder.scene import scene_from_options

    seed = fs.seed0 + i
    names = _names(seed)
    full = OUT / fs.name / f"log{i}.csv"
    full.parent.mkdir(parents=True, exist_ok=True)
    if not full.exists():
        t = time.perf_counter()
        spec = fs.friction.format(mu=fs.truths[i], seed=seed, mus=STATIC[fs.name][i] if fs.name in STATIC else None)
        scene = scene_from_options("allen-key", friction_spec=spec, engine=fs.engine, **dict(fs.settings))
        noise = f"pose:{fs.noise[i]:g},{fs.noise[i]:g}" if fs.noise else None
        res = run_direct(scene, names, fs.trials, seed=seed, workers=1, noise=noise)
        rng = np.random.default_rng([seed, 0xCA])
        p = res.poses.copy()
        p[..., :2] += rng.normal(0.0, CAMERA[0], p[..., :2].shape)
        p[..., 2] = np.mod(p[..., 2] + rng.normal(0.0, np.radians(CAMERA[1]), p[..., 2].shape), 2 * np.pi)
        write_poses_csv(full, replace(res, poses=p))
        print(f"{fs.name} log {i}: {spec}, {fs.engine}, {time.perf_counter() - t:.0f} s, faults {res.faults}",
              file=sys.stderr, flush=True)
    if trials is None or trials >= fs.trials:
        return str(full), names
    cut = full.with_name(f"log{i}_{trials}.csv")
    if not cut.exists():
        _cut_log(full, cut, trials)
    return str(cut), names


MISREAD_SHARE = 0.03


def add_misreads(src, dst, share: float, seed: int, tray=(200.0, 200.0)) -> int:
    """Copy the log ``src`` to ``dst`` with ``share`` of its ``ok`` rows' poses replaced by wild
    ones (uniform over the tray, theta uniform); returns how many were replaced."""
    import csv

    with open(src, newline="") as fh:
        rows = list(csv.reader(fh))
    head = rows[0]
    ix, iy, it, ist = (head.index(c) for c in ("x_mm", "y_mm", "theta_rad", "status"))
    ok = [k for k, r in enumerate(rows[1:], 1) if r[ist] == "ok"]
    rng = np.random.default_rng([seed, 3])
    pick = rng.choice(len(ok), int(round(share * len(ok))), replace=False)
    for k in np.sort(pick):
        r = rows[ok[k]]
        r[ix], r[iy], r[it] = (repr(float(v)) for v in (rng.uniform(0, tray[0]), rng.uniform(0, tray[1]),
                                                          rng.uniform(0, 2 * np.pi)))
    with open(dst, "w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    return len(pick)


def fit_misread(fs: FineSet, i: int, trials: int, options=(), label: str = "") -> dict:
    """``kruskal fit`` of log ``i``'s misread copy (``MISREAD_SHARE``) at ``trials``, kept."""
    from benchmarks.bench_fit import fit_file

    out = OUT / fs.name / f"fit{i}_{trials}_misread{label}.json"
    if out.exists():
        return json.loads(out.read_text())
    path, names = make_log(fs, i, trials)
    bad = pathlib.Path(path).with_name(f"log{i}_{trials}_misread.csv")
    if not bad.exists():
        add_misreads(path, bad, MISREAD_SHARE, fs.seed0 + i)
    return fit_file(bad, names, i, out, fs.truths[i], (*FIT_OPTIONS, *options), workers=1)


def fit(fs: FineSet, i: int, trials: int, options=(), label: str = "") -> dict:
    """``kruskal fit`` of log ``i`` at ``trials`` (kept as JSON; a kept fit is read back)."""
    from benchmarks.bench_fit import fit_file

    out = OUT / fs.name / f"fit{i}_{trials}{label}.json"
    if out.exists():
        return json.loads(out.read_text())
    path, names = make_log(fs, i, trials)
    return fit_file(path, names, i, out, fs.truths[i], (*FIT_OPTIONS, *options), workers=1)


def row(r: dict, i: int, trials: int) -> dict:
    """One fit's row: error, interval, coverage, goodness of fit."""
    est = r["estimate"]["mu"]
    iv = (r["interval_90"] or {}).get("mu")
    gof = r.get("goodness_of_fit", {}).get("verdict")
    return {"log": i, "trials": trials, "truth": r["truth"], "estimate": est, "error": round(est - r["truth"], 4),
            "interval_90": iv, "width": None if iv is None else round(iv[1] - iv[0], 4),
            "covered": bool(iv and iv[0] <= r["truth"] <= iv[1]), "models": len(r["models"]),
            "wall_seconds": round(r["wall_seconds"], 1), "goodness": gof,
            "dominated_by": r["trials_needed"].get("dominated_by")}


def summary(rows: list) -> dict:
    """Per log size: mean / max absolute error, coverage, mean width."""
    out = {}
    for n in sorted({r["trials"] for r in rows}):
        rs = [r for r in rows if r["trials"] == n]
        err = np.abs([r["error"] for r in rs])
        widths = [r["width"] for r in rs if r["width"] is not None]
        out[n] = {"logs": len(rs), "mean_abs_error": round(float(err.mean()), 4),
                  "max_abs_error": round(float(err.max()), 4), "covered": sum(r["covered"] for r in rs),
                  "mean_width": round(float(np.mean(widths)), 4) if widths else None}
    return out


def design_check(fs: FineSet, trials: int, label: str = "_l4", simulated: int = 200) -> list:
    """The design's predicted 90% width (the trials' term, Fisher information from the models at the
    fit's patch centre +- 0.025, all cached by the fit) beside the fit's realised trials-only width,
    for each kept fit of ``fs`` at ``trials``."""
    from analysis.fit.design import fisher_information, predicted_width
    from analysis.montecarlo import report_grid_for
    from transition_builder.builder import BuildSettings
    from transition_builder.cache import cached_build
    from transition_builder.scene import scene_from_options

    scene = scene_from_options("allen-key", engine="planar")
    grid = report_grid_for(scene, "4x4x4")
    rows = []
    for i in range(len(fs.truths)):
        path = OUT / fs.name / f"fit{i}_{trials}{label}.json"
        if not path.exists():
            continue
        r = json.loads(path.read_text())
        mus = sorted(round(c["mu"], 6) for c in r["criterion"])
        best = max(r["criterion"], key=lambda c: c["loglik"])["mu"]
        centre = min((m for m in mus if round(m - 0.025, 6) in mus and round(m + 0.025, 6) in mus),
                     key=lambda m: abs(m - best))
        models = [cached_build(scene_from_options("allen-key", friction_spec=round(m, 6), engine="planar"),
                               BuildSettings.compared(), workers=1)[0].model for m in (centre - 0.025, centre, centre + 0.025)]
        seq = [scene.actions.index(a) for a in r["sequence"]]
        info = fisher_information(models, seq, 0.025, simulated, CAMERA, np.random.default_rng([fs.seed0 + i, 4]), grid)
        tv = r["interval_90_trials_only"]["mu"]
        rows.append({"log": i, "trials": trials, "centre": centre, "information_per_trial": round(info["per_trial"], 1),
                     "predicted_width_90": predicted_width(info["per_trial"], trials),
                     "realised_trials_only_width_90": tv[1] - tv[0],
                     "realised_width_90": (r["interval_90"]["mu"][1] - r["interval_90"]["mu"][0])})
        print(json.dumps(rows[-1]), flush=True)
    return rows


def fit_pairs(fs: FineSet = PAIR, options=(), label: str = "") -> list:
    """The pair logs of ``fs`` fitted with ``--fit mu_s,mu_k`` and ``options`` (kept as
    ``fit{i}{label}.json``); one row per log."""
    from benchmarks.bench_fit import fit_file

    rows = []
    static = STATIC[fs.name]
    for i in range(len(fs.truths)):
        out = OUT / fs.name / f"fit{i}{label}.json"
        path, names = make_log(fs, i)
        r = json.loads(out.read_text()) if out.exists() else fit_file(
            path, names, i, out, fs.truths[i],
            ("--engine", "planar", "--workers", "1", "--range", "0.15..0.5", "--fit", "mu_s,mu_k",
             "--camera-noise", "0.5,0.5", *options), workers=1)
        iv = r["interval_90"] or {}
        rows.append({"log": i, "truth": [static[i], fs.truths[i]], "estimate": r["estimate"],
                     "error": [round(r["estimate"]["mu_s"] - static[i], 4), round(r["estimate"]["mu_k"] - fs.truths[i], 4)],
                     "interval_90": iv, "covered": {k: bool(iv.get(k) and iv[k][0] <= t <= iv[k][1])
                                                     for k, t in (("mu_s", static[i]), ("mu_k", fs.truths[i]))},
                     "open": (r.get("calibration") or {}).get("open"),
                     "models": len(r["models"]), "wall_seconds": round(r["wall_seconds"], 1),
                     "goodness": r["goodness_of_fit"].get("verdict")})
        print(json.dumps(rows[-1]), flush=True)
    return rows


def pair_summary(rows: list) -> dict:
    """The pair's targets: mu_k within +-0.02, mu_s within +-0.04, coverage of each and both."""
    return {"logs": len(rows),
            "mu_k_within_0.02": sum(abs(r["error"][1]) <= 0.02 for r in rows),
            "mu_s_within_0.04": sum(abs(r["error"][0]) <= 0.04 for r in rows),
            "covered_mu_s": sum(r["covered"]["mu_s"] for r in rows),
            "covered_mu_k": sum(r["covered"]["mu_k"] for r in rows),
            "covered_both": sum(r["covered"]["mu_s"] and r["covered"]["mu_k"] for r in rows),
            "mu_s_open": sum(bool(r["open"] and r["open"]["mu_s"]) for r in rows),
            "not_explained": sum(r["goodness"] == "not explained" for r in rows)}


#: ``--fit mu,noise`` options of the noise set. First (fixed before any of its logs was made): the
#: floor over 0.15..0.5 at 8 points, the noise over 0..0.5 at 6; stopped before its first fit ended
#: because a noisy model took about 3 minutes (not the 10 s measured for one at 0.2 mm): 48 of them
#: would take over 2 hours. Then (2026-11-29, before any noise fit had a result): the floor over
#: 0.15..0.45 at 4 points (0.1 apart), the noise over 0.05..0.45 at 5 (0.1 apart), 20 models.
NOISE_OPTIONS = ("--engine", "planar", "--workers", "1", "--fit", "mu,noise", "--range", "0.15..0.45", "--points", "4",
                 "--noise-range", "0.05..0.45", "--noise-points", "5", "--camera-noise", "0.5,0.5")


def fit_noise(fs: FineSet, options=(), label: str = "") -> list:
    """The noise logs fitted with ``--fit mu,noise`` (kept); one row per log."""
    from benchmarks.bench_fit import fit_file

    rows = []
    for i in range(len(fs.truths)):
        out = OUT / fs.name / f"fit{i}{label}.json"
        path, names = make_log(fs, i)
        r = json.loads(out.read_text()) if out.exists() else fit_file(
            path, names, i, out, fs.truths[i], (*NOISE_OPTIONS, *options), workers=1)
        iv = r["interval_90"] or {}
        est = r["estimate"]
        sigma = fs.noise[i]
        rows.append({"log": i, "truth": {"mu": fs.truths[i], "noise": sigma}, "estimate": est,
                     "error_mu": round(est["mu"] - fs.truths[i], 4),
                     "noise_relative_error": round((est["noise"] - sigma) / sigma, 3),
                     "interval_90": iv,
                     "covered": {k: bool(iv.get(k) and iv[k][0] <= t <= iv[k][1])
                                 for k, t in (("mu", fs.truths[i]), ("noise", sigma))},
                     "models": len(r["models"]), "wall_seconds": round(r["wall_seconds"], 1),
                     "goodness": r["goodness_of_fit"].get("verdict")})
        print(json.dumps(rows[-1]), flush=True)
    return rows


def noise_summary(rows: list) -> dict:
    """The noise's target: sigma within +-30%; the floor's error; coverage."""
    return {"logs": len(rows), "noise_within_30pct": sum(abs(r["noise_relative_error"]) <= 0.3 for r in rows),
            "mu_within_0.02": sum(abs(r["error_mu"]) <= 0.02 for r in rows),
            "mean_abs_error_mu": round(float(np.mean([abs(r["error_mu"]) for r in rows])), 4),
            "covered_mu": sum(r["covered"]["mu"] for r in rows),
            "covered_noise": sum(r["covered"]["noise"] for r in rows),
            "not_explained": sum(r["goodness"] == "not explained" for r in rows)}


DESIGN_CHECK = FineSet("design", (0.39, 0.351, 0.355), 6300, trials=200)
DESIGN_CHECK2 = FineSet("design2", (0.399, 0.31, 0.398), 6400, trials=200)


def _design_sequences(at: str = "0.3") -> dict:
    """The recommended and the first random candidate of ``fit --design`` at its defaults, seed 0."""
    import contextlib
    import io

    from analysis.cli import main as cli

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert cli(["fit", "--design", "--shape", "allen-key", "--engine", "planar", "--workers", "1",
                    "--sequences", "4", "--seed", "0", "--at", at, "--json"]) == 0
    d = json.loads(buf.getvalue())
    return {"recommended": d["recommended"]["sequence"], "random": d["candidates"][0]["sequence"]}


def design_logs(fs: FineSet = DESIGN_CHECK, at: str = "0.3") -> list:
    """``fs`` (DESIGN_CHECK, DESIGN_CHECK2): each truth logged along the recommended and a random
    sequence of the design made at ``at``, each fitted."""
    from analysis.montecarlo import run_direct, write_poses_csv
    from benchmarks.bench_fit import fit_file
    from transition_builder.scene import scene_from_options

    seqs = _design_sequences(at)
    rows = []
    for i, mu in enumerate(fs.truths):
        for kind, names in seqs.items():
            d = OUT / fs.name
            d.mkdir(parents=True, exist_ok=True)
            path, out = d / f"log{i}_{kind}.csv", d / f"fit{i}_{kind}.json"
            if not path.exists():
                scene = scene_from_options("allen-key", friction_spec=mu, engine="planar")
                res = run_direct(scene, names, fs.trials, seed=fs.seed0 + i, workers=1)
                rng = np.random.default_rng([fs.seed0 + i, 0xCA])
                p = res.poses.copy()
                p[..., :2] += rng.normal(0.0, CAMERA[0], p[..., :2].shape)
                p[..., 2] = np.mod(p[..., 2] + rng.normal(0.0, np.radians(CAMERA[1]), p[..., 2].shape), 2 * np.pi)
                write_poses_csv(path, replace(res, poses=p))
            r = json.loads(out.read_text()) if out.exists() else fit_file(
                path, names, i, out, mu, (*FIT_OPTIONS, "--local", "4", "--camera-noise", "0.5,0.5"), workers=1)
            iv, tv = r["interval_90"]["mu"], r["interval_90_trials_only"]["mu"]
            rows.append({"log": i, "kind": kind, "truth": mu, "estimate": r["estimate"]["mu"],
                         "error": round(r["estimate"]["mu"] - mu, 4), "width": iv[1] - iv[0],
                         "covered": iv[0] <= mu <= iv[1], "trials_only_width": tv[1] - tv[0],
                         "goodness": r["goodness_of_fit"]["verdict"], "wall_seconds": round(r["wall_seconds"], 1)})
            print(json.dumps(rows[-1]), flush=True)
    return rows


def markdown(name: str, label: str = "") -> str:
    """The kept summary ``summary{label}.json`` of set ``name`` as a markdown table (rows and totals)."""
    d = json.loads((OUT / name / f"summary{label}.json").read_text())
    rows, out = d["rows"], []
    if "noise_relative_error" in rows[0]:
        out += ["| log | truth mu / sigma | estimate mu / sigma | error mu | sigma error | 90% mu | 90% sigma | goodness | models | seconds |",
                "|---|---|---|---|---|---|---|---|---|---|"]
        for r in rows:
            iv = r["interval_90"] or {}
            out.append(f"| {r['log']} | {r['truth']['mu']:g} / {r['truth']['noise']:g} | {r['estimate']['mu']:.4g} / "
                       f"{r['estimate']['noise']:.4g} | {r['error_mu']:+.4f} | {100 * r['noise_relative_error']:+.0f}% | "
                       f"{_iv(iv.get('mu'), r['covered']['mu'])} | {_iv(iv.get('noise'), r['covered']['noise'])} | "
                       f"{r['goodness']} | {r['models']} | {r['wall_seconds']:.0f} |")
    elif "error" in rows[0] and isinstance(rows[0]["error"], list):
        out += ["| log | truth mu_s / mu_k | estimate | error mu_s / mu_k | 90% mu_s | 90% mu_k | mu_s pinned | goodness | models | seconds |",
                "|---|---|---|---|---|---|---|---|---|---|"]
        for r in rows:
            iv = r["interval_90"] or {}
            pinned = "-" if r["open"] is None else ("no" if r["open"]["mu_s"] else "yes")
            out.append(f"| {r['log']} | {r['truth'][0]:g} / {r['truth'][1]:g} | {r['estimate']['mu_s']:.4f} / "
                       f"{r['estimate']['mu_k']:.4f} | {r['error'][0]:+.4f} / {r['error'][1]:+.4f} | "
                       f"{_iv(iv.get('mu_s'), r['covered']['mu_s'])} | {_iv(iv.get('mu_k'), r['covered']['mu_k'])} | "
                       f"{pinned} | {r['goodness']} | {r['models']} | {r['wall_seconds']:.0f} |")
    else:
        out += ["| log | trials | truth | estimate | error | 90% interval (width) | covers | goodness | models | seconds |",
                "|---|---|---|---|---|---|---|---|---|---|"]
        for r in rows:
            iv = r["interval_90"]
            ivt = "-" if iv is None else f"{iv[0]:.4f}..{iv[1]:.4f} ({r['width']:.4f})"
            out.append(f"| {r['log']} | {r['trials']} | {r['truth']:g} | {r['estimate']:.4f} | {r['error']:+.4f} | {ivt} | "
                       f"{'yes' if r['covered'] else '**no**'} | {r['goodness']} | {r['models']} | {r['wall_seconds']:.0f} |")
    out.append("")
    out.append("Totals: `" + json.dumps(d["summary"]) + "`")
    return "\n".join(out)


def _iv(iv, covered) -> str:
    if not iv:
        return "-"
    return f"{iv[0]:.3f}..{iv[1]:.3f}" + ("" if covered else " (**misses**)")


#: the ninth session's kept summaries gathered into ``benchmarks/data/fit_calibration.json``: (set, label).
CALIBRATION_SUMMARIES = (("tuning", "_cal8"), ("valid3", "_cal8"), ("valid3", "_l4"), ("pair", "_cal9"),
                         ("pair3", "_cal9"), ("noise", ""), ("finestep", "_cal8"))


def collect() -> dict:
    """The kept summaries of :data:`CALIBRATION_SUMMARIES` in one file (what docs/log/fit-calibration.md shows)."""
    out = {}
    for name, label in CALIBRATION_SUMMARIES:
        path = OUT / name / f"summary{label}.json"
        if path.exists():
            out[f"{name}{label}"] = json.loads(path.read_text())
    dst = HERE / "data" / "fit_calibration.json"
    dst.write_text(json.dumps(out, indent=1) + "\n")
    return out


def main(argv) -> None:
    if argv[0] == "collect":
        print(", ".join(collect()))
        return
    if argv[0] == "table":
        print(markdown(argv[1], argv[2] if len(argv) > 2 else ""))
        return
    if argv[0] in ("designcheck", "designcheck2"):
        fs, at = (DESIGN_CHECK, "0.3") if argv[0] == "designcheck" else (DESIGN_CHECK2, "0.2,0.3,0.4")
        rows = design_logs(fs, at)
        (OUT / fs.name / "summary.json").write_text(json.dumps(rows, indent=1))
        return
    extra = ()
    if "--" in argv:
        k = argv.index("--")
        argv, extra = argv[:k], tuple(argv[k + 1:])
    label = os.environ.get("FIT_FINE_LABEL", "")
    if argv[0] in ("pair", "pair2", "pair3"):
        fs = SETS[argv[0]]
        (OUT / fs.name).mkdir(parents=True, exist_ok=True)
        rows = fit_pairs(fs, extra, label)
        (OUT / fs.name / f"summary{label}.json").write_text(json.dumps({"rows": rows, "summary": pair_summary(rows)}, indent=1))
        print(json.dumps(pair_summary(rows)), flush=True)
        return
    if argv[0] == "noise":
        rows = fit_noise(NOISE, extra, label)
        (OUT / NOISE.name / f"summary{label}.json").write_text(json.dumps({"rows": rows, "summary": noise_summary(rows)}, indent=1))
        print(json.dumps(noise_summary(rows)), flush=True)
        return
    if argv[0] == "design":
        rows = design_check(SETS[argv[1]], int(argv[2]))
        (OUT / argv[1] / f"design_{argv[2]}.json").write_text(json.dumps(rows, indent=1))
        return
    part, misread = argv[0], argv[1].endswith("-misread")
    fs = SETS[argv[1].removesuffix("-misread")]
    sizes = tuple(int(v) for v in argv[2:]) or ((fs.trials,) if fs.trials < 1000 else SIZES)
    rows = []
    for i in range(len(fs.truths)):
        if part == "logs":
            make_log(fs, i)
            continue
        for n in sizes:
            rows.append(row((fit_misread if misread else fit)(fs, i, n, extra, label), i, n))
            print(json.dumps(rows[-1]), flush=True)
    if rows:
        s = summary(rows)
        print(json.dumps(s), flush=True)
        (OUT / fs.name / f"summary{'_misread' if misread else ''}{label}.json").write_text(json.dumps({"rows": rows, "summary": s}, indent=1))


if __name__ == "__main__":
    main(sys.argv[1:])
