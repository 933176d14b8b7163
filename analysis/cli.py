"""The ``kruskal`` command line.

Each sub-command lives in its own module under :mod:`analysis.commands` and exposes
``add_arguments(parser)`` and ``run(args) -> dict``. This module adds the options every command
shares (``--json``), times the run (``"seconds"``), prints the result, and turns bad input into one
clear line on standard error with exit status 2 (see ``docs/commands.md``).
"""
from __future__ import annotations

import argparse
import importlib
import json
import math
import sys
import time
import warnings

from analysis.commands import COMMANDS, InputError, strict_json


class _OneLineParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line on standard error and exit status 2."""

    def error(self, message: str):  # noqa: D102 - argparse API
        sys.stderr.write(f"kruskal {self.prog.split()[-1]}: error: {message}\n"
                         if " " in self.prog else f"kruskal: error: {message}\n")
        sys.exit(2)


def build_parser() -> argparse.ArgumentParser:
    """Return the top-level parser with one sub-parser per command in :data:`COMMANDS`."""
    parser = _OneLineParser(prog="kruskal", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_OneLineParser)
    sub.required = True
    for name, (module_name, help_text) in COMMANDS.items():
        # argparse %-formats help strings: a literal '%' ("a 90% interval") must be doubled
        cmd = sub.add_parser(name, help=help_text.replace("%", "%%"), description=help_text)
        cmd.add_argument("--json", action="store_true",
                         help="print exactly one JSON object on standard output (logs go to stderr)")
        module = importlib.import_module(module_name)
        module.add_arguments(cmd)
        cmd.set_defaults(_module=module)
    return parser


def _json_safe(value):
    """Replace non-finite floats by None so that the output is strict JSON."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if hasattr(value, "tolist"):  # numpy scalars and arrays
        return _json_safe(value.tolist())
    return value


def _format_text(result: dict) -> str:
    lines = []
    for key, value in result.items():
        if isinstance(value, float):
            value = f"{value:.6g}"
        elif isinstance(value, list) and value and all(isinstance(v, float) for v in value):
            value = " ".join(f"{v:.4g}" for v in value)
        elif isinstance(value, (dict, list)):
            value = json.dumps(value)
        lines.append(f"{key}: {value}")
    return "\n".join(lines)


def _one_line_warning(command: str):
    """A ``warnings.showwarning`` that writes ``kruskal COMMAND: warning: ...`` as one line (no
    file name, line number or source line, which mean nothing to a user of the command)."""
    def show(message, category, filename, lineno, file=None, line=None):
        text = str(message).strip()
        text = text.splitlines()[0] if text else category.__name__
        sys.stderr.write(f"kruskal {command}: warning: {text}\n")
    return show


class Terminated(KeyboardInterrupt):
    """SIGTERM, turned into the same clean unwinding as Ctrl-C (workers shut down, files left whole)."""


def _raise_terminated(signum, frame):
    import signal

    signal.signal(signal.SIGTERM, signal.SIG_IGN)   # a second SIGTERM must not interrupt the unwinding
    raise Terminated()


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return the process exit status."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _raise_terminated)
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:   # --help, or a usage error already printed as one line
        return exc.code if isinstance(exc.code, int) else 2
    start = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _one_line_warning(args.command)
            result = args._module.run(args)
    except (InputError, ValueError, OSError) as exc:
        message = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        sys.stderr.write(f"kruskal {args.command}: error: {message}\n")
        return 2
    except Terminated:
        sys.stderr.write(f"kruskal {args.command}: terminated\n")
        return 143
    except KeyboardInterrupt:
        sys.stderr.write(f"kruskal {args.command}: interrupted\n")
        return 130
    result = dict(result)
    result["seconds"] = time.perf_counter() - start
    result = _json_safe(result)
    if args.json:
        sys.stdout.write(strict_json(result) + "\n")
    else:
        formatter = getattr(args._module, "format_text", _format_text)
        sys.stdout.write(formatter(result) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
