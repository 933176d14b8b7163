"""Sub-commands of ``kruskal``: one module each, ``add_arguments(parser)`` and ``run(args) -> dict``."""
from __future__ import annotations


class InputError(ValueError):
    """Bad input from the user: the CLI prints its message as one line and exits with status 2."""


def strict_json(value, indent=None) -> str:
    """``json.dumps`` that writes strict JSON: NaN and infinities become ``null`` (Python's default
    writes ``NaN``/``Infinity``, which other JSON readers refuse); numpy scalars and arrays as numbers.

    >>> strict_json({"a": float("inf"), "b": [1.5, float("nan")]})
    '{"a": null, "b": [1.5, null]}'
    """
    import json
    import math

    def clean(x):
        if hasattr(x, "tolist") and not isinstance(x, (str, bytes)):
            x = x.tolist()
        if isinstance(x, float):
            return x if math.isfinite(x) else None
        if isinstance(x, dict):
            return {k: clean(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [clean(v) for v in x]
        return x

    return json.dumps(clean(value), indent=indent, allow_nan=False, default=str)


#: command name -> (module, one-line help). Order is the order shown by ``kruskal --help``.
COMMANDS: dict[str, tuple[str, str]] = {}


def register(name: str, module: str, help_text: str) -> None:
    """Add a command to :data:`COMMANDS` (used below; one line per command)."""
    COMMANDS[name] = (module, help_text)


# --- the commands (each helper adds its line here) ---------------------------------------------
register("simulate", "analysis.commands.simulate",
         "direct Monte Carlo in the physics engine (the paper's method)")
register("build", "analysis.commands.build",
         "sample the physics engine into per-action transition matrices")
register("entropy", "analysis.commands.entropy",
         "entropy after every tilt of a sequence, from a model, an automaton or recorded poses")
register("ensemble", "analysis.commands.ensemble",
         "statistics of K random sequences (the paper's Fig. 3)")
register("sync", "analysis.commands.sync", "shortest synchronizing word (optimal sensorless plan)")
register("plan", "analysis.commands.plan",
         "shortest tilt sequence that orients the part (targets state, cell, probability:E; robust plans)")
register("convergence", "analysis.commands.convergence",
         "expected length of a random synchronizing sequence")
register("validate", "analysis.commands.validate", "model prediction against direct simulation")
register("rank", "analysis.commands.rank", "orientability ranking of shapes")
register("design", "analysis.commands.design",
         "tray variants (compartment size, aspect, tilt) ranked for a part or a kit, with the Pareto front")
register("fit", "analysis.commands.fit",
         "the tray's physics (floor friction, process noise) from a pose log, with a 90% interval")
register("reproduce", "analysis.commands.reproduce", "the paper's experiments as a report")
