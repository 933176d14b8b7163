"""The build options as users see them, defined once: the command line and the docs are written from
:data:`BUILD_OPTIONS` (this module imports nothing heavy, so ``kruskal --help`` stays fast).
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["BUILD_OPTIONS", "BuildOption", "options_markdown"]


@dataclass(frozen=True)
class BuildOption:
    """One build option as users see it: the :class:`BuildSettings` field it sets, its command-line
    flag and its one-line help, which ``kruskal build --help`` and the options table of
    ``docs/builder.md`` (:func:`options_markdown`) both print.

    Attributes
    ----------
    name : str
        The :class:`BuildSettings` field.
    flag : str
        The ``kruskal build`` flag.
    type : type
        ``int``, ``float`` or ``bool`` (a ``--flag/--no-flag`` pair).
    metavar : str
        The value's name in the help.
    help : str
        One line, the default included.
    set_apart : bool
        Measured worse and off by default: kept so that the measurements in ``docs/builder.md`` can be
        reproduced, and listed apart from the others.
    """

    name: str
    flag: str
    type: type
    metavar: str
    help: str
    set_apart: bool = False


#: the options ``kruskal build`` exposes beyond the scene, noise, resolution, symmetry and seed
BUILD_OPTIONS = (
    BuildOption("samples", "--samples", int, "K",
                "samples per state and action (default 1 without noise, 4 with noise)"),
    BuildOption("start_samples", "--start-samples", int, "N",
                "uniform start poses for the first tilt (default 5000)"),
    BuildOption("grid", "--grid", str, "AxBxG", "report grid (default 4x4x4)"),
    BuildOption("theta_offset", "--theta-offset", float, "RAD",
                "theta bin offset of the report grid (default half a bin)"),
    BuildOption("max_states", "--max-states", int, "N", "stop exploring beyond this many states (default 400000)"),
    BuildOption("recenter_rounds", "--recenter-rounds", int, "R",
                "recentring rounds of a deterministic build (default 3)"),
    BuildOption("explore_weight", "--explore-weight", float, "W",
                "expand only states that hold probability >= W on some random sequence "
                "(default 0 = everything without noise, 1e-3 with noise)"),
    BuildOption("max_samples", "--max-samples", int, "KMAX",
                "noisy builds: rows of weight w >= --heavy-weight get K * w / heavy-weight samples, up to KMAX "
                "(default 128 for weighted noisy builds, else 0: off)"),
    BuildOption("heavy_weight", "--heavy-weight", float, "W",
                "the weight from which --max-samples adds samples (default 0.025)"),
    BuildOption("probes", "--probes", int, "M",
                "deterministic builds: representatives of weight >= --probe-weight tilt up to M of their members; "
                "where one lands in another report cell the row becomes the members' landings (default 4 without "
                "noise at the default tolerance or finer, else 0)"),
    BuildOption("probe_weight", "--probe-weight", float, "W",
                "the weight from which --probes probes a representative (default 0.05)"),
    BuildOption("probe_distance", "--probe-distance", float, "D",
                "with --probes, a member landing in the representative's report cell but more than D tolerance "
                "balls from its landing also makes the row sensitive (default 4 with --probes, 0 without)"),
    BuildOption("flush_side", "--flush-side", bool, "",
                "snap only between poses resting on the same end of an edge flush with a wall "
                "(default on without noise, off with noise)"),
    BuildOption("refine_rounds", "--refine-rounds", int, "R",
                "set apart, measured no better: rounds splitting a representative whose farthest member lands "
                "in another report cell (default 0)", set_apart=True),
    BuildOption("confirm_samples", "--confirm-samples", int, "K1",
                "set apart, measured worse: noisy builds top heavy rows up to K1 samples first and only those "
                "whose samples disagree on the report cell up to K (default 0: off)", set_apart=True),
)


def options_markdown() -> str:
    """The options table of ``docs/builder.md``, written from :data:`BUILD_OPTIONS`.

    Returns
    -------
    str
        A Markdown table: flag, setting, meaning; the options set apart last.
    """
    rows = ["| flag | `BuildSettings` field | meaning |", "|---|---|---|"]
    for o in sorted(BUILD_OPTIONS, key=lambda o: o.set_apart):
        flag = f"`{o.flag}/--no-{o.flag[2:]}`" if o.type is bool else f"`{o.flag} {o.metavar}`"
        rows.append(f"| {flag} | `{o.name}` | {o.help} |")
    return "\n".join(rows) + "\n"

