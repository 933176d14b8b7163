"""Kits and trays (docs/kits.md): the three-part kit's common plan, its replay, and the key's tray design.

Runs the documented command lines in this process, one after the other, and appends every run's
JSON (with its command line, the date and the commit) to ``benchmarks/data/kits.jsonl``::

    PYTHONPATH=. python -m benchmarks.bench_kits kit [--resolution 1,1] [--workers 1]
    PYTHONPATH=. python -m benchmarks.bench_kits check [--resolution 1,1] [--workers 1]
    PYTHONPATH=. python -m benchmarks.bench_kits design [--resolution 2,2] [--start-samples 500] [--workers 1]

``kit`` runs ``plan --kit`` (cell target), then ``simulate --kit`` of the plan with 1,000 trials
per compartment (the replay, and the animation ``docs/kits_animation.gif``), then ``ensemble
--kit`` and ``convergence --kit --epsilon 0.001``; ``design`` runs the key's sweep over trays of
80-200 mm and tilts of 20-40 degrees (12 variants). Times are wall times on this machine (2 cores,
shared when the note says so).
"""
from __future__ import annotations

import datetime
import io
import json
import os
import pathlib
import subprocess
import sys
from contextlib import redirect_stdout

ROOT = pathlib.Path(__file__).resolve().parent.parent
KIT = str(ROOT / "docs" / "kit_three_parts.json")
OUT = pathlib.Path(__file__).parent / "data" / "kits.jsonl"


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


#: the commit of the code that runs (read once, at import: a later commit does not change the running code)
COMMIT = _commit()


def run(argv: list[str]) -> dict:
    """Run ``kruskal ARGV --json`` here; record and return its JSON."""
    from analysis.cli import main

    buf = io.StringIO()
    with redirect_stdout(buf):
        code = main([*argv, "--json"])
    if code != 0:
        raise SystemExit(f"kruskal {' '.join(argv)} exited {code}")
    out = json.loads(buf.getvalue())
    OUT.parent.mkdir(parents=True, exist_ok=True)
    from transition_builder.cache import cache_dir
    line = json.dumps({"command": "kruskal " + " ".join(argv), "commit": COMMIT,
                       "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                       "result": out})
    # no machine's paths in committed data: models by their cache key, files relative to the checkout
    line = line.replace(os.path.join(cache_dir(), ""), "").replace(str(ROOT) + "/", "")
    with open(OUT, "a", encoding="utf-8") as fh:
        fh.write(line + "\n")
    return out


def _workers(options: list[str]) -> list[str]:
    """The ``--workers W`` of ``options`` (simulate takes no build options)."""
    return next((["--workers", options[i + 1]] for i, o in enumerate(options[:-1]) if o == "--workers"), [])


def kit(options: list[str]) -> None:
    """The three-part kit: common plan, replay (with the animation), ensemble, convergence."""
    plan = run(["plan", "--kit", KIT, "--target", "cell", *options])
    print(f"plan {plan['word']} length {plan['length']} exact {plan['exact']} lower {plan['lower_bound']}; own "
          f"{[(p['name'], p['length'], p['exact']) for p in plan['per_compartment']]} ({plan['seconds']:.0f} s)")
    if plan["word"]:
        sim = run(["simulate", "--kit", KIT, "--sequence", ",".join(plan["word"]), "--trials", "1000", "--seed", "1",
                   "--animation", str(ROOT / "docs" / "kits_animation.gif"), *_workers(options)])
        for c, cell in zip(sim["compartments"], plan["final_cell"]):
            print(f"  replay {c['name']}: {c['final_cells'].get(str(cell), c['final_cells'].get(cell, 0))} of "
                  f"{sim['trials']} in cell {cell}; entropy {c['entropy_bits'][-1]:.3f} ({sim['seconds']:.0f} s)")
    ens = run(["ensemble", "--kit", KIT, "--count", "2000", "--length", "50", "--epsilon", "0.001", *options])
    print(f"ensemble: {ens['converged']} of 2000 converge ({ens['seconds']:.0f} s)")
    conv = run(["convergence", "--kit", KIT, "--runs", "1000", "--epsilon", "0.001", *options])
    print(f"convergence: {conv['expected_length']} / tilts {conv['entropy_tilts']} ({conv['seconds']:.0f} s)")


def check(options: list[str]) -> None:
    """The independence the kit answers use, checked: one random 50-tilt sequence through the kit,
    the models' kit entropy (the sum of the compartments' predictions) against direct simulation
    (the sum of the compartments' simulated entropies), 300 trials per compartment."""
    from analysis.cli import build_parser
    from analysis.commands._kit import build_settings
    from analysis.kit import kit_models, load_kit
    from kruskal_markov.entropy import entropy_trajectory

    sim = run(["simulate", "--kit", KIT, "--sequence", "random:50", "--seed", "2", "--trials", "300",
               *_workers(options)])
    args = build_parser().parse_args(["plan", "--kit", KIT, *options])
    comps = kit_models(load_kit(KIT), build_settings(args), workers=args.workers)
    model = [sum(h) for h in zip(*(entropy_trajectory(c["model"], sim["sequence"]).entropy_bits for c in comps))]
    err = [abs(a - b) for a, b in zip(model, sim["entropy_bits"])]
    first = [next((t for t, h in enumerate(c["entropy_bits"]) if h <= 1e-3), None) for c in sim["compartments"]]
    print(f"kit entropy along random:50 (seed 2): mean |model - direct| {sum(err[1:]) / 50:.3f} bits, max "
          f"{max(err):.3f}; final model {model[-1]:.3f} / direct {sim['entropy_bits'][-1]:.3f} bits; "
          f"first step <= 1e-3 per compartment (direct) {first}")
    own = own_replays(comps, args.workers)
    with open(OUT, "a", encoding="utf-8") as fh:
        fh.write(json.dumps({"command": "model kit entropy along the same sequence", "commit": COMMIT,
                             "model_entropy_bits": model, "direct_entropy_bits": sim["entropy_bits"]}) + "\n")
        fh.write(json.dumps({"command": "each compartment's own plan replayed (1,000 trials, seed 1)",
                             "commit": COMMIT, "result": own}) + "\n")


def own_replays(comps, workers) -> list:
    """Each compartment's own shortest cell plan replayed alone (1,000 trials, seed 1): does a part
    miss its cell under the common plan only, or under its own plan too?"""
    from analysis.kit_replay import replay_plan
    from kruskal_markov.sync.plan import shortest_plan

    out = []
    for c in comps:
        p = shortest_plan(c["model"], "cell")
        rep = replay_plan([c["scene"]], [c["name"]], list(p.word), [p.final_cell], [p.success_probability], 1000,
                          seed=1, workers=workers)
        row = rep["compartments"][0]
        out.append({"name": c["name"], "word": list(p.word), "model_success": row["model_success"],
                    "share": row["share"], "share_ci95": row["share_ci95"]})
        print(f"  own plan of {c['name']} ({','.join(p.word)}): {row['share']:.3f} in its cell "
              f"(model {row['model_success']:.3f})")
    return out


def design(options: list[str]) -> None:
    """The key's tray design: 4 tray sizes x 3 tilts."""
    out = run(["design", "--shape", "allen-key", "--tray-mm", "80..200:4", "--tilt-deg", "20..40:3",
               "--figure", str(ROOT / "docs" / "kits_design.png"), *options])
    for i, v in enumerate(out["variants"]):
        print(i, v["tray_mm"], v["tilt_deg"], v["plan_length"], v["exact"], v["lower_bound"],
              round(v["converging_share"], 3), v["expected_tilts"], round(v["seconds"]))
    print("best", out["best"], "pareto", out["pareto"], "reference", out["reference"], f"{out['seconds']:.0f} s")


if __name__ == "__main__":
    what, rest = sys.argv[1], sys.argv[2:]
    {"kit": kit, "check": check, "design": design}[what](rest)
