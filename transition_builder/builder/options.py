"""The build settings, defined once: one :class:`BuildOption` row per setting in :data:`BUILD_OPTIONS`
drives the fields, defaults, checks and docstring of
:class:`~transition_builder.builder.build_settings.BuildSettings`, the flags of ``kruskal build`` and the
options table of ``docs/builder.md`` (:func:`options_markdown`). A new setting is one new row.

This module imports nothing heavy, so ``kruskal --help`` stays fast.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

__all__ = ["BUILD_OPTIONS", "BuildOption", "options_markdown"]

_DEFAULT_NOISY_EXPLORE_WEIGHT = 1e-3
#: noisy builds: samples in proportion to weight from this weight on, up to this many per action
_DEFAULT_NOISY_HEAVY_WEIGHT = 0.025
_DEFAULT_PROBE_WEIGHT = 0.05       # member probes (deterministic builds): from this weight on
#: member probes by default without noise at the default tolerance or finer: 4 members of every
#: representative of weight >= 0.05, and a row is sensitive where one lands in another cell or more
#: than 4 tolerance balls away (docs/builder.md)
_DEFAULT_PROBES = 4
_DEFAULT_PROBE_DISTANCE = 4.0
_DEFAULT_NOISY_MAX_SAMPLES = 128
#: default snapping tolerance (mm and degrees), chosen with the flush-side signature on the tuning set
#: and two held-out sets of sequences (benchmarks/BUILDER_RESULTS.md, docs/builder.md)
_DEFAULT_TOL_DETERMINISTIC = 0.25
_DEFAULT_TOL_NOISY = 0.75
_DEFAULT_NOISY_SAMPLES = 4


@dataclass(frozen=True)
class BuildOption:
    """One build setting: the :class:`BuildSettings` field, its default and check, its command-line
    flag and its help, which ``kruskal build --help`` and the options table of ``docs/builder.md``
    (:func:`options_markdown`) both print.

    Attributes
    ----------
    name : str
        The :class:`BuildSettings` field.
    type : type
        ``int``, ``float``, ``str`` or ``bool`` (on the command line a ``--flag/--no-flag`` pair).
    default : object
        The field's default; ``None`` where ``auto`` chooses (or, without ``auto``, where None has a
        meaning of its own, given in ``doc``).
    help : str
        One line, the default included (``--help`` and the docs table).
    doc : str
        The field's entry in the ``Attributes`` of :class:`BuildSettings`.
    check : tuple or None
        How the value is checked and normalised: ``("int", lo, hi)`` an integer (not a bool) in
        ``lo..hi`` (None: open); ``("number", lo, hi, lo_open, hi_open)`` a finite number;
        ``("bool",)`` anything, taken as a bool; ``("flag",)`` true or false, nothing else;
        ``("grid",)`` a report grid ``AxBxG``; ``("finite",)`` a finite number or None, kept as
        given. None: not checked here (``noise`` is parsed first, as the choices depend on it).
    auto : callable or None
        ``auto(settings, deterministic)``: the builder's choice for a ``None`` value, given the
        settings checked so far (the rows above this one) and whether the build has no process noise.
    flag : str or None
        The ``kruskal build`` flag (``--`` and the name with dashes); None: no flag of its own.
    metavar : str
        The value's name in the help.
    via : str
        Without a flag of its own: how ``kruskal build`` sets it (empty: from Python only).
    set_apart : bool
        Measured worse and off by default: kept so that the measurements in ``docs/builder.md`` can be
        reproduced, and listed apart from the others.
    later : bool
        Added after models were cached: left out of the cache key while off (0, False), so that
        switching it off reproduces the keys of the models built before it.
    serves : str or None
        The setting this one only matters beside: left out of the cache key while that one is off.
    """

    name: str
    type: type
    default: object
    help: str
    doc: str
    check: tuple | None = None
    auto: Callable | None = None
    flag: str | None = None
    metavar: str = ""
    via: str = ""
    set_apart: bool = False
    later: bool = False
    serves: str | None = None

    @property
    def annotation(self) -> str:
        """The field's type annotation (``"int | None"`` where the default is None)."""
        return f"{self.type.__name__} | None" if self.default is None else self.type.__name__

    def attribute_doc(self) -> str:
        """The field's numpydoc ``Attributes`` entry, indented as in a class docstring."""
        kind = f"{self.type.__name__} or None" if self.default is None else self.type.__name__
        text = "\n".join("        " + line.strip() for line in self.doc.strip().splitlines())
        return f"    {self.name} : {kind}\n{text}"


def _auto_max_samples(s, deterministic: bool) -> int:
    return (_DEFAULT_NOISY_MAX_SAMPLES if not deterministic and s.explore_weight > 0 and not s.confirm_samples
            and s.samples < _DEFAULT_NOISY_MAX_SAMPLES else 0)


def _auto_probes(s, deterministic: bool) -> int:
    return (_DEFAULT_PROBES if deterministic and s.explore_weight == 0
            and max(s.tol_mm, s.tol_deg) <= _DEFAULT_TOL_DETERMINISTIC else 0)


def _auto_tolerance(s, deterministic: bool) -> float:
    return _DEFAULT_TOL_DETERMINISTIC if deterministic else _DEFAULT_TOL_NOISY


#: every build setting, in the order of the :class:`BuildSettings` fields; a row's ``auto`` may read
#: the rows above it
BUILD_OPTIONS = (
    BuildOption(
        "tol_mm", float, None, check=("number", 0, None, True, False), auto=_auto_tolerance,
        via="`--resolution MM,DEG`",
        help="snapping tolerance in x and y, mm (default 0.25 without noise, 0.75 with noise)",
        doc="""Snapping tolerance in x and y (mm); None: 0.25 without noise, 0.75 with noise (with
        ``samples`` 4 and ``max_samples`` the design that met the noisy targets within the 30-minute
        build target; ``docs/builder.md``)."""),
    BuildOption(
        "tol_deg", float, None, check=("number", 0, None, True, False), auto=_auto_tolerance,
        via="`--resolution MM,DEG`",
        help="snapping tolerance in theta, degrees (default 0.25 without noise, 0.75 with noise)",
        doc="Snapping tolerance in theta (degrees); None: as ``tol_mm``."),
    BuildOption(
        "start_samples", int, 5000, check=("int", 1, 10_000_000), flag="--start-samples", metavar="N",
        help="uniform start poses for the first tilt (default 5000)",
        doc="Uniform start poses for the first tilt (the initial distribution)."),
    BuildOption(
        "samples", int, None, check=("int", 1, 10_000), auto=lambda s, det: 1 if det else _DEFAULT_NOISY_SAMPLES,
        flag="--samples", metavar="K",
        help="samples per state and action (default 1 without noise, 4 with noise)",
        doc="""Samples per (representative, action): None = 1 without noise (the physics is
        deterministic) and 4 with noise (rows that carry mass get more: ``max_samples``)."""),
    BuildOption(
        "grid", str, "4x4x4", check=("grid",), flag="--grid", metavar="AxBxG",
        help="report grid (default 4x4x4)", doc="Report grid ``AxBxG``."),
    BuildOption(
        "theta_offset", float, None, check=("finite",), flag="--theta-offset", metavar="RAD",
        help="theta bin offset of the report grid (default half a bin)",
        doc="Theta bin offset of the report grid (None: half a bin, the bins centred on the axes)."),
    BuildOption(
        "symmetry", bool, True, via="`--no-symmetry`",
        help="use the tray's rotation group (default on; off by itself for friction maps and odd trays)",
        doc="Use the tray's rotation group (automatically off for friction maps and odd trays)."),
    BuildOption(
        "contacts", bool, True, help="snap only within one wall-contact signature (default on)",
        doc="Snap only within one wall-contact signature (as well as one report cell)."),
    BuildOption(
        "contact_tol_mm", float, 0.05, check=("number", 0, None, True, False),
        help="a vertex this close to a wall touches it, mm (default 0.05)",
        doc="A vertex this close to a wall (mm) touches it."),
    BuildOption(
        "max_states", int, 400_000, check=("int", 1, 50_000_000), flag="--max-states", metavar="N",
        help="stop exploring beyond this many states (default 400000)",
        doc="Stop exploring when this many rest states exist (the rest is reported as unexplored)."),
    BuildOption(
        "noise", str, "none", via="`--noise SPEC`",
        help="process noise: none or pose:SIGMA_MM,SIGMA_DEG (default none)",
        doc="Process noise spec (``none`` or ``pose:SIGMA_MM,SIGMA_DEG``), kept in its canonical spelling."),
    BuildOption(
        "seed", int, 0, check=("int", 0, None), via="`--seed N`",
        help="seed of the start poses and of the noise (default 0)",
        doc="Seed of the start poses and of the noise."),
    BuildOption(
        "refine_rounds", int, 0, check=("int", 0, 20), flag="--refine-rounds", metavar="R", set_apart=True,
        help="set apart, measured no better: rounds splitting a representative whose farthest member lands "
             "in another report cell (default 0)",
        doc="""Adaptive refinement rounds (deterministic builds only; set apart, measured no better):
        after exploration closes, the farthest member of every representative (a landing snapped to
        it, farther than ``refine_min_distance`` in tolerance units) is tilted under every action;
        where one of its landings falls in another report cell than the representative's, the
        member becomes a representative of its own (a split), and exploration continues from what it
        reaches."""),
    BuildOption(
        "refine_min_distance", float, 0.2, check=("number", 0, 1, False, False), set_apart=True,
        help="with refine_rounds, members nearer than this (tolerance units) are not tried (default 0.2)",
        doc="Members nearer than this (normalised tolerance units) are not tried by ``refine_rounds``."),
    BuildOption(
        "adaptive", bool, True, check=("bool",),
        help="noisy builds: samples_first samples for every row, the rest up to samples for the rows that "
             "carry mass (default on)",
        doc="""Adaptive sampling (noisy builds): every row first gets ``samples_first`` samples; then
        the rows that carry mass — probability above 1e-3 at some step of one of 200 random
        30-tilt sequences through the model built so far — are topped up to ``samples``, and
        exploration continues from what the new samples reach (up to 4 rounds)."""),
    BuildOption(
        "samples_first", int, 2, check=("int", 1, None),
        help="samples per row before the adaptive top-up (default 2)",
        doc="Samples per row before the top-up of ``adaptive``."),
    BuildOption(
        "explore_weight", float, None, check=("number", 0, 1, False, True),
        auto=lambda s, det: 0.0 if det else _DEFAULT_NOISY_EXPLORE_WEIGHT, flag="--explore-weight", metavar="W",
        help="expand only states that hold probability >= W on some random sequence "
             "(default 0 = everything without noise, 1e-3 with noise)",
        doc="""None: 0 without noise, 1e-3 with noise. 0: explore everything the actions reach (closure).
        w > 0: weighted exploration — expand only representatives that hold probability >= w at
        some step of one of 200 random 30-tilt sequences through the model built so far (weighed
        again after every expansion), and every state the first tilt reaches (the uniform starts
        spread their mass thinly over many of those); the rest stay ``unexplored``: each borrows
        the row of the nearest explored state in its report cell and contact group (within 8
        tolerance units), else of the nearest explored pose anywhere (``rows_borrowed`` and
        ``rows_borrowed_from_afar`` in the statistics, ``extras["borrowed_from"]`` in the model).
        For noisy scenes, whose closure is an order of magnitude larger than the deterministic one."""),
    BuildOption(
        "recenter_rounds", int, 3, check=("int", 0, 20), flag="--recenter-rounds", metavar="R",
        help="recentring rounds of a deterministic build (default 3)",
        doc="""Recentring rounds (deterministic builds): once exploration has closed, every
        representative moves to the densest point of its members (the landings snapped to it:
        where parts really come to rest, e.g. an exact corner-wedge pose that many landings hit)
        and is tilted again from there; exploration then continues from what it reaches."""),
    BuildOption(
        "snap_compensation", bool, False, check=("bool",), set_apart=True, later=True,
        help="set apart, measured worse: noisy builds perturb a representative by less than the noise, "
             "by the snapping offset it stands for (default off)",
        doc="""Noisy builds (set apart, measured worse): perturb a representative by less than the
        process noise, so that the noise plus the snapping offset it stands for (a landing moved onto
        its representative, root mean square over all landings so far) has the variance of the
        process noise (:func:`compensated_noise`; the offset is measured again before every batch of
        samples)."""),
    BuildOption(
        "confirm_samples", int, 0, check=("int", 0, None), flag="--confirm-samples", metavar="K1",
        set_apart=True, later=True,
        help="set apart, measured worse: noisy builds top heavy rows up to K1 samples first and only those "
             "whose samples disagree on the report cell up to K (default 0: off)",
        doc="""Agreement-staged top-up (weighted noisy builds; 0: off). A heavy row is first topped up
        to ``confirm_samples`` samples per action; only the (row, action) pairs whose samples so far
        disagree — landings in more than one report cell, or a fault — get the rest up to
        ``samples``. Most heavy rows send every sample to one report cell (91-97% of the allen
        key's at 8 samples). Set apart: on the key at 0.5 mm it cut the tilts by 44% but
        raised the error from 0.036 / 0.25 to 0.053 / 0.43 bits, the model's entropy running low
        (a row stopped because its samples agreed over-states its main outcome; the samples that
        stay in one cell still spread the row over representatives that part later;
        ``docs/builder.md``)."""),
    BuildOption(
        "flush_side", bool, None, check=("flag",), auto=lambda s, det: det, flag="--flush-side", later=True,
        help="snap only between poses resting on the same end of an edge flush with a wall "
             "(default on without noise, off with noise)",
        doc="""Snap only within the same flush side (:func:`transition_builder.snapping.wall_contacts`):
        an edge resting a hair off flush against a wall rests on one end or the other, and a pose
        on one end does not stand for poses on the other (on the allen key, 1e-4 rad either side
        of flush sent the next tilt's landing 0.1 mm and the one after 0.7 mm apart). None: on
        without noise (at 0.25 mm it lowered the mean and the worst step on both held-out sets of
        sequences), off with noise (the noise moves theta by far more than such an angle)."""),
    BuildOption(
        "max_samples", int, None, check=("int", 0, 10_000), auto=_auto_max_samples, flag="--max-samples",
        metavar="KMAX", later=True,
        help="noisy builds: rows of weight w >= --heavy-weight get K * w / heavy-weight samples, up to KMAX "
             "(default 128 for weighted noisy builds, else 0: off)",
        doc="""Samples in proportion to weight (weighted noisy builds; 0: off; None: 128 for weighted
        noisy builds, off otherwise). A row whose weight ``w`` (the largest probability one of its
        states holds at some step of the weighing sequences) reaches ``heavy_weight`` gets
        ``samples * w / heavy_weight`` samples per action (rounded up to a multiple of ``samples``),
        up to ``max_samples``. The rows that hold a tenth of the mass or more carry nearly all of a
        noisy model's sampling error (on the key at 1 mm, 237 of 14,397 rows carried 97% of it):
        samples proportional to the mass that passes through a row minimise the variance of the
        propagated distribution for a given number of tilts. The decision depends on the weights
        alone, never on the samples' outcomes, so the estimate stays unbiased (unlike
        ``confirm_samples``)."""),
    BuildOption(
        "heavy_weight", float, None, check=("number", 0, 1, True, False),
        auto=lambda s, det: _DEFAULT_NOISY_HEAVY_WEIGHT, flag="--heavy-weight", metavar="W", serves="max_samples",
        help="the weight from which --max-samples adds samples (default 0.025)",
        doc="The weight at which ``max_samples`` starts adding samples (None: 0.025)."),
    BuildOption(
        "probes", int, None, check=("int", 0, 64), auto=_auto_probes, flag="--probes", metavar="M", later=True,
        help="deterministic builds: representatives of weight >= --probe-weight tilt up to M of their members; "
             "where one lands in another report cell the row becomes the members' landings (default 4 without "
             "noise at the default tolerance or finer, else 0)",
        doc="""Member probes (deterministic builds; 0: off; None: 4 without noise and weighted exploration
        at the default tolerance or finer, where they were chosen on two held-out sets of sequences;
        0 otherwise — at 0.5 mm / 0.5 deg they made the worst step worse, docs/builder.md). Once
        exploration and recentring have closed, every representative of weight at least
        ``probe_weight`` (the largest probability one of its states holds at some step of 200 random
        30-tilt sequences through the model) tilts up to ``probes`` of its members — landings that
        snapped to it, drawn at random, so a pose many landings share is drawn as often — under
        every action. Where a member lands in another report cell than the representative, or faults
        where it does not (or the other way round), the physics is sensitive inside the
        representative's tolerance, and the row becomes the representative's landing and its
        members' with equal weights (Ulam's method: the image of the cell, not of its centre);
        elsewhere the row stays the representative's single landing. Exploration then continues from
        what the members reach."""),
    BuildOption(
        "probe_weight", float, None, check=("number", 0, 1, True, False), auto=lambda s, det: _DEFAULT_PROBE_WEIGHT,
        flag="--probe-weight", metavar="W", serves="probes",
        help="the weight from which --probes probes a representative (default 0.05)",
        doc="The weight from which a representative is probed (None: 0.05)."),
    BuildOption(
        "probe_distance", float, None, check=("number", 0, None, False, False),
        auto=lambda s, det: _DEFAULT_PROBE_DISTANCE if s.probes else 0.0, flag="--probe-distance", metavar="D",
        later=True, serves="probes",
        help="with --probes, a member landing in the representative's report cell but more than D tolerance "
             "balls from its landing also makes the row sensitive (default 4 with --probes, 0 without)",
        doc="""(None: 4 with probes, 0 without.) With ``probes``, also count a row as sensitive where a
        member lands in the same report cell as the representative but farther than
        ``probe_distance`` tolerance balls from its landing (the snapping metric,
        :class:`transition_builder.snapping.PoseIndex`; a landing in another contact group counts as
        far; 0: off, the report cell and faults alone decide). A tilt that scatters a tight cluster
        across a report cell sends the pieces different ways at later tilts, which a single landing
        cannot follow."""),
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
        if o.flag is None:
            flag = o.via or "(Python only)"
        elif o.type is bool:
            flag = f"`{o.flag}/--no-{o.flag[2:]}`"
        else:
            flag = f"`{o.flag} {o.metavar}`"
        rows.append(f"| {flag} | `{o.name}` | {o.help} |")
    return "\n".join(rows) + "\n"
