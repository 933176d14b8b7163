"""Build settings and the cache key: everything besides the scene that changes a built model.

:class:`BuildSettings` (its defaults and checks), :func:`build_key` (the content hash a model is
cached under) and :class:`BuildResult` (a built model and what it cost).
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, fields

import numpy as np

from kruskal_markov._checks import check_int, check_number, is_number
from kruskal_markov.model import TransitionModel
from transition_builder.grid import parse_grid
from transition_builder.noise import NoiseSpec, parse_noise
from transition_builder.scene import Scene

#: bump when a change of the builder changes its models (part of the cache key).
BUILDER_VERSION = "snap-1"
#: weighted exploration's design, in the cache key of weighted builds: an unexplored state borrows
#: the row of the nearest explored state in its report cell and contact group (``_BORROW_RADIUS``)
_WEIGHTED_DESIGN = "borrow-2"
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
class BuildSettings:
    """Everything besides the scene that changes a built model (all of it is in the cache key).

    Attributes
    ----------
    tol_mm, tol_deg : float or None
        Snapping tolerance (mm in x and y, degrees in theta); None: 0.25 / 0.25 without noise,
        0.75 / 0.75 with noise (with ``samples`` 4 and ``max_samples`` the design that met the
        noisy targets within the 30-minute build target; ``docs/builder.md``).
    start_samples : int
        Uniform start poses for the first tilt (the initial distribution).
    samples : int or None
        Samples per (representative, action): None = 1 without noise (the physics is
        deterministic) and 4 with noise (rows that carry mass get more: ``max_samples``).
    grid : str
        Report grid ``AxBxG``; ``theta_offset`` its theta bin offset (None: centred on the axes).
    symmetry : bool
        Use the tray's rotation group (automatically off for friction maps and odd trays).
    contacts : bool
        Snap only within one wall-contact signature (as well as one report cell).
    contact_tol_mm : float
        A vertex this close to a wall touches it.
    max_states : int
        Stop exploring when this many rest states exist (the rest is reported as unexplored).
    noise : str
        Process noise spec (``none`` or ``pose:SIGMA_MM,SIGMA_DEG``).
    seed : int
        Seed of the start poses and of the noise.
    refine_rounds : int
        Adaptive refinement rounds (deterministic builds only): after exploration closes, the
        farthest member of every representative (a landing snapped to it, farther than
        ``refine_min_distance`` in tolerance units) is tilted under every action; where one of
        its landings falls in another report cell than the representative's, the member becomes a
        representative of its own (a split), and exploration continues from what it reaches.
    refine_min_distance : float
        Members nearer than this (normalised tolerance units) are not tried.
    adaptive : bool
        Adaptive sampling (noisy builds): every row first gets ``samples_first`` samples; then
        the rows that carry mass — probability above 1e-3 at some step of one of 200 random
        30-tilt sequences through the model built so far — are topped up to ``samples``, and
        exploration continues from what the new samples reach (up to 4 rounds).
    samples_first : int
        Samples per row before the top-up.
    confirm_samples : int
        Agreement-staged top-up (weighted noisy builds; 0: off). A heavy row is first topped up
        to ``confirm_samples`` samples per action; only the (row, action) pairs whose samples so far
        disagree — landings in more than one report cell, or a fault — get the rest up to
        ``samples``. Most heavy rows send every sample to one report cell (91-97% of the allen
        key's at 8 samples). Off by default: on the key at 0.5 mm it cut the tilts by 44% but
        raised the error from 0.036 / 0.25 to 0.053 / 0.43 bits, the model's entropy running low
        (a row stopped because its samples agreed over-states its main outcome; the samples that
        stay in one cell still spread the row over representatives that part later;
        ``docs/builder.md``).
    recenter_rounds : int
        Recentring rounds (deterministic builds; default 3): once exploration has closed, every
        representative moves to the densest point of its members (the landings snapped to it:
        where parts really come to rest, e.g. an exact corner-wedge pose that many landings hit)
        and is tilted again from there; exploration then continues from what it reaches.
    explore_weight : float or None
        None: 0 without noise, 1e-3 with noise. 0: explore everything the actions reach (closure).
        w > 0: weighted exploration — expand only representatives that hold probability >= w at
        some step of one of 200 random 30-tilt sequences through the model built so far (weighed
        again after every expansion), and every state the first tilt reaches (the uniform starts
        spread their mass thinly over many of those); the rest stay ``unexplored``: each borrows
        the row of the nearest explored state in its report cell and contact group (within 8
        tolerance units), else of the nearest explored pose anywhere (``rows_borrowed`` and
        ``rows_borrowed_from_afar`` in the statistics, ``extras["borrowed_from"]`` in the model).
        For noisy scenes, whose closure is an order of magnitude larger than the deterministic one.
    snap_compensation : bool
        Noisy builds: perturb a representative by less than the process noise, so that the
        noise plus the snapping offset it stands for (a landing moved onto its representative,
        root mean square over all landings so far) has the variance of the process noise
        (:func:`compensated_noise`; the offset is measured again before every batch of samples).
    max_samples : int or None
        Samples in proportion to weight (weighted noisy builds; 0: off; None: 128 for weighted noisy
        builds, off otherwise). A row whose weight ``w``
        (the largest probability one of its states holds at some step of the weighing sequences)
        reaches ``heavy_weight`` gets ``samples * w / heavy_weight`` samples per action (rounded up
        to a multiple of ``samples``), up to ``max_samples``. The rows that hold a tenth of the mass
        or more carry nearly all of a noisy model's sampling error (on the key at 1 mm, 237 of
        14,397 rows carried 97% of it): samples proportional to the mass that passes through a row
        minimise the variance of the propagated distribution for a given number of tilts. The
        decision depends on the weights alone, never on the samples' outcomes, so the estimate
        stays unbiased (unlike ``confirm_samples``).
    heavy_weight : float or None
        The weight at which ``max_samples`` starts adding samples (None: 0.025).
    flush_side : bool or None
        Snap only within the same flush side (:func:`transition_builder.snapping.wall_contacts`):
        an edge resting a hair off flush against a wall rests on one end or the other, and a pose
        on one end does not stand for poses on the other (on the allen key, 1e-4 rad either side
        of flush sent the next tilt's landing 0.1 mm and the one after 0.7 mm apart). None: on
        without noise (at 0.25 mm it lowered the mean and the worst step on both held-out sets of
        sequences), off with noise (the noise moves theta by far more than such an angle).
    probes : int or None
        Member probes (deterministic builds; 0: off; None: 4 without noise and weighted exploration
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
        what the members reach.
    probe_weight : float or None
        The weight from which a representative is probed (None: 0.05).
    probe_distance : float or None
        (None: 4 with probes, 0 without.) With ``probes``, also count a row as sensitive where a
        member lands in the same report cell as the representative but farther than
        ``probe_distance`` tolerance balls from its landing (the snapping metric,
        :class:`transition_builder.snapping.PoseIndex`; a landing in another contact group counts as
        far; 0: off, the report cell and faults alone decide). A tilt that scatters a tight cluster
        across a report cell sends the pieces different ways at later tilts, which a single landing
        cannot follow.
    """

    tol_mm: float | None = None
    tol_deg: float | None = None
    start_samples: int = 5000
    samples: int | None = None
    grid: str = "4x4x4"
    theta_offset: float | None = None
    symmetry: bool = True
    contacts: bool = True
    contact_tol_mm: float = 0.05
    max_states: int = 400_000
    noise: str = "none"
    seed: int = 0
    refine_rounds: int = 0
    refine_min_distance: float = 0.2
    adaptive: bool = True
    samples_first: int = 2
    explore_weight: float | None = None
    recenter_rounds: int = 3
    snap_compensation: bool = False
    confirm_samples: int = 0
    flush_side: bool | None = None
    max_samples: int | None = None
    heavy_weight: float | None = None
    probes: int | None = None
    probe_weight: float | None = None
    probe_distance: float | None = None

    def __post_init__(self):
        noise = parse_noise(self.noise)
        object.__setattr__(self, "noise", str(noise))
        for name, rule in _CHECKS.items():
            value = getattr(self, name)
            if value is None and name in _AUTO:
                value = _AUTO[name](self, noise.is_zero)
            object.__setattr__(self, name, _check(name, value, rule))
        if noise.is_zero:
            object.__setattr__(self, "samples", 1)  # deterministic physics: every extra sample would repeat the first
        _check_combinations(self, noise.is_zero)
        parse_grid(self.grid)
        if self.theta_offset is not None and not is_number(self.theta_offset):
            raise ValueError("theta_offset must be finite")

    @property
    def noise_spec(self) -> NoiseSpec:
        return parse_noise(self.noise)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> "BuildSettings":
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"unknown build setting(s) {', '.join(unknown)}")
        return cls(**data)


#: None -> the builder's choice, given the settings checked so far (in ``_CHECKS`` order) and
#: whether the build is deterministic (no process noise)
_AUTO = {
    "tol_mm": lambda s, det: _DEFAULT_TOL_DETERMINISTIC if det else _DEFAULT_TOL_NOISY,
    "tol_deg": lambda s, det: _DEFAULT_TOL_DETERMINISTIC if det else _DEFAULT_TOL_NOISY,
    "flush_side": lambda s, det: det,                        # on for deterministic builds
    "explore_weight": lambda s, det: 0.0 if det else _DEFAULT_NOISY_EXPLORE_WEIGHT,
    "samples": lambda s, det: 1 if det else _DEFAULT_NOISY_SAMPLES,
    "max_samples": lambda s, det: (_DEFAULT_NOISY_MAX_SAMPLES if not det and s.explore_weight > 0
                                   and not s.confirm_samples and s.samples < _DEFAULT_NOISY_MAX_SAMPLES else 0),
    "heavy_weight": lambda s, det: _DEFAULT_NOISY_HEAVY_WEIGHT,
    "probes": lambda s, det: (_DEFAULT_PROBES if det and s.explore_weight == 0
                              and max(s.tol_mm, s.tol_deg) <= _DEFAULT_TOL_DETERMINISTIC else 0),
    "probe_weight": lambda s, det: _DEFAULT_PROBE_WEIGHT,
    "probe_distance": lambda s, det: _DEFAULT_PROBE_DISTANCE if s.probes else 0.0,
}

#: every checked setting, in the order its default may depend on the ones before it:
#: ("int", lo, hi) an integer (not a bool) in lo..hi; ("number", lo, hi, lo_open, hi_open) a finite
#: number; ("bool",) anything, taken as a bool; ("flag",) true or false, no other value
_CHECKS = {
    "tol_mm": ("number", 0, None, True, False),
    "tol_deg": ("number", 0, None, True, False),
    "contact_tol_mm": ("number", 0, None, True, False),
    "start_samples": ("int", 1, 10_000_000),
    "max_states": ("int", 1, 50_000_000),
    "samples_first": ("int", 1, None),
    "adaptive": ("bool",),
    "confirm_samples": ("int", 0, None),
    "snap_compensation": ("bool",),
    "flush_side": ("flag",),
    "recenter_rounds": ("int", 0, 20),
    "explore_weight": ("number", 0, 1, False, True),
    "refine_rounds": ("int", 0, 20),
    "refine_min_distance": ("number", 0, 1, False, False),
    "samples": ("int", 1, 10_000),
    "max_samples": ("int", 0, 10_000),
    "heavy_weight": ("number", 0, 1, True, False),
    "probes": ("int", 0, 64),
    "probe_weight": ("number", 0, 1, True, False),
    "probe_distance": ("number", 0, None, False, False),
    "seed": ("int", 0, None),
}


def _check(name: str, value, rule: tuple):
    """``value`` of the setting ``name`` checked by its ``_CHECKS`` rule and normalised."""
    kind = rule[0]
    label = f"build setting {name}"
    if kind == "int":
        return check_int(value, label, lo=rule[1], hi=rule[2])
    if kind == "number":
        return check_number(value, label, lo=rule[1], hi=rule[2], lo_open=rule[3], hi_open=rule[4])
    if kind == "flag" and not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{label} must be true, false or None, got {value!r}")
    return bool(value)


def _check_combinations(s: "BuildSettings", deterministic: bool) -> None:
    """The settings that only make sense together (a one-line ValueError naming them)."""
    k, ew = s.samples, s.explore_weight
    if s.confirm_samples and k > 1:
        if not s.samples_first < s.confirm_samples < k:
            raise ValueError(f"confirm_samples must lie between samples_first ({s.samples_first}) and "
                             f"samples ({k}), got {s.confirm_samples}")
        if ew == 0 or not s.adaptive:
            raise ValueError("confirm_samples needs adaptive sampling with weighted exploration "
                             "(explore_weight > 0)")
    if s.max_samples:
        if deterministic or ew == 0:
            raise ValueError("max_samples needs process noise and weighted exploration (explore_weight > 0)")
        if s.max_samples <= k:
            raise ValueError(f"max_samples must exceed samples ({k}), got {s.max_samples}")
        if s.confirm_samples:
            raise ValueError("max_samples and confirm_samples cannot be combined")
    if s.probes and (not deterministic or ew > 0):
        raise ValueError("probes are for deterministic builds that explore everything (no noise, "
                         "explore_weight 0)")


def _package_version() -> str:
    try:
        from importlib.metadata import version
        return version("kruskal")
    except Exception:  # pragma: no cover - running from a source tree without installing
        return "0+unknown"


#: build options added after models were cached; at their "off" value they are left out of the
#: cache key, so that switching them off reproduces the keys of the models built before them
_LATER_OPTIONS = ("snap_compensation", "confirm_samples", "flush_side", "max_samples", "probes", "probe_distance")
#: later options that only matter while another one is on (option: the one it serves)
_SERVING_OPTIONS = {"heavy_weight": "max_samples", "probe_weight": "probes", "probe_distance": "probes"}


def settings_design(settings: dict) -> dict:
    """Build settings (``BuildSettings.to_dict()``, or a model's ``build_settings``) without the
    later options that are off: the same design compares equal whether or not it was built before
    those options existed."""
    return {k: v for k, v in settings.items()
            if (v or k not in _LATER_OPTIONS) and (k not in _SERVING_OPTIONS or settings.get(_SERVING_OPTIONS[k]))}


def build_key(scene: Scene, settings: BuildSettings) -> str:
    """Content hash (hex) of everything that changes a built model: the scene's own content hash
    (shape, tray, friction, tilt, actions, every solver setting, simulator and PyBullet versions),
    the build settings (noise and seed included), the builder and package versions."""
    payload = {"scene": scene.content_hash(), "settings": settings_design(settings.to_dict()),
               "builder": BUILDER_VERSION, "package": _package_version()}
    if settings.explore_weight > 0:
        payload["weighted"] = _WEIGHTED_DESIGN
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


@dataclass(frozen=True)
class BuildResult:
    """A built model and what it cost (``stats``: the JSON keys of ``kruskal build``).

    Attributes
    ----------
    model : kruskal_markov.model.TransitionModel
        The built model (its ``metadata`` records the scene, the settings, the key and ``stats``).
    stats : dict
        What the build did and cost: states, tilts simulated (over every run of a resumed build),
        faults, seconds, and the phase counters (the JSON keys of ``kruskal build``).
    """

    model: TransitionModel
    stats: dict
