"""Options and parsing shared by several commands."""
from __future__ import annotations

import argparse
import os
import re

import numpy as np

from analysis.commands import InputError
from analysis.sequences import sequence_rng  # noqa: F401 - re-exported for the commands
from kruskal_markov.validation import action_position


def parse_sequence(text: str, action_names, rng: np.random.Generator | None = None) -> np.ndarray:
    """Parse ``"NE,S,W"`` (or ``"random:N"``, drawn from ``rng``, see :func:`sequence_rng`) into action indices.

    Raises :class:`InputError` naming the unknown action and the known ones.
    """
    names = list(action_names)
    text = text.strip()
    if text.startswith("random:"):
        try:
            length = int(text.split(":", 1)[1])
        except ValueError:
            raise InputError(f"bad sequence {text!r}: expected random:N with an integer N") from None
        if length < 0:
            raise InputError(f"bad sequence {text!r}: length must be >= 0")
        from kruskal_markov.limits import check_memory

        check_memory(length * 8.0 * 4, f"--sequence {text}", "use a shorter sequence")
        if rng is None:     # every random choice flows from --seed: the caller passes sequence_rng(seed)
            raise ValueError("parse_sequence: random:N needs the generator of --seed (sequence_rng)")
        return rng.integers(0, len(names), size=length).astype(np.int64)
    if text == "":
        return np.zeros(0, dtype=np.int64)
    try:
        return np.asarray([action_position(names, token.strip(), " in sequence")
                           for token in text.split(",")], dtype=np.int64)
    except ValueError as exc:
        raise InputError(str(exc)) from None


def add_seed(parser: argparse.ArgumentParser, default: int = 0) -> None:
    """Add ``--seed`` (every random choice of the command flows from it)."""
    parser.add_argument("--seed", type=int, default=default,
                        help=f"random seed; the same seed gives the same output (default {default})")


def add_model_source(parser: argparse.ArgumentParser) -> None:
    """Add the mutually exclusive ``--model PATH`` / ``--automaton FILE`` options."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--model", metavar="PATH", help="a built transition model (.npz)")
    group.add_argument("--automaton", metavar="FILE", help="an automaton in the JSON format of docs/commands.md")


def load_model_source(args: argparse.Namespace, required: bool = True):
    """Load the :class:`~kruskal_markov.model.TransitionModel` named by ``--model`` or ``--automaton``."""
    from kruskal_markov.automaton_json import model_from_automaton
    from kruskal_markov.model import TransitionModel

    if getattr(args, "model", None):
        return TransitionModel.load(args.model)
    if getattr(args, "automaton", None):
        return model_from_automaton(args.automaton)
    if required:
        raise InputError("one of --model PATH or --automaton FILE is required")
    return None


def parse_resolution(text: str) -> tuple[float, float]:
    """``"MM,DEG"`` (or one number for both) as floats; InputError otherwise."""
    m = re.fullmatch(r"\s*([0-9.eE+-]+)\s*(?:,\s*([0-9.eE+-]+)\s*)?", text or "")
    try:
        mm = float(m.group(1))
        deg = float(m.group(2)) if m.group(2) else mm
    except (AttributeError, ValueError):
        raise InputError(f"bad --resolution {text!r}: expected MM,DEG, e.g. 0.5,0.5") from None
    return mm, deg


def check_writable_file(path: str | None, option: str) -> None:
    """Fail before any work if ``path`` (the value of ``option``) cannot be written as a file.

    None means the option was not given; an empty string, a directory, a path whose directory does
    not exist, or one where a probe file cannot be created (or an existing file opened for
    writing) is an :class:`InputError` naming the option. The probe really writes: permission bits
    alone say nothing for root, read-only mounts or pseudo file systems.
    """
    import tempfile

    if path is None:
        return
    if not path.strip():
        raise InputError(f"{option} must be a file path, got an empty string")
    if os.path.isdir(path):
        raise InputError(f"{option} {path!r} is a directory, not a file")
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise InputError(f"{option} {path!r}: directory {directory} does not exist")
    try:
        if os.path.exists(path):
            with open(path, "ab"):
                pass
        fd, probe = tempfile.mkstemp(prefix=".kruskal-probe-", dir=directory)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise InputError(f"{option} {path!r} is not writable ({exc.strerror or type(exc).__name__})") from None


def check_positive(value: int, option: str) -> int:
    """``value`` if it is at least 1, else an :class:`InputError` naming ``option`` (one rule for
    ``--length``, ``--count``, ``--trials``, ``--sequences`` and ``--workers`` of every command)."""
    if value < 1:
        raise InputError(f"{option} must be at least 1, got {value}")
    return value


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0 (NaN, infinities and non-positive values are refused)."""
    import math

    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a finite positive number, got {text!r}")
    return value


def check_writable_dir(path: str, option: str) -> None:
    """Fail before any work if ``path`` (the value of ``option``) cannot be used as an output directory:
    empty, an existing non-directory, or under a directory that is not writable."""
    if not path.strip():
        raise InputError(f"{option} must name a directory")
    if os.path.exists(path) and not os.path.isdir(path):
        raise InputError(f"{option} {path!r} exists and is not a directory")
    parent = os.path.abspath(path)
    while not os.path.exists(parent):
        parent = os.path.dirname(parent)
    if not os.access(parent, os.W_OK):
        raise InputError(f"{option} {path!r}: {parent} is not writable")


def add_contact(parser: argparse.ArgumentParser) -> None:
    """``--contact`` and ``--engine``: the physics of the simulator, the same meaning on every command."""
    parser.add_argument("--contact", default=None, metavar="MODEL",
                        help="floor contact of the simulator: coulomb (distributed Coulomb friction, the "
                             "default), sphere (one support sphere, the default before simulator version 4) "
                             "or legs:K (K point legs); see docs/simulator.md")
    add_engine(parser)


def add_engine(parser: argparse.ArgumentParser) -> None:
    """``--engine planar|pybullet``: the physics engine of every simulation and build of the command."""
    from transition_builder.sim_settings import SimSettings
    default = SimSettings().engine
    parser.add_argument("--engine", default=None, metavar="ENGINE",
                        help=f"physics engine: planar (the compiled planar engine for flat parts) or pybullet "
                             f"(the reference); default {default}, chosen by the rule in docs/simulator.md")


def parse_engine_arg(text: str | None):
    """The canonical name of an ``--engine`` value (None stays None); one-line InputError."""
    if text is None:
        return None
    from transition_builder.sim_settings import parse_engine
    try:
        return parse_engine(text)
    except ValueError as exc:
        raise InputError(f"--engine: {exc}") from None


def physics_changes(args) -> dict:
    """The :class:`~transition_builder.sim_settings.SimSettings` changes of ``--contact`` and ``--engine``
    (only those given)."""
    out = {}
    contact = parse_contact_arg(getattr(args, "contact", None))
    if contact is not None:
        out["contact"] = contact
    engine = parse_engine_arg(getattr(args, "engine", None))
    if engine is not None:
        out["engine"] = engine
    return out


#: the help of ``--friction`` on every command that simulates.
FRICTION_HELP = ("floor friction: a number (Coulomb coefficient, default 0.3), a static/kinetic pair MU_S/MU_K "
                 "(e.g. 0.61/0.47; needs the coulomb contact) or map:LEVEL:SEED[:MEAN] (LEVEL low|medium|high, "
                 "MEAN a number or a pair; default 0.3)")


def add_tilt_time(parser: argparse.ArgumentParser) -> None:
    """``--tilt-time S``: the tray rotates from level to its tilt over S seconds (0, the default, is
    the instant tilt: the same models and cache keys as before the option existed)."""
    parser.add_argument("--tilt-time", type=float, default=None, metavar="S",
                        help="seconds the tray takes to rotate from level to its tilt, gravity following "
                             "(default 0: an instant tilt); see docs/simulator.md")


def parse_friction_arg(text: str):
    """The :class:`~transition_builder.friction.FrictionSpec` of a ``--friction`` value; one-line InputError."""
    from transition_builder.friction import parse_friction
    try:
        return parse_friction(text)
    except ValueError as exc:
        raise InputError(f"--friction: {exc}") from None


def _tilt_time_arg(args):
    value = getattr(args, "tilt_time", None)
    if value is None:
        return None
    from transition_builder.scene import check_tilt_time
    try:
        return check_tilt_time(value)
    except ValueError as exc:
        raise InputError(f"--tilt-time: {exc}") from None


def parse_contact_arg(text: str | None):
    """The canonical spelling of a ``--contact`` value (None stays None); one-line InputError."""
    if text is None:
        return None
    from transition_builder.sim_settings import parse_contact
    try:
        return str(parse_contact(text))
    except ValueError as exc:
        raise InputError(f"--contact: {exc}") from None


def scene_from_args(args):
    """The scene of --scene (a scene file; --shape/--friction/--tilt-deg/--tilt-time replace its
    parts) or of --shape/--friction/--tilt-deg/--tilt-time."""
    from transition_builder.scene import Scene, scene_from_options

    if args.scene:
        from dataclasses import replace

        from transition_builder.shapes import parse_shape

        if not os.path.isfile(args.scene):
            raise InputError(f"scene file {args.scene!r} does not exist")
        scene = Scene.load(args.scene)
        changes = {}
        if args.shape is not None:
            changes["shape"] = parse_shape(args.shape)
        if args.friction is not None:
            changes["friction"] = parse_friction_arg(args.friction)
        if args.tilt_deg is not None:
            changes["tilt_deg"] = args.tilt_deg
        if _tilt_time_arg(args) is not None:
            changes["tilt_time_s"] = _tilt_time_arg(args)
        physics = physics_changes(args)
        if physics:
            try:
                changes["settings"] = replace(scene.settings, **physics)
            except ValueError as exc:
                raise InputError(str(exc)) from None
        return replace(scene, **changes) if changes else scene
    kw = dict(physics_changes(args))
    if args.friction is not None:
        kw["friction_spec"] = parse_friction_arg(args.friction)
    if args.tilt_deg is not None:
        kw["tilt_deg"] = args.tilt_deg
    if _tilt_time_arg(args) is not None:
        kw["tilt_time_s"] = _tilt_time_arg(args)
    if args.shape is not None and not args.shape.strip():
        raise InputError("--shape is empty; name a shape, e.g. allen-key (the default when --shape is not given)")
    return scene_from_options(args.shape or "allen-key", **kw)


def parse_weights(text: str | None, actions) -> list[float] | None:
    """``--weights``: comma-separated numbers in action order, or ``NAME=W`` pairs (other actions 0).

    None when the option was not given; :class:`InputError` naming the problem otherwise (the
    values themselves are checked by :func:`kruskal_markov.validation.action_weights`).
    """
    if text is None:
        return None
    names = list(actions)
    parts = [p.strip() for p in text.split(",") if p.strip()]
    if parts and all("=" in p for p in parts):
        w = [0.0] * len(names)
        for p in parts:
            name, val = p.split("=", 1)
            try:
                w[action_position(names, name.strip(), " in --weights")] = float(val)
            except ValueError as exc:
                msg = str(exc) if str(exc).startswith("unknown action") else f"bad --weights entry {p!r}: {exc}"
                raise InputError(msg) from None
        return w
    try:
        w = [float(p) for p in parts]
    except ValueError:
        raise InputError(f"bad --weights {text!r}: expected {len(names)} comma-separated numbers or NAME=W "
                         f"pairs") from None
    if len(w) != len(names):
        raise InputError(f"--weights has {len(w)} values, the model has {len(names)} actions ({','.join(names)})")
    return w


def add_interval_options(parser) -> None:
    """``--draws`` and ``--structural-delta``: the model-uncertainty intervals of the answers."""
    parser.add_argument("--draws", type=int, default=20,
                        help="posterior draws of the model's rows for the answers' model intervals (default 20; 0: none)")
    parser.add_argument("--structural-delta", type=float, default=None, metavar="D",
                        help="relative structural error of the model intervals (default: the model's own -- "
                             "its `validate --calibrate` value, else 0.105 for a built model, none for an "
                             "automaton; 0: posterior only)")


def interval_settings(args) -> dict:
    """The checked ``draws`` and ``structural_delta`` of :func:`add_interval_options` (InputError when bad)."""
    import math

    if isinstance(args.draws, bool) or args.draws < 0:
        raise InputError(f"--draws must be a non-negative integer, got {args.draws}")
    d = args.structural_delta
    if d is not None and not (math.isfinite(d) and d >= 0):
        raise InputError(f"--structural-delta must be a non-negative number, got {args.structural_delta}")
    return {"draws": args.draws, "structural_delta": d}
