"""The scene of a tray-tilt experiment: tray, part, friction, tilt angle, action set, simulator settings.

Tray frame (docs/commands.md): origin at the tray's inner south-west corner, x east, y north, millimetres.
A pose is ``(x, y, theta)`` of the part's area centroid, ``theta`` counter-clockwise in ``[0, 2 pi)``.
Tilting ``E`` lowers the east side: the part slides east (downhill direction angle 0); the eight
actions ``N, NE, E, SE, S, SW, W, NW`` have downhill angles 90, 45, 0, -45, -90, -135, 180, 135 deg.

A :class:`Scene` holds everything that can change a simulated outcome, and
:meth:`Scene.content_hash` hashes all of it (including the PyBullet version), so cached samples and
models can be keyed by it.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import tomllib
from dataclasses import dataclass, field, replace

import numpy as np

from kruskal_markov.validation import action_position
from transition_builder.friction import DEFAULT_MU, FrictionSpec, parse_friction
from transition_builder.shapes import Shape, check_fits, make_shape, parse_shape
from transition_builder.sim_settings import PLANAR_ENGINE_VERSION, SIMULATOR_VERSION, SimSettings

__all__ = ["Scene", "scene_from_options", "check_tilt_time", "ACTIONS", "ACTION_ANGLES_DEG", "DEFAULT_TILT_DEG"]

#: canonical action names in index order (docs/commands.md).
ACTIONS = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")
#: downhill direction of each action, degrees counter-clockwise from east (+x).
ACTION_ANGLES_DEG = {"N": 90.0, "NE": 45.0, "E": 0.0, "SE": -45.0, "S": -90.0, "SW": -135.0,
                     "W": 180.0, "NW": 135.0}
DEFAULT_TILT_DEG = 30.0
_SCENE_FORMAT = 1


def _pybullet_version() -> str:
    try:
        from importlib.metadata import version
        return version("pybullet")
    except Exception:  # pragma: no cover - pybullet is a hard dependency
        return "unknown"


def _positive(name, val, upper=None):
    if (isinstance(val, bool) or not isinstance(val, (int, float, np.integer, np.floating))
            or not math.isfinite(val) or val <= 0):
        raise ValueError(f"{name} must be a positive finite number, got {val!r}")
    if upper is not None and val >= upper:
        raise ValueError(f"{name} must be below {upper}, got {val!r}")
    return float(val)


@dataclass(frozen=True, eq=False)
class Scene:
    """A tray-tilt scene.

    Parameters
    ----------
    shape : Shape
        The part (see :mod:`transition_builder.shapes`).
    tray_x_mm, tray_y_mm : float
        Inner size of the tray (default 200 x 200 mm).
    wall_height_mm, wall_thickness_mm : float
        Wall size. Walls are taller than any part so nothing can jump them.
    friction : FrictionSpec or str or float
        Floor friction: a uniform coefficient, a static/kinetic pair ``MU_S/MU_K`` or
        ``map:LEVEL:SEED[:MEAN]`` (see :mod:`transition_builder.friction`). A pair needs the
        ``coulomb`` contact.
    wall_mu : float or None
        Coulomb coefficient between part and walls; ``None`` means the floor's (base, kinetic)
        coefficient. Walls have one coefficient (Bullet's contact friction, static and kinetic alike).
    tilt_deg : float
        Tilt angle of every action (default 30 degrees), in (0, 90).
    tilt_time_s : float
        Seconds the tray takes to rotate from level to its tilt (the robot's motion), the gravity
        direction following; 0 (the default) is today's instant tilt. Only a non-zero value enters
        :meth:`to_dict` and the content hash, so existing scenes keep their keys.
    actions : tuple of str
        The action set, a subset of ``N, NE, E, SE, S, SW, W, NW`` kept in canonical order.
    settings : SimSettings
        Simulator settings.
    """

    shape: Shape
    tray_x_mm: float = 200.0
    tray_y_mm: float = 200.0
    wall_height_mm: float = 30.0
    wall_thickness_mm: float = 20.0
    friction: FrictionSpec = field(default_factory=lambda: parse_friction(DEFAULT_MU))
    wall_mu: float | None = None
    tilt_deg: float = DEFAULT_TILT_DEG
    actions: tuple = ACTIONS
    settings: SimSettings = field(default_factory=SimSettings)
    tilt_time_s: float = 0.0

    def __post_init__(self):
        if not isinstance(self.shape, Shape):
            raise ValueError(f"scene shape must be a Shape, got {type(self.shape).__name__}")
        for name in ("tray_x_mm", "tray_y_mm", "wall_height_mm", "wall_thickness_mm"):
            object.__setattr__(self, name, _positive(name.replace("_", " "), getattr(self, name)))
        object.__setattr__(self, "tilt_deg", _positive("tilt angle (deg)", self.tilt_deg, upper=90.0))
        object.__setattr__(self, "friction", parse_friction(self.friction))
        object.__setattr__(self, "tilt_time_s", check_tilt_time(self.tilt_time_s))
        if self.wall_mu is not None:
            wm = self.wall_mu
            if isinstance(wm, bool) or not isinstance(wm, (int, float)) or not math.isfinite(wm) or wm < 0:
                raise ValueError(f"wall friction must be a finite number >= 0, got {wm!r}")
            object.__setattr__(self, "wall_mu", float(wm))
        if not isinstance(self.settings, SimSettings):
            raise ValueError("scene settings must be a SimSettings")
        acts = self.actions
        if isinstance(acts, str):
            acts = [a for a in acts.split(",") if a.strip()]
        names = []
        for a in acts:
            if not isinstance(a, str):
                raise ValueError(f"unknown action {a!r}; known actions: {','.join(ACTIONS)}")
            names.append(ACTIONS[action_position(ACTIONS, a)])
        if not names:
            raise ValueError("the action set is empty")
        if len(set(names)) != len(names):
            raise ValueError(f"repeated action in the action set {','.join(names)}")
        object.__setattr__(self, "actions", tuple(a for a in ACTIONS if a in names))
        if self.wall_height_mm <= self.shape.thickness_mm:
            raise ValueError(f"walls ({self.wall_height_mm:g} mm) must be taller than the part "
                             f"({self.shape.thickness_mm:g} mm)")
        check_fits(self.shape, self.tray_x_mm, self.tray_y_mm)
        if self.friction.is_pair and self.settings.contact != "coulomb":
            raise ValueError(f"a static/kinetic friction pair ({self.friction}) needs the coulomb contact: the "
                             f"{self.settings.contact} contact has one Bullet coefficient, static and kinetic alike")
        _check_support_inside(self.shape, self.settings.support_radius_mm)

    # ------------------------------------------------------------------ actions
    def action_index(self, action) -> int:
        """Index of ``action`` (a name or an index) in this scene's action set; ValueError if unknown."""
        if isinstance(action, (int, np.integer)) and not isinstance(action, bool):
            if not 0 <= int(action) < len(self.actions):
                raise ValueError(f"action index {action} out of range 0..{len(self.actions) - 1} "
                                 f"(actions {','.join(self.actions)})")
            return int(action)
        if not isinstance(action, str):
            raise ValueError(f"unknown action {action!r}; known actions: {','.join(self.actions)}")
        return action_position(self.actions, action)

    def action_name(self, action) -> str:
        return self.actions[self.action_index(action)]

    def downhill_angle(self, action) -> float:
        """Downhill direction of ``action`` in radians counter-clockwise from +x (east)."""
        return math.radians(ACTION_ANGLES_DEG[self.action_name(action)])

    @property
    def base_mu(self) -> float:
        return self.friction.mu

    @property
    def effective_wall_mu(self) -> float:
        return self.base_mu if self.wall_mu is None else self.wall_mu

    # ------------------------------------------------------------------ serialisation
    def to_dict(self) -> dict:
        """Everything that defines the scene, JSON-able."""
        return {
            "format": _SCENE_FORMAT,
            "shape": self.shape.to_dict(),
            "tray_x_mm": self.tray_x_mm, "tray_y_mm": self.tray_y_mm,
            "wall_height_mm": self.wall_height_mm, "wall_thickness_mm": self.wall_thickness_mm,
            "friction": str(self.friction), "base_mu": self.friction.mu,
            "wall_mu": self.wall_mu,
            "tilt_deg": self.tilt_deg,
            "actions": list(self.actions),
            "settings": self.settings.to_dict(),
            # only when set: an instant tilt keeps the scene's dict, hash and cache keys of before
            **({"tilt_time_s": self.tilt_time_s} if self.tilt_time_s else {}),
        }

    @classmethod
    def from_dict(cls, data: dict) -> "Scene":
        """Build a scene from :meth:`to_dict` output or a hand-written JSON/TOML table.

        ``shape`` may be a spec string (``"allen-key"``) or a table with ``vertices`` (and optional
        ``name``, ``thickness_mm``, ``density_kg_m3``). Missing keys take their defaults.
        """
        if not isinstance(data, dict):
            raise ValueError(f"a scene must be a table/object, got {type(data).__name__}")
        known = {"format", "shape", "tray_x_mm", "tray_y_mm", "wall_height_mm", "wall_thickness_mm",
                 "friction", "base_mu", "wall_mu", "tilt_deg", "actions", "settings", "tilt_time_s"}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"unknown scene key(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
        if "shape" not in data:
            raise ValueError("scene has no 'shape'")
        sh = data["shape"]
        if isinstance(sh, str):
            shape = parse_shape(sh)
        elif isinstance(sh, dict):
            if "vertices" not in sh:
                raise ValueError("scene shape table has no 'vertices'")
            shape = None
            try:                      # a saved scene: the spec string rebuilds the identical shape
                cand = parse_shape(str(sh.get("name", "")))
                if cand.to_dict() == {**cand.to_dict(), **sh}:
                    shape = cand
            except (ValueError, OSError):
                pass
            if shape is None:
                kw = {k: sh[k] for k in ("thickness_mm", "density_kg_m3") if k in sh}
                shape = make_shape(sh["vertices"], name=str(sh.get("name", "polygon")), **kw)
        else:
            raise ValueError(f"scene shape must be a spec string or a table, got {type(sh).__name__}")
        kw = {k: data[k] for k in ("tray_x_mm", "tray_y_mm", "wall_height_mm", "wall_thickness_mm",
                                   "wall_mu", "tilt_deg", "tilt_time_s") if k in data}
        base_mu = data.get("base_mu", DEFAULT_MU)
        kw["friction"] = parse_friction(data.get("friction", base_mu), base_mu=base_mu)
        if "actions" in data:
            kw["actions"] = tuple(data["actions"]) if not isinstance(data["actions"], str) else data["actions"]
        if "settings" in data:
            kw["settings"] = SimSettings.from_dict(data["settings"])
        return cls(shape=shape, **kw)

    @classmethod
    def load(cls, path) -> "Scene":
        """Load a scene from a ``.json`` or ``.toml`` file."""
        path = os.fspath(path)
        try:
            if path.lower().endswith(".toml"):
                with open(path, "rb") as f:
                    data = tomllib.load(f)
            else:
                with open(path, encoding="utf-8") as f:
                    data = json.load(f)
        except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
            raise ValueError(f"scene file {path}: cannot parse: {exc}") from None
        return cls.from_dict(data)

    def save(self, path) -> None:
        """Write :meth:`to_dict` as JSON (atomically)."""
        from kruskal_markov.model import atomic_write_text

        atomic_write_text(path, json.dumps(self.to_dict(), indent=1))

    def content_hash(self) -> str:
        """SHA-256 (hex) of the canonical JSON of everything that can change a simulated result.

        Includes the shape's vertices and convex parts, tray, friction, tilt, actions, every
        simulator setting, the simulator's model version and the PyBullet version.
        """
        payload = dict(self.to_dict(), pybullet=_pybullet_version(), simulator=SIMULATOR_VERSION)
        if self.settings.engine == "planar":       # only then: every PyBullet key stays as it was
            payload["planar_engine"] = PLANAR_ENGINE_VERSION
        text = json.dumps(payload, sort_keys=True, separators=(",", ":"), allow_nan=False)
        return hashlib.sha256(text.encode("utf-8")).hexdigest()

    def with_settings(self, **changes) -> "Scene":
        """A copy with some simulator settings changed."""
        return replace(self, settings=replace(self.settings, **changes))

    def __eq__(self, other):
        return isinstance(other, Scene) and self.to_dict() == other.to_dict()

    def __hash__(self):
        return hash(self.content_hash())

    def __repr__(self):
        ramp = f" over {self.tilt_time_s:g} s" if self.tilt_time_s else ""
        return (f"Scene({self.shape.name!r}, tray {self.tray_x_mm:g}x{self.tray_y_mm:g} mm, "
                f"friction {self.friction}, tilt {self.tilt_deg:g} deg{ramp}, actions {','.join(self.actions)})")


#: the longest tilt time accepted (s).
MAX_TILT_TIME_S = 60.0


def check_tilt_time(val) -> float:
    """A tilt time in seconds: a finite number in [0, 60]; one-line ValueError otherwise."""
    if (isinstance(val, bool) or not isinstance(val, (int, float, np.integer, np.floating))
            or not math.isfinite(val) or not 0.0 <= val <= MAX_TILT_TIME_S):
        raise ValueError(f"tilt time must be a number of seconds in [0, {MAX_TILT_TIME_S:g}], got {val!r}")
    return float(val)


def _check_support_inside(shape: Shape, radius_mm: float) -> None:
    """Refuse a part too small for the simulator's support sphere (one line).

    The weight rests on a sphere of ``radius_mm`` under the centroid (docs/simulator.md). If the
    sphere reaches closer than its radius to the edge of the part's convex hull, it touches a wall
    before the part does, and the part stops short of the wall (a 0.5 mm square rested 0.7 mm
    off it with status ok). The centroid must therefore lie at least ``radius_mm`` inside the hull.
    """
    from shapely.geometry import MultiPoint, Point

    hull = MultiPoint([tuple(p) for p in shape.vertices]).convex_hull
    clearance = hull.exterior.distance(Point(0.0, 0.0)) if hull.contains(Point(0.0, 0.0)) else 0.0
    if clearance < radius_mm - 1e-9:
        raise ValueError(f"shape {shape.name!r} is too small for the simulator: its centroid lies "
                         f"{clearance:.2f} mm inside its outline, less than the {radius_mm:g} mm support "
                         f"sphere (the smallest square part is {2 * radius_mm:g} x {2 * radius_mm:g} mm)")


def scene_from_options(shape_spec, friction_spec=DEFAULT_MU, tilt_deg: float = DEFAULT_TILT_DEG,
                       actions=None, tray_mm=(200.0, 200.0), wall_mu=None,
                       settings: SimSettings | None = None, tilt_time_s: float = 0.0,
                       **setting_changes) -> Scene:
    """Build a :class:`Scene` from command-line style options.

    ``shape_spec`` is a shape spec string or a :class:`Shape`; ``friction_spec`` a number, a pair
    ``MU_S/MU_K`` or ``map:LEVEL:SEED[:MEAN]``; ``actions`` ``None`` (all eight), a list of names or ``"N,E,S"``;
    extra keyword arguments change :class:`SimSettings` fields. Raises a one-line ValueError on bad input.

    Parameters
    ----------
    shape_spec : str or Shape
        See :func:`~transition_builder.shapes.parse_shape`.
    friction_spec : float or str, default 0.3
        See :func:`~transition_builder.friction.parse_friction`.
    tilt_deg : float, default 30
        Tilt angle of every action.
    actions : None, str or list of str
        The action set (default all eight compass directions).
    tray_mm : (float, float), default (200, 200)
        Inner size of the tray.
    wall_mu : float, optional
        Friction of the walls (default: the floor's).
    settings : SimSettings, optional
        Simulator settings; ``**setting_changes`` change its fields.
    tilt_time_s : float, default 0
        Seconds the tray takes to rotate from level to its tilt (0: instant).

    Returns
    -------
    Scene
    """
    shape = shape_spec if isinstance(shape_spec, Shape) else parse_shape(shape_spec)
    settings = settings or SimSettings()
    if setting_changes:
        try:
            settings = replace(settings, **setting_changes)
        except TypeError as exc:
            raise ValueError(f"bad simulator setting: {exc}") from None
    tx, ty = tray_mm
    return Scene(shape=shape, tray_x_mm=tx, tray_y_mm=ty, friction=parse_friction(friction_spec),
                 wall_mu=wall_mu, tilt_deg=tilt_deg, actions=ACTIONS if actions is None else actions,
                 settings=settings, tilt_time_s=tilt_time_s)
