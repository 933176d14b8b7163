"""The ranking's stability over a friction interval, in resumable pieces (docs/ranges.md).

``kruskal rank --shapes <the report's 19 parts> --friction 0.2..0.4 --range-points 2`` builds 38
models; this module builds them one at a time with exactly ``rank``'s scenes and settings
(:func:`analysis.commands.rank.scenes_and_settings`), so that the final ``rank`` call finds every
model in the cache, and records each build's time.

Usage (``PYTHONPATH=. KRUSKAL_CACHE=...``)::

    python -m benchmarks.bench_ranges status [RANK OPTIONS]           # which models are cached
    python -m benchmarks.bench_ranges build SPEC MU [RANK OPTIONS]    # one model (resumes a checkpoint)
    python -m benchmarks.bench_ranges next MU [RANK OPTIONS]          # the first missing part at MU
    python -m benchmarks.bench_ranges plan-models                     # the two plans under the key's models
    python -m benchmarks.bench_ranges summarise                       # results/ranges -> data/ranges + tables

RANK OPTIONS are ``rank``'s build options (default :data:`OPTIONS`); build times are appended to
``benchmarks/results/ranges/builds.jsonl``.
"""
from __future__ import annotations

import json
import pathlib
import sys
import time

#: the report's ranking (reports/full/ranking.md): the key, 15 random triangles, a square, an
#: equilateral triangle and a U
PARTS = ("allen-key", *(f"triangle:{i}" for i in range(1, 16)), "rectangle:40x40",
         "polygon:0,0;50,0;25,43.30127", "polygon:0,0;60,0;60,40;45,40;45,15;15,15;15,40;0,40")
#: the build options of the ranking over 0.2..0.4 (docs/ranges.md says why not the report's)
OPTIONS = ("--resolution", "2,2", "--recenter-rounds", "1", "--start-samples", "2000", "--seed", "0")
OUT = pathlib.Path(__file__).parent / "results" / "ranges"


def _scenes(mu: str, options=OPTIONS, parts=PARTS):
    from analysis.cli import build_parser
    from analysis.commands.rank import scenes_and_settings

    args = build_parser().parse_args(["rank", "--shapes", *parts, "--friction", str(mu), *options])
    return scenes_and_settings(args)


def status(options=OPTIONS, mus=("0.2", "0.4")) -> dict:
    """Per friction: which of the parts' models are in the cache (by ``rank``'s build key)."""
    import os

    from transition_builder.builder import build_key
    from transition_builder.cache import cache_dir

    out = {}
    for mu in mus:
        scenes, settings = _scenes(mu, options)
        out[mu] = {spec: os.path.exists(os.path.join(cache_dir(), f"{build_key(sc, settings)}.npz"))
                   for spec, sc in scenes.items()}
    return out


def build(spec: str, mu: str, options=OPTIONS, workers: int = 2) -> dict:
    """Build (or find) one part's model at ``mu`` with ``rank``'s settings; its time is recorded."""
    from transition_builder.cache import cached_build

    scenes, settings = _scenes(mu, options, parts=(spec,))
    t = time.perf_counter()
    res, path, cached = cached_build(scenes[spec], settings, workers=workers)
    row = {"shape": spec, "mu": mu, "options": list(options), "cached": cached, "states": res.model.n_states,
           "wall_seconds": round(time.perf_counter() - t, 1), "path": path,
           "recorded_build_seconds": res.stats.get("seconds", res.stats.get("build_seconds"))}
    OUT.mkdir(parents=True, exist_ok=True)
    with open(OUT / "builds.jsonl", "a") as f:
        f.write(json.dumps(row) + "\n")
    return row


def plan_on_models(interval: str = "0.2..0.4", points: int = 5, single: str = "0.3") -> dict:
    """The key's robust plan over ``interval`` and the single-mu optimum at ``single`` (``plan``'s
    search and defaults, target ``cell``), each propagated through every model of the interval:
    the mass in the plan's own cell, and the best cell and its mass (models cached: seconds)."""
    import numpy as np

    from analysis.friction_range import models_over_range, parse_friction_range, plan_cell
    from kruskal_markov.entropy import propagate
    from kruskal_markov.sync.plan import shortest_plan
    from kruskal_markov.sync.targets import parse_target
    from transition_builder.scene import scene_from_options

    models = models_over_range(scene_from_options("allen-key"), parse_friction_range(interval), points)
    at = [m for spec, m, _ in models if float(spec) == float(single)]
    out = {}
    for name, ms in ((f"robust {interval}", [m for _, m, _ in models]), (f"single mu {single}", at)):
        res = shortest_plan(ms, parse_target("cell")).to_dict()
        cell = plan_cell(res["final_cell"])
        rows = {}
        for spec, m, _ in models:
            mass = np.bincount(np.asarray(m.partition), weights=propagate(m, res["word"])[-1], minlength=m.n_cells)
            rows[spec] = {"states": m.n_states, "mass_in_plan_cell": round(float(mass[cell]), 4),
                          "best_cell": int(mass.argmax()), "mass_in_best_cell": round(float(mass.max()), 4)}
        out[name] = {"word": res["word"], "length": res["length"], "exact": res["exact"], "cell": cell,
                     "on_models": rows}
    return out


def _load(path):
    try:
        return json.loads(pathlib.Path(path).read_text())
    except (OSError, ValueError):
        return None


def summarise_replay(results=OUT) -> list:
    """The replay's rows (``plan_{robust,single}_{MU}.json`` of the driver, one coefficient each)."""
    rows = []
    for f in sorted(pathlib.Path(results).glob("plan_*_*.json")):
        d = _load(f)
        if not d:
            continue
        plan = f.stem.split("_")[1]
        for r in d["friction_range"].get("between_points", []):
            rows.append({"plan": plan, "word": d["word"], "length": d["length"], "exact": d["exact"], **r})
    return sorted(rows, key=lambda r: (r["mu"], r["plan"]))


def summarise_rank(results=OUT, ends=("0.2", "0.4")) -> dict | None:
    """``rank --friction LO..HI --range-points 2``'s summary from the two ends' rankings."""
    from analysis.friction_range import rankings_over_range

    outs = [_load(pathlib.Path(results) / f"rank_{mu}.json") for mu in ends]
    if not all(outs):
        return None
    summary = rankings_over_range(list(ends), [o["ranking"] for o in outs])
    summary["rankings"] = {mu: [{k: r.get(k) for k in _RANK_KEYS} for r in o["ranking"]] for mu, o in zip(ends, outs)}
    summary["seconds"] = {mu: o.get("seconds") for mu, o in zip(ends, outs)}
    return summary


#: the ranking rows' keys kept in ``data/ranges/rank.json`` (the full rows stay in ``results/``)
_RANK_KEYS = ("shape", "rank", "decided_by", "states", "sync_length", "sync_exact", "random_tilts", "random_tilts_lower",
              "random_tilts_ci95", "random_tilts_censored", "converging_share_50", "mean_entropy_50")


def _tilts(row) -> str:
    from analysis.orientability import random_tilts_text

    return random_tilts_text(row)


def summarise_builds(results=OUT, options=OPTIONS) -> list:
    """The ranking models' builds at ``options`` (``builds.jsonl``; the last fresh build of each
    part and coefficient; a cache hit is not a build time)."""
    rows = {}
    path = pathlib.Path(results) / "builds.jsonl"
    for line in path.read_text().splitlines() if path.exists() else []:
        r = json.loads(line)
        if tuple(r["options"]) == tuple(options) and not r["cached"]:
            rows[(r["shape"], r["mu"])] = {k: r[k] for k in ("shape", "mu", "states", "wall_seconds")}
    return sorted(rows.values(), key=lambda r: (PARTS.index(r["shape"]) if r["shape"] in PARTS else 99, r["mu"]))


def _print_builds(builds) -> None:
    by = {(r["shape"], r["mu"]): r for r in builds}
    print("| part | states 0.2 / 0.4 | build wall s 0.2 / 0.4 |")
    print("|---|---|---|")
    for shape in PARTS:
        a, b = by.get((shape, "0.2")), by.get((shape, "0.4"))
        st = " / ".join(str(r["states"]) if r else "-" for r in (a, b))
        ws = " / ".join(f"{r['wall_seconds']:.0f}" if r else "-" for r in (a, b))
        print(f"| {shape} | {st} | {ws} |")
    print(f"{len(builds)} builds, {sum(r['wall_seconds'] for r in builds):.0f} s wall in all")


def summarise(results=OUT, data=pathlib.Path(__file__).parent / "data" / "ranges") -> None:
    """Copy the small results to ``benchmarks/data/ranges/`` and print the doc's tables."""
    data.mkdir(parents=True, exist_ok=True)
    builds = summarise_builds(results)
    if builds:
        (data / "rank_builds.json").write_text(json.dumps(builds, indent=1))
        _print_builds(builds)
    replay = summarise_replay(results)
    if replay:
        (data / "replay.json").write_text(json.dumps(replay, indent=1))
        print("| mu | plan | in cell / M | share | Wilson 95% | faulted | modal cell (share) |")
        print("|---|---|---|---|---|---|---|")
        for r in replay:
            ci = r["share_in_cell_ci95"]
            print(f"| {r['mu']:g} | {r['plan']} ({r['length']}) | {r['in_cell']} / {r['trials']} | "
                  f"{r['share_in_cell']:.3f} | {ci[0]:.3f}-{ci[1]:.3f} | {r['faulted']} | "
                  f"{r['modal_cell']} ({r['share_in_modal_cell']:.3f}) |")
    rank = summarise_rank(results)
    if rank:
        (data / "rank.json").write_text(json.dumps(rank, indent=1))
        print(f"Kendall tau {rank['kendall_tau_ends']:.3f}; {len(rank['orders_that_hold'])} orders hold, "
              f"{len(rank['orders_that_flip'])} flip")
        lo, hi = (dict((r["shape"], r) for r in rank["rankings"][mu]) for mu in ("0.2", "0.4"))
        print("| part | rank at 0.2 | rank at 0.4 | expected random tilts 0.2 / 0.4 | converging 0.2 / 0.4 |")
        print("|---|---|---|---|---|")
        for s in sorted(rank["rank_range"], key=lambda k: (lo[k]["rank"], k)):
            print(f"| {s} | {lo[s]['rank']} | {hi[s]['rank']} | {_tilts(lo[s])} / {_tilts(hi[s])} | "
                  f"{lo[s]['converging_share_50']:.0%} / {hi[s]['converging_share_50']:.0%} |")


def main(argv) -> None:
    part, rest = argv[0], argv[1:]
    if part == "status":
        st = status(tuple(rest) or OPTIONS)
        print(json.dumps({mu: [s for s, ok in v.items() if not ok] for mu, v in st.items()}))
        print({mu: f"{sum(v.values())}/{len(v)} cached" for mu, v in st.items()})
    elif part == "build":
        print(json.dumps(build(rest[0], rest[1], tuple(rest[2:]) or OPTIONS)), flush=True)
    elif part == "next":
        mu, opts = rest[0], tuple(rest[1:]) or OPTIONS
        missing = [s for s, ok in status(opts, (mu,))[mu].items() if not ok]
        if missing:
            print(json.dumps(build(missing[0], mu, opts)), flush=True)
        else:
            print("none missing", flush=True)
    elif part == "summarise":
        summarise()
    elif part == "plan-models":
        print(json.dumps(plan_on_models(), indent=1))
    else:
        raise SystemExit(f"unknown part {part!r}: status, build, next or plan-models")


if __name__ == "__main__":
    main(sys.argv[1:])
