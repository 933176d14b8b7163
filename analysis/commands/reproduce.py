"""``kruskal reproduce``: the paper's experiments A, B, C and what it could not do, as a report.

Runs :func:`analysis.reproduce.reproduce` and writes ``DIR/index.md`` with figures and
``DIR/results.json`` (:mod:`analysis.report`). ``--quick`` (what ``make run`` runs) uses coarse
models and few trials and takes minutes; without it the run has the paper's scale (the committed
report under ``reports/``; about an hour on 2 cores when the key's model is cached).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys

from analysis.commands._common import add_contact, add_seed, check_positive, check_writable_dir, physics_changes


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--quick", action="store_true",
                        help="coarse models, 3 triangles, 3 friction maps, few trials (minutes)")
    parser.add_argument("--out", required=True, metavar="DIR", help="directory of the report (index.md)")
    add_seed(parser)
    add_contact(parser)
    parser.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")


def run(args: argparse.Namespace) -> dict:
    from analysis.report import write_report
    from analysis.reproduce import ReproduceSettings, reproduce

    if args.workers is not None:
        check_positive(args.workers, "--workers")
    check_writable_dir(args.out, "--out")
    physics = physics_changes(args)           # --contact, --engine: checked before any work
    settings = (ReproduceSettings.quick_settings(args.seed) if args.quick
                else ReproduceSettings.full(args.seed))
    settings = dataclasses.replace(settings, **physics)

    def progress(text):
        print(f"reproduce: {text}", file=sys.stderr, flush=True)

    result = reproduce(settings, workers=args.workers, progress=progress)
    paths = write_report(result, args.out)
    a = result["A"]
    return {"report": paths["report"], "figures": paths["figures"], "quick": args.quick,
            "contact": next(iter(result["contact_models"])),
            "engine": result["engine"],
            "A_converged": a["converged"], "A_sequences": a["of"], "A_best_sequence": a["best_sequence"],
            "B_converged": result["B"]["converged"], "B_parts": len(result["B"]["parts"]),
            "sync_word": result["key_metrics"]["sync_word"],
            "model_mean_abs_error_bits": result["validation"]["mean_abs_error_bits"]}
