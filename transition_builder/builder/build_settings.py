"""Build settings and the cache key: everything besides the scene that changes a built model.

:class:`BuildSettings` (its defaults and checks), :func:`build_key` (the content hash a model is
cached under) and :class:`BuildResult` (a built model and what it cost).
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass

import numpy as np

from kruskal_markov.model import TransitionModel
from kruskal_markov.validation import check_fields, check_int, check_number
from transition_builder.builder.options import BUILD_OPTIONS
from transition_builder.grid import parse_grid
from transition_builder.noise import NoiseSpec, parse_noise
from transition_builder.scene import Scene

#: bump when a change of the builder changes its models (part of the cache key).
BUILDER_VERSION = "snap-1"
#: weighted exploration's design, in the cache key of weighted builds: an unexplored state borrows
#: the row of the nearest explored state in its report cell and contact group (``_BORROW_RADIUS``)
_WEIGHTED_DESIGN = "borrow-2"
#: the report's compared resolution (:meth:`BuildSettings.compared`): 1 mm / 1 degree snapping, one
#: recentring round, 2000 start poses; the resolution at which models of different physics are compared
#: (contact models, sensitivity, the fit's grid, friction ranges). Copy it (``dict(COMPARED_RESOLUTION)``)
#: where a dict of changes is wanted.
COMPARED_RESOLUTION = {"tol_mm": 1.0, "tol_deg": 1.0, "recenter_rounds": 1, "start_samples": 2000}


def _fields_from_options(cls):
    """Class decorator: the fields of ``cls`` are the rows of :data:`BUILD_OPTIONS`, in its order, with
    their annotations and defaults, and its docstring gets their ``Attributes``; then it is made a
    frozen dataclass."""
    cls.__annotations__ = {o.name: o.annotation for o in BUILD_OPTIONS}
    for o in BUILD_OPTIONS:
        setattr(cls, o.name, o.default)
    cls.__doc__ = ((cls.__doc__ or "").rstrip() + "\n\n    Attributes\n    ----------\n"
                   + "\n".join(o.attribute_doc() for o in BUILD_OPTIONS) + "\n    ")
    return dataclass(frozen=True)(cls)


@_fields_from_options
class BuildSettings:
    """Everything besides the scene that changes a built model (all of it is in the cache key).

    One field per row of :data:`~transition_builder.builder.options.BUILD_OPTIONS`, which gives its
    default, its check and its ``None`` choice (the builder's, given the noise and the fields
    before it). ``BuildSettings(samples=8, noise="pose:0.5,0.5")``; :meth:`to_dict` and
    :meth:`from_dict` for JSON.
    """

    def __post_init__(self):
        noise = parse_noise(self.noise)
        object.__setattr__(self, "noise", str(noise))
        for option in BUILD_OPTIONS:
            value = getattr(self, option.name)
            if value is None and option.auto is not None:
                value = option.auto(self, noise.is_zero)
            if option.check is not None:
                object.__setattr__(self, option.name, _check(option.name, value, option.check))
        if noise.is_zero:
            object.__setattr__(self, "samples", 1)  # deterministic physics: every extra sample would repeat the first
        _check_combinations(self, noise.is_zero)

    @property
    def noise_spec(self) -> NoiseSpec:
        """The parsed ``noise``."""
        return parse_noise(self.noise)

    def to_dict(self) -> dict:
        """All fields, JSON-able (a model's ``build_settings``)."""
        return asdict(self)

    @classmethod
    def compared(cls, **changes) -> "BuildSettings":
        """The report's compared resolution (:data:`COMPARED_RESOLUTION`), with ``changes``.

        Parameters
        ----------
        **changes
            Fields to set besides (or instead of) the resolution's, e.g. ``seed`` or ``tol_mm``.

        Returns
        -------
        BuildSettings

        Examples
        --------
        >>> s = BuildSettings.compared(seed=3)
        >>> (s.tol_mm, s.tol_deg, s.recenter_rounds, s.start_samples, s.seed)
        (1.0, 1.0, 1, 2000, 3)
        """
        return cls(**{**COMPARED_RESOLUTION, **changes})

    @classmethod
    def from_dict(cls, data: dict) -> "BuildSettings":
        """Inverse of :meth:`to_dict`; unknown keys are an error."""
        return cls(**check_fields(data, cls, "build setting"))


def _check(name: str, value, rule: tuple):
    """``value`` of the setting ``name`` checked by its rule (:attr:`BuildOption.check`) and normalised."""
    kind = rule[0]
    label = f"build setting {name}"
    if kind == "int":
        return check_int(value, label, lo=rule[1], hi=rule[2])
    if kind == "number":
        return check_number(value, label, lo=rule[1], hi=rule[2], lo_open=rule[3], hi_open=rule[4])
    if kind == "grid":
        parse_grid(value)
        return value
    if kind == "finite":
        if value is not None:
            check_number(value, label)
        return value
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
_LATER_OPTIONS = tuple(o.name for o in BUILD_OPTIONS if o.later)
#: later options that only matter while another one is on (option: the one it serves)
_SERVING_OPTIONS = {o.name: o.serves for o in BUILD_OPTIONS if o.serves}


def settings_design(settings: dict) -> dict:
    """Build settings without the later options that are off: the same design compares equal
    whether or not it was built before those options existed.

    Parameters
    ----------
    settings : dict
        ``BuildSettings.to_dict()``, or a model's ``build_settings``.

    Returns
    -------
    dict
        ``settings`` without the options marked ``later`` in :data:`BUILD_OPTIONS` while they are
        off, and without those that ``serve`` an option that is off.

    Examples
    --------
    >>> design = settings_design(BuildSettings(noise="pose:1,1").to_dict())
    >>> "probes" in design, "max_samples" in design
    (False, True)
    """
    return {k: v for k, v in settings.items()
            if (v or k not in _LATER_OPTIONS) and (k not in _SERVING_OPTIONS or settings.get(_SERVING_OPTIONS[k]))}


def build_key(scene: Scene, settings: BuildSettings) -> str:
    """Content hash (hex) of everything that changes a built model: the scene's own content hash
    (shape, tray, friction, tilt, actions, every solver setting, simulator and PyBullet versions),
    the build settings (noise and seed included), the builder and package versions.

    Parameters
    ----------
    scene : Scene
        The scene built.
    settings : BuildSettings
        The build settings; the later options that are off are left out (:func:`settings_design`).

    Returns
    -------
    str
        SHA-256 in hex: the name a model is cached under (``kruskal build --json`` prints it as ``key``).
    """
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
