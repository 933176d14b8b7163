"""Do the paper-level answers converge in the time step? (issue 34, item 4; docs/simulator.md)

The allen key at the report's compared resolution (``ReproduceSettings.contact_build``: 1 mm / 1
degree, 1 recentring round, 2,000 starts) is built at 1/r of the default time step (the rest test
keeps its interval) with build seed b, for each ``r:b`` of ``KRUSKAL_BENCH_STEPS`` (default
``1:0,1:1,1:2,2:0,4:0,4:1,8:0,8:1``). Each model's answers are computed exactly as the report's
contact section computes them (:func:`analysis.experiments.model_answers.model_answers`; the
report's random streams under seed 0, 100,000 random 50-tilt sequences), so the rows of build seed 0
at r = 1 and 4 repeat the report's. Several build seeds at one step measure the build's own noise beside the step's effect.

Models come from the model cache (``kruskal build`` keys), so a rerun costs the analysis only; the
first build at 1/8 of the step takes about 6.5 minutes on 2 workers. Writes
``benchmarks/results/step_answers.json`` and prints a markdown table.
"""
from __future__ import annotations

import json
import os
import pathlib

HERE = pathlib.Path(__file__).parent
RESULTS = HERE / "results"
DEFAULT_STEPS = "1:0,1:1,1:2,2:0,4:0,4:1,8:0,8:1"
ANSWERS = ("converging_share", "mean_entropy_20", "mean_entropy_end", "random_tilts", "sync_length")


def step_answers(refine: int, build_seed: int, workers: int = 2) -> dict:
    """The report's paper-level answers of the key built at 1/``refine`` of the default step."""
    from analysis.experiments.context import Context
    from analysis.experiments.model_answers import key_metrics, model_answers
    from analysis.reproduce import ReproduceSettings

    s = ReproduceSettings(seed=0)
    ctx = Context(s, workers=workers, progress=print)
    key = ctx.scene()
    scene = key if refine == 1 else key.with_settings(**key.settings.finer_step(refine))
    model, info = ctx.build(scene, s.contact_build, f"1/{refine} step, build seed {build_seed}", build_seed=build_seed)
    answers = model_answers(ctx, model, key_metrics(ctx, model, sync_time_budget=s.sync_time_budget))
    return {**answers.to_dict(), "refine": refine, "build_seed": build_seed, "build_seconds": info.seconds,
            "cached": info.cached}


def table(rows: list[dict]) -> str:
    """One markdown row per model, then the relative differences between the steps (build seed 0)."""
    lines = ["| step | build seed | states | " + " | ".join(ANSWERS) + " |", "|---" * (len(ANSWERS) + 3) + "|"]
    for r in rows:
        lines.append(f"| 1/{r['refine']} | {r['build_seed']} | {r['states']:,} | "
                     + " | ".join(f"{r[k]:.3f}" if isinstance(r[k], float) else str(r[k]) for k in ANSWERS) + " |")
    base = {r["refine"]: r for r in rows if r["build_seed"] == 0}
    steps = sorted(base)
    for i, a in enumerate(steps):
        for b in steps[i + 1:]:
            rel = ", ".join(f"{k} {100 * abs(base[a][k] - base[b][k]) / abs(base[b][k]):.0f}%" for k in ANSWERS
                            if base[b][k])
            lines.append(f"\n1/{a} against 1/{b}: {rel}")
    return "\n".join(lines)


def main() -> None:
    spec = os.environ.get("KRUSKAL_BENCH_STEPS", DEFAULT_STEPS)
    try:
        pairs = [tuple(int(v) for v in item.split(":")) for item in spec.split(",")]
        if any(len(p) != 2 or p[0] < 1 or p[1] < 0 for p in pairs):
            raise ValueError
    except ValueError:
        raise SystemExit(f"KRUSKAL_BENCH_STEPS must be r:seed pairs (r >= 1, seed >= 0), got {spec!r}") from None
    rows = [step_answers(r, b) for r, b in pairs]
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "step_answers.json").write_text(json.dumps(rows, indent=1, default=str))
    print(table(rows))


if __name__ == "__main__":
    main()
