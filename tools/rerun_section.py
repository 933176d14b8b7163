"""Re-run one section of an existing report in place, with the settings that report was written with.

A report (``kruskal reproduce``) is regenerated whole; that costs two hours at the full scale. When
one section's code changes, this tool re-runs that section alone (and what it needs, on cached
models), replaces its entries in ``results.json``, its text in ``index.md`` (from its heading to the
next section's heading) and its figures, and leaves every other section as it was. The settings
are read back from the report's own ``results.json``, so the section runs exactly as the full run
would have. ``docs/results.md`` must say which sections were re-run this way, at which commit.

A section that simulates nothing (it only reads other sections' results, e.g. ``differences``)
defines ``from_saved(saved_results, report_dir)``; ``--from-saved`` renders it from the saved
``results.json`` without running any section, so it reads exactly the numbers the report shows.

Usage::

    python tools/rerun_section.py --out reports/full --section tray_log [--workers 2]
    python tools/rerun_section.py --out reports/full --section differences --from-saved
    python tools/rerun_section.py --out reports/full --section engines --before "## NEXT HEADING"
"""
from __future__ import annotations

import argparse
import dataclasses
import importlib
import json
import os
import sys

from analysis.commands import strict_json
from analysis.experiments import EXPERIMENTS
from analysis.experiments.runner import run_experiments
from analysis.reproduce import ReproduceSettings
from kruskal_markov.model import atomic_write_text


def settings_from_results(saved: dict) -> ReproduceSettings:
    """The :class:`ReproduceSettings` a ``results.json`` was written with (JSON lists back to tuples)."""
    fields = {f.name: f for f in dataclasses.fields(ReproduceSettings)}
    unknown = sorted(set(saved) - set(fields))
    if unknown:
        raise ValueError(f"results.json has settings this code does not know: {', '.join(unknown)}")
    default = ReproduceSettings.full()

    def like(value, template):
        if isinstance(template, tuple) and isinstance(value, list):
            inner = template[0] if template else None
            return tuple(like(v, inner) for v in value)
        return value

    return dataclasses.replace(default, **{k: like(v, getattr(default, k)) for k, v in saved.items()})


def splice_section(index_text: str, new_text: str, before: str | None = None) -> str:
    """``index_text`` with the section that starts at ``new_text``'s heading replaced by ``new_text``; a
    section the report does not have yet goes in just before the heading ``before`` (a section added to
    the registry after the report was written)."""
    heading = new_text.splitlines()[0]
    if not heading.startswith("## "):
        raise ValueError(f"a section must start with a '## ' heading, got {heading!r}")
    lines = index_text.splitlines()
    if heading not in lines and before == "END":
        return "\n".join(lines + [""] + new_text.rstrip("\n").splitlines()) + "\n"
    if heading not in lines and before is not None:
        if before not in lines:
            raise ValueError(f"the report has no section {before!r} to put {heading!r} before")
        at = lines.index(before)
        return "\n".join(lines[:at] + new_text.rstrip("\n").splitlines() + [""] + lines[at:]) + "\n"
    try:
        start = lines.index(heading)
    except ValueError:
        raise ValueError(f"the report has no section {heading!r}") from None
    end = next((i for i in range(start + 1, len(lines)) if lines[i].startswith("## ")), len(lines))
    return "\n".join(lines[:start] + new_text.rstrip("\n").splitlines() + [""] + lines[end:]) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="the report directory (index.md, results.json)")
    ap.add_argument("--section", required=True, choices=sorted(EXPERIMENTS))
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--from-saved", action="store_true",
                    help="render the section from the saved results.json (sections with from_saved only)")
    ap.add_argument("--before", default=None, metavar="HEADING",
                    help="a section the report does not have yet goes in before this heading (e.g. '## B: other parts'; END: at the end)")
    args = ap.parse_args(argv)
    results_path, index_path = (os.path.join(args.out, n) for n in ("results.json", "index.md"))
    try:
        with open(results_path) as f:
            saved = json.load(f)
        with open(index_path) as f:
            index_text = f.read()
        settings = settings_from_results(saved["settings"])
    except (OSError, ValueError, KeyError) as exc:
        print(f"rerun_section: {exc}", file=sys.stderr)
        return 2
    module = importlib.import_module(EXPERIMENTS[args.section])
    if args.from_saved:
        if not hasattr(module, "from_saved"):
            print(f"rerun_section: section {args.section!r} cannot be rendered from a saved report (it computes; "
                  "run it without --from-saved)", file=sys.stderr)
            return 2
        result, seconds = module.from_saved(saved, args.out), 0.0
    else:
        report = run_experiments(settings, workers=args.workers, only=(args.section,),
                                 progress=lambda msg: print(msg, file=sys.stderr))
        result, seconds = report.results[args.section], report.seconds
    saved.update(result.to_dict())
    text = module.markdown(result)
    try:
        new_index = splice_section(index_text, text, args.before) if text else index_text
    except ValueError as exc:
        print(f"rerun_section: {exc}", file=sys.stderr)
        return 2
    atomic_write_text(results_path, strict_json(saved, indent=1))
    figures = module.figures(result, args.out)
    atomic_write_text(index_path, new_index)
    print(json.dumps({"section": args.section, "seconds": seconds, "figures": figures}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
