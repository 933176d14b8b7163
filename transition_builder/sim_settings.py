"""Simulator settings (:class:`SimSettings`): every knob of the tilt simulator that can change a result.

Results of a rigid-body engine are very sensitive to solver settings (docs/simulator.md: the final yaw
after 64 tilts differed by more than 3 rad between 10 and 50 solver iterations), so every field here
goes into :meth:`transition_builder.scene.Scene.content_hash`.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

from kruskal_markov.validation import check_fields

__all__ = ["SimSettings", "SIMULATOR_VERSION", "ContactModel", "parse_contact", "CONTACT_CHOICES", "LONG_STEPS",
           "LEGACY_CHOICES", "SETTING_CHOICES", "ENGINES", "parse_engine",
           "PLANAR_ENGINE_VERSION"]

#: the contact models ``--contact`` accepts (``legs:K`` with an integer K from 2 to 64).
CONTACT_CHOICES = "coulomb (default), sphere, legs:K"

#: bump when the simulator's model changes in a way that changes results (part of the scene hash;
#: re-exported by :mod:`transition_builder.sim`). 3: every task starts from freshly built worlds
#: (:meth:`TraySimulator.fresh_start`), so results no longer depend on which worker ran what; the
#: part's area integrals count grid points on its outline as inside (friction radius of some
#: triangles up by 0.1%). 4: the floor contact is a setting (``contact``), distributed Coulomb
#: friction by default.
SIMULATOR_VERSION = "planar-chain-4"
#: bump when the planar engine's results change (part of the content hash of planar scenes only).
PLANAR_ENGINE_VERSION = "planar-engine-1"
#: values of :attr:`SimSettings.contact_pairs`.
CONTACT_PAIRS = ("all", "needed")
#: values of :attr:`SimSettings.long_steps`.
LONG_STEPS = ("free", "free+steady", "free+steady-hold", "free+stick")
#: values of :attr:`SimSettings.part_links`.
PART_LINKS = ("per-part", "compound", "yaw-compound", "floating")

#: values of :attr:`SimSettings.engine` (``pybullet`` first: every scene before the planar engine had it).
ENGINES = ("pybullet", "planar")
#: the settings only the PyBullet engine has: a planar scene reads them as legacy (one key per physics)
_PYBULLET_ONLY = ("contact_pairs", "long_steps", "part_links")

#: the settings that take one of a few names. The first is the *legacy* value: the one every scene had
#: before the setting existed, left out of :meth:`SimSettings.to_dict` (so the content hash of those
#: scenes stays as it was) and read back by :meth:`SimSettings.from_dict` when a saved dict lacks it.
#: The defaults are not the first since the seventh session (``needed``, ``free+stick``, ``floating``:
#: docs/builder.md, "The lighter physics as the default"), so a new default scene records all three.
SETTING_CHOICES = {"contact_pairs": CONTACT_PAIRS, "long_steps": LONG_STEPS, "part_links": PART_LINKS, "engine": ENGINES}
#: the legacy value of every such setting: the physics of every scene up to the sixth session
LEGACY_CHOICES = {name: choices[0] for name, choices in SETTING_CHOICES.items()}
#: the fields every saved settings dict has had since the first simulator version: a dict with all of
#: them was written by :meth:`SimSettings.to_dict`, not by hand
_ALWAYS_SAVED = ("time_step_s", "substeps", "solver_iterations", "solver_residual_threshold", "rest_speed_mm_s",
                 "rest_angular_speed_rad_s", "dwell_s", "max_time_s", "support_radius_mm", "floor_clearance_mm",
                 "world_units_per_m", "contact_threshold_mm", "escape_tolerance_mm", "lift_tolerance_mm")


@dataclass(frozen=True)
class ContactModel:
    """A parsed floor-contact model: ``kind`` is ``"coulomb"``, ``"sphere"`` or ``"legs"`` (with
    ``legs`` = K). ``str()`` gives the canonical spelling (``"legs:4"``)."""

    kind: str
    legs: int = 0

    def __str__(self) -> str:
        return f"legs:{self.legs}" if self.kind == "legs" else self.kind

    @property
    def support_points(self) -> int:
        """Floor contacts of the part: K legs, else one sphere."""
        return self.legs if self.kind == "legs" else 1


def parse_engine(spec) -> str:
    """The canonical name of an engine (``planar`` or ``pybullet``); one-line :class:`ValueError` otherwise."""
    text = spec.strip().lower() if isinstance(spec, str) else None
    if text not in ENGINES:
        raise ValueError(f"unknown engine {spec!r}; expected one of {', '.join(ENGINES)}")
    return text


def parse_contact(spec) -> ContactModel:
    """Parse a contact spec (``coulomb``, ``sphere``, ``legs:K``); one-line :class:`ValueError` if
    it is none of them."""
    if isinstance(spec, ContactModel):
        return spec
    text = str(spec).strip().lower() if isinstance(spec, str) else None
    if text in ("coulomb", "sphere"):
        return ContactModel(text)
    if text is not None and text.startswith("legs:"):
        k = text[5:]
        if k.isdigit() and 2 <= int(k) <= 64:
            return ContactModel("legs", int(k))
    raise ValueError(f"unknown contact model {spec!r}; expected {CONTACT_CHOICES} (K an integer from 2 to 64)")


@dataclass(frozen=True)
class SimSettings:
    """Numerical settings of the PyBullet tilt simulator (see :mod:`transition_builder.sim`).

    Attributes
    ----------
    time_step_s : float
        Physics time step (s).
    substeps : int
        Physics steps per ``stepSimulation`` call (PyBullet ``numSubSteps``); the rest test runs once
        per call, i.e. every ``substeps * time_step_s`` seconds.
    solver_iterations : int
        Sequential-impulse solver iterations per step.
    solver_residual_threshold : float
        The solver stops iterating early once its residual is below this (PyBullet
        ``solverResidualThreshold``, in world units; PyBullet's default is 1e-7).
    rest_speed_mm_s : float
        The object is at rest while its centroid speed (mean over each rest-test interval) is
        below this (mm/s) ...
    rest_angular_speed_rad_s : float
        ... and its yaw rate is below this (rad/s) ...
    dwell_s : float
        ... continuously for this long (s).
    max_time_s : float
        A tilt still moving after this long is ``UNSETTLED``.
    contact : str
        The floor contact (:func:`parse_contact`). ``"coulomb"`` (the default): distributed
        Coulomb friction under uniform pressure, by quadrature over the footprint before every
        physics step, carried by one support sphere under the centroid (its lateral and spinning
        friction limits) plus an explicit force for the part one contact cannot give.
        ``"sphere"``: the same sphere with fixed limits (``mu`` and ``mu`` x friction radius, a
        "box" limit surface; the default up to simulator version 3). ``"legs:K"``: K "legs"
        (independent prismatic-z links with a sphere each) under K equal-area cells, each carrying
        its cell's weight (PyBullet's per-axis friction rows bias them away from Coulomb's law).
    footprint_points : int
        Quadrature points of the ``coulomb`` contact (about this many, equal area).
    friction_substeps : int
        Physics steps per update of the ``coulomb`` contact's friction (one ``stepSimulation`` call
        of this many internal steps; the explicit force persists over them). Must divide
        ``substeps``.
    free_flight_step_factor : int
        ``coulomb`` contact: while the part's bounding circle is clear of every wall (by more than
        twice the distance it covers in one rest-test interval plus the contact threshold), physics
        steps are this many times longer: the time step matters where a part slides along or pivots
        on a wall, not in free flight (docs/simulator.md). 1 turns it off.
    stick_speed_mm_s : float
        The ``coulomb`` contact sticks (limits of the friction "box", no explicit force) while the
        fastest point of the part moves slower than this; the stick-slip rule with a velocity
        threshold of the paper's Simscape contact. Far below the rest test's speeds.
    support_radius_mm : float
        Radius of the support sphere(s) that carry the floor contact.
    floor_clearance_mm : float
        Gap between the floor and the bottom of the part's prism; larger than
        ``contact_threshold_mm`` so the prism never makes floor contacts (it only touches walls).
    world_units_per_m : float
        Length scale of the PyBullet world (100: one world unit is a centimetre). PyBullet fixes
        the collision margin of a convex hull at 0.001 world units (1 mm in a metre world, 0.3 of a
        5 mm part); at 100 units per metre it is 0.01 mm, and the convex parts are inset by it so
        hull + margin is the true outline.
    contact_threshold_mm : float
        Bullet contact breaking threshold: contact points are made (and kept) up to this far
        apart. Large values (8 mm) kept stale wall contacts that made sharp corners jitter and
        creep along walls (4% of second tilts of ``triangle:1`` never settled); walls are 20 mm
        thick, so a step of up to 5.4 mm (1.3 m/s at 1/240 s) cannot pass through them.
    escape_tolerance_mm : float
        A rest pose whose outline is outside the tray by more than this is ``ESCAPED``.
    lift_tolerance_mm : float
        A part at rest more than this above the floor is ``TIPPED`` (lifted off it); one more than
        this below the floor during a tilt is ``ESCAPED`` (fell through it).
    contact_pairs : str
        Which collision pairs of the part's links Bullet tests: ``all`` (every link against the
        floor and the walls) or ``needed`` (the floor against the support(s) only, the walls against
        the prism only: the prism floats ``floor_clearance_mm`` above the floor and the supports lie
        inside its outline, so the pairs left out never carry a force; Bullet still made speculative
        contacts for them every step). Recorded in the cache key only when not ``all``
        (docs/builder.md, "Where a build's time goes").
    long_steps : str
        ``coulomb`` contact: when physics steps are ``free_flight_step_factor`` times longer.
        ``free`` (the default up to the sixth session): in free flight only. ``free+steady``: also while the contact is
        steady, i.e. its last friction update gave exactly the limits and the explicit force of the
        update before (the part sticks, or slides in pure translation: nothing the contact feeds
        Bullet changes). The friction is still updated once per call of the same simulated length,
        so a change is seen as soon as before, and the next call runs at the short step again.
        ``free+steady-hold``: the same, and a steady call runs twice as long (two long steps, one
        friction update), when the rest-test interval leaves room for it. ``free+stick``: long
        steps in free flight and while the contact sticks (steady with a non-zero spinning limit),
        not in pure translation (the default). The ``sphere`` and ``legs:K`` contacts have no
        long steps: for them the setting is always ``free``. ``free`` is left out of the cache key
        (docs/builder.md, "Longer steps while the contact is steady").
    part_links : str
        How the part's prism is made of links of its Featherstone chain (x, y, z slides, the yaw
        hinge, then fixed children). ``per-part`` (the default up to the sixth session, and always
        with ``legs:K``, whose legs hang from the chain's slides): one fixed link per convex part.
        ``compound``: one fixed link whose shape is the compound of all convex parts (one
        collision object in the broadphase instead of one per part). ``yaw-compound``: the
        compound is the yaw link's own shape and the support sphere a fixed child (the same
        number of links as ``compound``). ``floating``: no slides and no hinge: the part is the
        free base of the multibody (the support sphere its shape; the part's mass, its z inertia,
        and a roll and pitch inertia 1e8 times larger, so that it stays flat), with one
        fixed link per convex part (the default; with ``legs:K`` it reads as ``per-part``).
        ``per-part`` is left out of the cache key (docs/builder.md, "A lighter multibody").
    engine : str
        The physics engine: ``pybullet`` (:mod:`transition_builder.sim`) or ``planar`` (the compiled
        planar engine, :mod:`transition_builder.planar`; the coulomb contact only). ``pybullet`` is left
        out of the cache key, so every scene from before the planar engine keeps its key and reads back
        as ``pybullet``. With ``planar`` the PyBullet-only settings (``contact_pairs``, ``long_steps``,
        ``part_links``) change nothing and are left out of :meth:`to_dict` (one key per physics); they are
        kept, so that the same settings with ``engine="pybullet"`` are PyBullet's (docs/simulator.md, "The
        planar engine").
    """

    time_step_s: float = 1.0 / 480.0
    substeps: int = 8
    solver_iterations: int = 100
    solver_residual_threshold: float = 1e-4
    rest_speed_mm_s: float = 1.0
    rest_angular_speed_rad_s: float = 0.03
    dwell_s: float = 0.05
    max_time_s: float = 4.0
    contact: str = "coulomb"
    footprint_points: int = 300
    friction_substeps: int = 2
    free_flight_step_factor: int = 2
    stick_speed_mm_s: float = 0.5
    support_radius_mm: float = 1.0
    floor_clearance_mm: float = 4.0
    world_units_per_m: float = 100.0
    contact_threshold_mm: float = 2.0
    escape_tolerance_mm: float = 1.0
    lift_tolerance_mm: float = 2.0
    contact_pairs: str = "needed"
    long_steps: str = "free+stick"
    part_links: str = "floating"
    engine: str = "pybullet"

    def __post_init__(self):
        for f in fields(self):
            val = getattr(self, f.name)
            if f.name == "contact":
                object.__setattr__(self, f.name, str(parse_contact(val)))
                continue
            if f.name == "engine":
                object.__setattr__(self, f.name, parse_engine(val))
                continue
            if f.name in SETTING_CHOICES:
                if val not in SETTING_CHOICES[f.name]:
                    raise ValueError(f"SimSettings.{f.name} must be one of {', '.join(SETTING_CHOICES[f.name])}, got {val!r}")
                continue
            if f.type in ("int", int):
                if isinstance(val, bool) or not isinstance(val, int) or val < 1:
                    raise ValueError(f"SimSettings.{f.name} must be a positive integer, got {val!r}")
            else:
                if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val) or val <= 0:
                    raise ValueError(f"SimSettings.{f.name} must be a positive finite number, got {val!r}")
                object.__setattr__(self, f.name, float(val))
        if self.substeps % self.friction_substeps:
            raise ValueError(f"SimSettings.friction_substeps ({self.friction_substeps}) must divide "
                             f"substeps ({self.substeps})")
        k = self.free_flight_step_factor
        if self.substeps % (max(self.friction_substeps // k, 1) * k):
            raise ValueError(f"SimSettings.free_flight_step_factor ({k}) does not fit substeps ({self.substeps}) "
                             f"and friction_substeps ({self.friction_substeps})")
        if self.floor_clearance_mm <= self.contact_threshold_mm:
            raise ValueError("SimSettings.floor_clearance_mm must exceed contact_threshold_mm")
        self._canonical_choices()
        if self.max_time_s < self.dwell_s:
            raise ValueError("SimSettings.max_time_s must be at least dwell_s")

    def _canonical_choices(self) -> None:
        """Settings a physics does not have read as their legacy value, so ``with_settings(contact=...)``
        works from a default scene and equal physics has one key."""
        if self.part_links == "floating" and self.contact.startswith("legs"):
            object.__setattr__(self, "part_links", LEGACY_CHOICES["part_links"])
        if self.contact != "coulomb":
            object.__setattr__(self, "long_steps", LEGACY_CHOICES["long_steps"])
        if self.engine == "planar" and self.contact != "coulomb":
            raise ValueError(f"the planar engine has the coulomb contact only, not {self.contact}")

    def to_dict(self) -> dict:
        """All fields, JSON-able (``contact_pairs``, ``long_steps`` and ``part_links`` only when not at their
        legacy values, the first of their choices: the content hash of every scene simulated before
        the settings existed stays as it was)."""
        d = asdict(self)
        for name, legacy in LEGACY_CHOICES.items():
            if d[name] == legacy:
                del d[name]
        if self.engine == "planar":         # settings the planar engine does not have: one key per physics
            for name in _PYBULLET_ONLY:
                d.pop(name, None)
        return d

    @classmethod
    def from_dict(cls, data: dict) -> "SimSettings":
        """Inverse of :meth:`to_dict`; unknown keys are an error.

        A saved dict (one with every field of :data:`_ALWAYS_SAVED`) that lacks a
        setting of :data:`SETTING_CHOICES` had its legacy value; a hand-written, partial dict takes the
        defaults for whatever it leaves out."""
        if isinstance(data, dict) and "support_points" in data and "contact" not in data:  # before version 4
            data = dict(data)
            k = data.pop("support_points")
            data["contact"] = "sphere" if k == 1 else f"legs:{k}"
        if isinstance(data, dict) and all(name in data for name in _ALWAYS_SAVED):
            legacy = dict(LEGACY_CHOICES)
            if data.get("engine") == "planar":      # never saved by a planar scene: PyBullet's defaults
                for name in _PYBULLET_ONLY:
                    legacy.pop(name)
            data = {**legacy, **data}
        return cls(**check_fields(data, cls, "sim setting"))

    @property
    def check_interval_s(self) -> float:
        """Simulated time between two rest tests."""
        return self.time_step_s * self.substeps

    def finer_step(self, refine: int) -> dict:
        """The changes, for ``with_settings``, that divide the time step by ``refine`` while the rest
        test keeps its interval (``substeps`` multiplied by ``refine``): how every time-step
        convergence check in the project refines the simulator."""
        if isinstance(refine, bool) or not isinstance(refine, int) or refine < 1:
            raise ValueError(f"refine must be a positive integer, got {refine!r}")
        return {"time_step_s": self.time_step_s / refine, "substeps": self.substeps * refine}
