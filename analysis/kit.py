"""Kit files (``--kit KIT``): one tray tilted by one robot, a compartment for every part of a kit.

A kit is JSON (docs/commands.md, docs/kits.md)::

    {"tilt_deg": 30, "tilt_time_s": 0,
     "compartments": [{"name": "key", "size_mm": [120, 90], "shape": "allen-key", "friction": "0.3"},
                      {"name": "tri1", "size_mm": [100, 80], "shape": "triangle:1"}]}

``tilt_deg`` (default 30) and ``tilt_time_s`` (default 0) belong to the tray: one tilt tilts every
compartment. Every compartment is a scene of its own (its walls are the compartment's, its size
``size_mm`` = [x, y] its inner size), with its part (any ``--shape`` spec) and optionally its own
floor friction (default the floor's, 0.3). An optional ``settings`` object (simulator settings,
as a scene file's) applies to every compartment. Compartments have no positions: the walls
between them are the compartments' walls, so they cannot overlap; the parts move independently
given the tilt sequence, which is what the kit answers rely on (:mod:`kruskal_markov.kit`).

Bad kits (not JSON, unknown keys, no compartments, duplicate names, non-positive sizes, a part
that does not fit its compartment at any rotation) raise a one-line :class:`ValueError`, which
the command line turns into exit status 2.
"""
from __future__ import annotations

import dataclasses
import json
import math
import os

__all__ = ["Compartment", "Kit", "load_kit", "parse_kit", "kit_models"]

_KIT_KEYS = {"tilt_deg", "tilt_time_s", "compartments", "settings", "name"}
_COMPARTMENT_KEYS = {"name", "size_mm", "shape", "friction"}


@dataclasses.dataclass(frozen=True)
class Compartment:
    """One compartment of a kit tray.

    Attributes
    ----------
    name : str
        Unique within the kit.
    size_mm : tuple of float
        Inner size ``(x, y)`` in mm.
    shape : str
        The part's shape spec (``allen-key``, ``triangle:SEED``, ...).
    friction : str or None
        Floor friction spec of this compartment (None: the floor's default).
    """

    name: str
    size_mm: tuple
    shape: str
    friction: str | None = None

    def to_dict(self) -> dict:
        """The compartment as it is written in a kit file."""
        out = {"name": self.name, "size_mm": list(self.size_mm), "shape": self.shape}
        if self.friction is not None:
            out["friction"] = self.friction
        return out


@dataclasses.dataclass(frozen=True)
class Kit:
    """A kit tray: its tilt and its compartments (validated by :func:`parse_kit`).

    Attributes
    ----------
    compartments : tuple of Compartment
    tilt_deg : float
        Tilt angle of every action, degrees.
    tilt_time_s : float
        Seconds the tray takes to reach its tilt (0: instant).
    settings : dict
        Simulator setting changes applied to every compartment's scene.
    """

    compartments: tuple
    tilt_deg: float = 30.0
    tilt_time_s: float = 0.0
    settings: dict = dataclasses.field(default_factory=dict)

    @property
    def names(self) -> list[str]:
        """The compartments' names, in file order."""
        return [c.name for c in self.compartments]

    @property
    def area_mm2(self) -> float:
        """Total inner area of the compartments."""
        return float(sum(c.size_mm[0] * c.size_mm[1] for c in self.compartments))

    def scenes(self, contact: str | None = None, **setting_changes) -> list:
        """One :class:`~transition_builder.scene.Scene` per compartment (in order).

        Parameters
        ----------
        contact : str, optional
            Floor contact of every scene (None: the simulator's default).
        **setting_changes
            Further simulator settings of every scene (e.g. the engine), over the kit's own.

        Returns
        -------
        list of Scene
        """
        from transition_builder.scene import scene_from_options

        changes = {**self.settings, **setting_changes}
        if contact is not None:
            changes["contact"] = contact
        out = []
        for c in self.compartments:
            kw = {} if c.friction is None else {"friction_spec": c.friction}
            try:
                out.append(scene_from_options(c.shape, tilt_deg=self.tilt_deg, tray_mm=c.size_mm,
                                              tilt_time_s=self.tilt_time_s, **kw, **changes))
            except ValueError as exc:
                raise ValueError(f"kit compartment {c.name!r}: {exc}") from None
        return out

    def with_sizes(self, size_mm, tilt_deg: float | None = None) -> "Kit":
        """The same kit with every compartment of size ``size_mm`` (and tilt ``tilt_deg`` if given),
        validated again (a part that no longer fits is a ValueError)."""
        comps = [dict(c.to_dict(), size_mm=list(size_mm)) for c in self.compartments]
        data = {"tilt_deg": self.tilt_deg if tilt_deg is None else tilt_deg, "tilt_time_s": self.tilt_time_s,
                "settings": self.settings, "compartments": comps}
        return parse_kit(data)

    def with_tilt(self, tilt_deg: float) -> "Kit":
        """The same kit tilted by ``tilt_deg`` (validated again)."""
        return parse_kit(dict(self.to_dict(), tilt_deg=tilt_deg))

    def to_dict(self) -> dict:
        """The kit as a kit file's JSON object."""
        out = {"tilt_deg": self.tilt_deg, "tilt_time_s": self.tilt_time_s,
               "compartments": [c.to_dict() for c in self.compartments]}
        if self.settings:
            out["settings"] = dict(self.settings)
        return out


def _number(value, what: str, positive: bool = True) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"{what} must be a finite number, got {value!r}")
    if positive and value <= 0:
        raise ValueError(f"{what} must be positive, got {value!r}")
    return float(value)


def _compartment(i: int, entry) -> Compartment:
    if not isinstance(entry, dict):
        raise ValueError(f"kit compartment {i} must be an object with name, size_mm and shape")
    unknown = sorted(set(entry) - _COMPARTMENT_KEYS)
    if unknown:
        raise ValueError(f"kit compartment {i}: unknown key {unknown[0]!r} (known: friction, name, shape, size_mm)")
    for key in ("name", "size_mm", "shape"):
        if key not in entry:
            raise ValueError(f"kit compartment {i}: missing {key!r}")
    name = entry["name"]
    if not isinstance(name, str) or not name.strip():
        raise ValueError(f"kit compartment {i}: name must be a non-empty string")
    size = entry["size_mm"]
    if not isinstance(size, (list, tuple)) or len(size) != 2:
        raise ValueError(f"kit compartment {name!r}: size_mm must be [x, y] in mm, got {size!r}")
    size = tuple(_number(v, f"kit compartment {name!r}: size_mm") for v in size)
    shape = entry["shape"]
    if not isinstance(shape, str) or not shape.strip():
        raise ValueError(f"kit compartment {name!r}: shape must be a shape spec such as allen-key")
    friction = entry.get("friction")
    if friction is not None:
        if isinstance(friction, bool) or not isinstance(friction, (str, int, float)):
            raise ValueError(f"kit compartment {name!r}: friction must be a friction spec, got {friction!r}")
        friction = str(friction)
    return Compartment(name.strip(), size, shape.strip(), friction)


def _check_parts(kit: Kit) -> None:
    """Every part parses and fits its compartment; every friction parses (one-line ValueError)."""
    from transition_builder.friction import parse_friction
    from transition_builder.shapes import check_fits, parse_shape

    for c in kit.compartments:
        try:
            shape = parse_shape(c.shape)
        except ValueError as exc:
            raise ValueError(f"kit compartment {c.name!r}: {exc}") from None
        try:
            check_fits(shape, *c.size_mm)
        except ValueError as exc:
            raise ValueError(f"kit compartment {c.name!r} is too small for its part: {exc}") from None
        if c.friction is not None:
            try:
                parse_friction(c.friction)
            except ValueError as exc:
                raise ValueError(f"kit compartment {c.name!r}: friction: {exc}") from None


def parse_kit(data) -> Kit:
    """Validate a kit's JSON object into a :class:`Kit`.

    Parameters
    ----------
    data : dict
        The kit file's object (module docstring).

    Returns
    -------
    Kit

    Raises
    ------
    ValueError
        One line naming what is wrong.

    Examples
    --------
    >>> kit = parse_kit({"compartments": [{"name": "a", "size_mm": [60, 60], "shape": "rectangle:30x30"}]})
    >>> kit.names, kit.tilt_deg, kit.area_mm2
    (['a'], 30.0, 3600.0)
    >>> parse_kit({"compartments": [{"name": "a", "size_mm": [20, 60], "shape": "rectangle:30x30"}]})
    Traceback (most recent call last):
    ...
    ValueError: kit compartment 'a' is too small for its part: shape 'rectangle:30x30' (30.0 x 30.0 mm) does not fit in the 20 x 60 mm tray at any rotation
    """
    if not isinstance(data, dict):
        raise ValueError("a kit must be a JSON object with compartments")
    unknown = sorted(set(data) - _KIT_KEYS)
    if unknown:
        raise ValueError(f"kit: unknown key {unknown[0]!r} (known: compartments, settings, tilt_deg, tilt_time_s)")
    comps = data.get("compartments")
    if not isinstance(comps, list) or not comps:
        raise ValueError("kit: compartments must be a non-empty list")
    compartments = tuple(_compartment(i, e) for i, e in enumerate(comps))
    names = [c.name for c in compartments]
    dup = next((n for n in names if names.count(n) > 1), None)
    if dup is not None:
        raise ValueError(f"kit: compartment name {dup!r} appears twice")
    tilt = _number(data.get("tilt_deg", 30.0), "kit tilt_deg")
    if tilt >= 90:
        raise ValueError(f"kit tilt_deg must be below 90, got {tilt:g}")
    tilt_time = _number(data.get("tilt_time_s", 0.0), "kit tilt_time_s", positive=False)
    if tilt_time < 0:
        raise ValueError(f"kit tilt_time_s must be >= 0, got {tilt_time:g}")
    settings = data.get("settings", {})
    if not isinstance(settings, dict):
        raise ValueError("kit settings must be an object of simulator settings")
    kit = Kit(compartments, tilt, tilt_time, dict(settings))
    _check_parts(kit)
    kit.scenes()            # the scenes themselves (simulator settings, walls) must be valid too
    return kit


def load_kit(path: str) -> Kit:
    """Read and validate the kit file ``path`` (:func:`parse_kit`); one-line ValueError when bad."""
    if not os.path.isfile(path):
        raise ValueError(f"kit file {path!r} does not exist")
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
    except json.JSONDecodeError as exc:
        raise ValueError(f"kit file {path!r} is not valid JSON ({exc.msg}, line {exc.lineno})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"kit file {path!r} cannot be read ({type(exc).__name__})") from None
    return parse_kit(data)


def kit_models(kit: Kit, settings, *, contact: str | None = None, workers: int | None = None, log=None,
               setting_changes: dict | None = None):
    """The built model of every compartment, from the model cache when built before.

    Parameters
    ----------
    kit : Kit
    settings : BuildSettings
        Build settings of every compartment's model.
    contact : str, optional
        Floor contact (None: the default).
    workers : int, optional
        Worker processes of the builds.
    log : callable, optional
        Told one line per compartment.
    setting_changes : dict, optional
        Simulator settings of every compartment's scene (e.g. ``{"engine": "planar"}``).

    Returns
    -------
    list of dict
        Per compartment: ``name``, ``scene``, ``model`` (TransitionModel), ``path``, ``cached``.
    """
    from transition_builder.cache import cached_build

    out = []
    for c, scene in zip(kit.compartments, kit.scenes(contact, **(setting_changes or {}))):
        result, path, cached = cached_build(scene, settings, workers=workers)
        if log is not None:
            log(f"compartment {c.name}: {result.model.n_states} states ({'cached' if cached else 'built'})")
        out.append({"name": c.name, "scene": scene, "model": result.model, "path": path, "cached": bool(cached)})
    return out
