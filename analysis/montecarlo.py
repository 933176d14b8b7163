"""Direct Monte Carlo through a tilt sequence: the paper's method, and the ground truth for models.

``M`` start poses are drawn uniformly from the collision-free configuration space (from ``seed``, in
the parent process), and every trial is driven through the same action sequence in the physics
engine (Mannam et al., Sec. III-B and IV). After every tilt the plug-in Shannon entropy (bits) of
the surviving trials' poses on the report grid is recorded. A trial whose tilt faults (tipped,
escaped, unsettled, invalid) is counted once, by kind, and dropped from all later steps.

Trials are split into fixed-size chunks (the chunk size depends only on ``M``) and run by an
executor (:mod:`transition_builder.executors`: this process, spawned local worker processes, or a
Dask cluster), each worker building its simulator once per scene. Start poses come from the seed,
process noise (``noise``, :mod:`transition_builder.noise`) from the seed, the global trial index and
the step, and the physics is deterministic, so the result is the same for any number of workers and
any executor.

Local workers are *spawned* (never forked: a forked PyBullet client is not safe) and kept between
calls, because starting them costs about a second; :func:`shutdown_workers` stops them (it also runs
at exit). As with any spawned pool, a script that calls :func:`run_direct` with ``workers > 1`` must
guard its top level with ``if __name__ == "__main__":``.
"""
from __future__ import annotations

import csv
import math
import os
import sys
import tempfile
from dataclasses import dataclass, field

import numpy as np

from kruskal_markov._checks import check_int, is_int
from kruskal_markov.entropy import histogram_entropy_bits
from kruskal_markov.limits import check_memory
from kruskal_markov.validation import action_position
from transition_builder.executors import (
    Executor,
    SerialExecutor,
    make_executor,
    shutdown_workers,
    simulator_for,
)
from transition_builder.grid import ReportGrid, parse_grid
from transition_builder.noise import NoiseSpec, check_noise_for_tray, noise_rng, perturb_poses
from transition_builder.sampling import sample_start_poses
from transition_builder.status import INVALID, OK, STATUS_NAMES

__all__ = [
    "POSES_CSV_COLUMNS",
    "DirectResult",
    "PoseRecords",
    "entropy_by_step",
    "read_poses_csv",
    "report_grid_for",
    "resolve_sequence",
    "run_direct",
    "shutdown_workers",
    "summarise_trials",
    "write_poses_csv",
]

#: columns of the ``--poses`` CSV file (docs/commands.md).
POSES_CSV_COLUMNS = ("trial", "step", "x_mm", "y_mm", "theta_rad", "status")


# ----------------------------------------------------------------------------------------------
# scene access (the Scene class lives in transition_builder.scene)
# ----------------------------------------------------------------------------------------------

def _tray_size(scene) -> tuple[float, float]:
    """The tray's inner size (mm) of a :class:`~transition_builder.scene.Scene` (or a stand-in
    with ``tray_x_mm`` and ``tray_y_mm``)."""
    try:
        return float(scene.tray_x_mm), float(scene.tray_y_mm)
    except AttributeError:
        raise TypeError(f"cannot read the tray size from {type(scene).__name__}: it needs tray_x_mm "
                        f"and tray_y_mm") from None


def _action_names(scene) -> tuple[str, ...]:
    actions = getattr(scene, "actions", None)
    if actions is None:
        raise TypeError(f"{type(scene).__name__} has no action set")
    return tuple(str(a) for a in actions)


def report_grid_for(scene, grid="4x4x4", theta_offset: float | None = None) -> ReportGrid:
    """The report grid of ``scene``: ``grid`` ("AxBxG" or a :class:`ReportGrid`) over its tray,
    theta modulo the shape's symmetry order."""
    if isinstance(grid, ReportGrid):
        return grid
    a, b = _tray_size(scene)
    nx, ny, nt = parse_grid(grid) if isinstance(grid, str) else tuple(int(g) for g in grid)
    return ReportGrid(a, b, nx, ny, nt, symmetry_order=scene.shape.symmetry_order, theta_offset=theta_offset)


def resolve_sequence(sequence, action_names) -> np.ndarray:
    """Action indices (int64) of ``sequence``: names (``"NE"``), indices, or a ``"NE,S,W"`` string."""
    names = [str(n) for n in action_names]
    if isinstance(sequence, str):
        sequence = [t for t in (s.strip() for s in sequence.split(",")) if t]
    out = []
    for a in sequence:
        if isinstance(a, (str, np.str_)):
            out.append(action_position(names, str(a), " in sequence"))
        elif isinstance(a, (int, np.integer)) and not isinstance(a, bool):
            if not 0 <= int(a) < len(names):
                raise ValueError(f"action index {int(a)} out of range [0, {len(names)})")
            out.append(int(a))
        else:
            raise ValueError(f"bad action {a!r} in sequence: expected a name or an index")
    return np.asarray(out, dtype=np.int64)


# ----------------------------------------------------------------------------------------------
# result
# ----------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class DirectResult:
    """Outcome of :func:`run_direct`.

    Attributes
    ----------
    sequence : ndarray (N,) int64
        Action indices into ``action_names``.
    action_names : tuple of str
        The scene's action names.
    poses : ndarray (M, N+1, 3)
        Pose of every trial after every tilt (step 0 = start); NaN from a trial's fault onwards.
    status : ndarray (M, N+1) int8
        Status code per trial and step (``transition_builder.status``); from the faulting step on
        it holds the fault's code.
    fault_step : ndarray (M,) int64
        The step at which a trial faulted, -1 if never.
    entropy_bits : ndarray (N+1,)
        Report-grid entropy of the surviving trials after every tilt.
    surviving : ndarray (N+1,) int64
        Number of surviving trials at every step.
    occupied_voxels : ndarray (N+1,) int64
        Number of occupied report voxels at every step.
    faults : dict
        Faulted trials by kind ``{"tipped": .., "escaped": .., "unsettled": .., "invalid": ..}``.
    grid : ReportGrid
    seed : int or None
    noise : NoiseSpec
        The process noise of the run (``str(noise)`` is its spec, ``"none"`` for none).
    """

    sequence: np.ndarray
    action_names: tuple
    poses: np.ndarray
    status: np.ndarray
    fault_step: np.ndarray
    entropy_bits: np.ndarray
    surviving: np.ndarray
    occupied_voxels: np.ndarray
    faults: dict
    grid: ReportGrid
    seed: int | None = None
    extra: dict = field(default_factory=dict)
    noise: NoiseSpec = field(default_factory=lambda: NoiseSpec("none"))

    @property
    def trials(self) -> int:
        return int(self.poses.shape[0])

    @property
    def tilts(self) -> int:
        """Length N of the sequence."""
        return len(self.sequence)

    @property
    def tilts_simulated(self) -> int:
        """Tilts actually simulated (a faulted trial stops at its fault)."""
        return int(self.surviving[:-1].sum()) if self.tilts else 0

    @property
    def sequence_names(self) -> list[str]:
        return [self.action_names[i] for i in self.sequence]

    def to_json(self) -> dict:
        """Deprecated alias of :meth:`to_dict` (every result serialises with ``to_dict``)."""
        import warnings

        warnings.warn("DirectResult.to_json is deprecated; use to_dict", DeprecationWarning, stacklevel=2)
        return self.to_dict()

    def to_dict(self) -> dict:
        """The ``kruskal simulate`` JSON keys (without ``seconds``)."""
        return {
            "entropy_bits": [float(h) for h in self.entropy_bits],
            "trials": self.trials,
            "tilts": self.tilts,
            "faults": dict(self.faults),
            "sequence": self.sequence_names,
            "occupied_voxels": [int(v) for v in self.occupied_voxels],
            "surviving": [int(v) for v in self.surviving],
            "tilts_simulated": self.tilts_simulated,
            "grid": f"{self.grid.nx}x{self.grid.ny}x{self.grid.ntheta}",
            "theta_offset": self.grid.theta_offset,
            "symmetry_order": self.grid.symmetry_order,
            "seed": self.seed,
            "noise": str(self.noise),
            **self.extra,
        }


# ----------------------------------------------------------------------------------------------
# workers (the executors live in transition_builder.executors)
# ----------------------------------------------------------------------------------------------

def _tilt(sim, poses: np.ndarray, action_name: str) -> tuple[np.ndarray, np.ndarray]:
    rest, status = sim.tilt(poses, action_name)
    rest = np.array(rest, dtype=np.float64).reshape(len(poses), 3)
    status = np.array(status, dtype=np.int64).reshape(len(poses))
    if status.size and (status.min() < 0 or status.max() >= len(STATUS_NAMES)):
        raise RuntimeError(f"simulator returned unknown status codes {sorted(set(status.tolist()))}")
    bad_pose = (status == OK) & ~np.all(np.isfinite(rest), axis=1)
    status[bad_pose] = INVALID  # a fault is never returned as a pose
    rest[status != OK] = np.nan
    return rest, status


def _run_chunk(sim, starts: np.ndarray, sequence_names: list[str], scene=None, noise: NoiseSpec | None = None,
               noise_seed: int = 0, first_trial: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Drive a chunk of trials through the sequence; returns poses (c, N+1, 3), status (c, N+1).

    With ``noise`` (not zero), the pose of trial ``first_trial + i`` is perturbed before tilt ``k``
    (1..N) with :func:`~transition_builder.noise.noise_rng` ``(noise_seed, first_trial + i, k)``;
    the recorded poses are the rest poses (and the start poses), never the perturbed ones.
    """
    c, n = len(starts), len(sequence_names)
    poses = np.full((c, n + 1, 3), np.nan)
    status = np.zeros((c, n + 1), dtype=np.int8)
    poses[:, 0] = starts
    alive = np.ones(c, dtype=bool)
    for k, name in enumerate(sequence_names, start=1):
        status[~alive, k] = status[~alive, k - 1]
        idx = np.flatnonzero(alive)
        if idx.size == 0:
            continue
        before = poses[idx, k - 1]
        if noise is not None and not noise.is_zero:
            before = perturb_poses(scene, before, noise,
                                   [noise_rng(noise_seed, first_trial + int(i), k) for i in idx])
        rest, st = _tilt(sim, before, name)
        poses[idx, k] = rest
        status[idx, k] = st
        alive[idx[st != OK]] = False
    return poses, status


def _worker_chunk(scene, factory, starts, sequence_names, noise=None, noise_seed=0, first_trial=0):
    sim = simulator_for(scene, factory)
    fresh = getattr(sim, "fresh_start", None)
    if fresh is not None:
        fresh()              # a chunk's result depends on its own trials only
    return _run_chunk(sim, starts, sequence_names, scene, noise, noise_seed, first_trial)


def _chunk_size(trials: int) -> int:
    """Trials per chunk: a function of ``trials`` only (so results never depend on the workers)."""
    return int(min(256, max(16, math.ceil(trials / 64))))


# ----------------------------------------------------------------------------------------------
# the driver
# ----------------------------------------------------------------------------------------------

def run_direct(scene, sequence, trials: int, seed: int | None = 0, workers: int | None = None,
               progress: bool | None = False, *, grid="4x4x4", theta_offset: float | None = None,
               start_poses=None, simulator_factory=None, noise=None, executor: Executor | None = None,
               scheduler: str | None = None) -> DirectResult:
    """Direct Monte Carlo: ``trials`` uniform random start poses driven through ``sequence``.

    Parameters
    ----------
    scene : transition_builder.scene.Scene
        Tray, shape, friction, tilt angle, actions, simulator settings.
    sequence : sequence of str or int, or str
        Action names (``["NE", "S"]`` or ``"NE,S"``) or indices into ``scene.actions``.
    trials : int
        Number of trials M.
    seed : int
        Seed of the start poses (``numpy.random.default_rng(seed)``, drawn in this process) and of
        the process noise (None: random start poses, noise seed 0).
    workers : int or None
        Worker processes; None uses every available core, 1 runs in this process. Not used when
        ``executor`` or ``scheduler`` is given.
    progress : bool or None
        Show a tqdm progress bar on standard error; None shows it only if stderr is a terminal.
    grid : str or ReportGrid
        Report grid, ``"AxBxG"`` (default the paper's ``"4x4x4"``).
    theta_offset : float or None
        Theta bin offset of the report grid (None: bins centred on the tray axes).
    start_poses : array (M, 3), optional
        Explicit start poses instead of sampled ones (``trials`` must match, or be None).
    simulator_factory : callable, optional
        ``factory(scene)`` returning an object with ``.tilt(poses, action_name) -> (rest, status)``;
        default :class:`transition_builder.sim.TraySimulator`. Must be picklable unless run in
        this process.
    noise : NoiseSpec or str, optional
        Process noise (:mod:`transition_builder.noise`), applied to every trial before every tilt:
        trial ``t`` before tilt ``k`` draws from ``noise_rng(seed, t, k)``, so the result does not
        depend on the executor. ``None``, ``"none"`` and ``"pose:0,0"`` give identical results.
    executor : transition_builder.executors.Executor, optional
        Where the chunks run (the caller closes it). Default: ``make_executor(workers, scheduler)``
        (one chunk, or ``workers=1``: this process).
    scheduler : str, optional
        Address of a Dask scheduler (needs ``kruskal[distributed]``); the client made for it is
        closed before returning.

    Returns
    -------
    DirectResult
    """
    names = _action_names(scene)
    seq = resolve_sequence(sequence, names)
    if isinstance(trials, (int, np.integer)) and trials > 0:
        check_memory(float(trials) * (seq.size + 1) * 26 * 2, f"{trials:,} trials of {seq.size:,} tilts",
                     "use fewer --trials or a shorter sequence")
    rgrid = report_grid_for(scene, grid, theta_offset)
    noise = check_noise_for_tray(noise, scene.tray_x_mm, scene.tray_y_mm)
    noise_seed = 0 if seed is None else seed
    if not noise.is_zero and not (is_int(noise_seed) and noise_seed >= 0):
        raise ValueError(f"process noise needs a non-negative integer seed, got {seed!r}")
    if executor is not None and not isinstance(executor, Executor):
        raise ValueError(f"executor must be a transition_builder.executors.Executor, got {type(executor).__name__}")
    starts = _trial_starts(scene, trials, start_poses, seed)
    trials = len(starts)
    if workers is not None:
        check_int(workers, "workers", lo=1)

    seq_names = [names[i] for i in seq]
    size = _chunk_size(trials)
    bounds = [(lo, min(lo + size, trials)) for lo in range(0, trials, size)]
    poses = np.full((trials, len(seq) + 1, 3), np.nan)
    status = np.zeros((trials, len(seq) + 1), dtype=np.int8)
    poses[:, 0] = starts
    chunk_noise = None if noise.is_zero else noise  # a zero noise takes no perturbation path at all
    if len(seq):
        tasks = [(scene, simulator_factory, starts[lo:hi], seq_names, chunk_noise, int(noise_seed), lo)
                 for lo, hi in bounds]
        _run_chunks(tasks, bounds, poses, status, executor, scheduler, workers, progress)
    return summarise_trials(seq, names, poses, status, rgrid, seed, noise)


def _trial_starts(scene, trials, start_poses, seed) -> np.ndarray:
    """The (M, 3) start poses: ``start_poses`` checked (M must equal ``trials`` unless that is
    None), or ``trials`` poses drawn uniformly from the free configuration space with ``seed``."""
    if start_poses is not None:
        starts = np.array(start_poses, dtype=np.float64)
        if starts.ndim != 2 or starts.shape[1] != 3:
            raise ValueError(f"start poses must be an (M, 3) array, got shape {starts.shape}")
        if trials is not None and int(trials) != len(starts):
            raise ValueError(f"trials = {trials} but {len(starts)} start poses were given")
        if not np.all(np.isfinite(starts)):
            raise ValueError("start poses must be finite")
        return starts
    check_int(trials, "trials", lo=1)
    a, b = _tray_size(scene)
    return sample_start_poses(scene.shape, a, b, int(trials), np.random.default_rng(seed))


def _run_chunks(tasks, bounds, poses, status, executor, scheduler, workers, progress) -> None:
    """Run the chunk ``tasks`` (rows ``bounds``) on ``executor`` (default: a Dask client for
    ``scheduler``, this process for one chunk or one worker, else the kept local pool) and fill
    ``poses`` and ``status`` in place, with a progress bar when asked (None: on a terminal)."""
    owned = None
    if executor is None:
        if scheduler is not None:
            executor = owned = make_executor(workers, scheduler)
        elif len(bounds) == 1 or workers == 1:
            executor = SerialExecutor()
        else:
            executor = make_executor(workers)  # the local pool is kept: no churn between calls
    if progress is None:
        progress = sys.stderr.isatty()
    bar = None
    try:
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=int(bounds[-1][1]), unit="trial", desc="simulate", file=sys.stderr, leave=False)
        for i, (p, s) in executor.map(_worker_chunk, tasks):
            lo, hi = bounds[i]
            poses[lo:hi], status[lo:hi] = p, s
            if bar is not None:
                bar.update(hi - lo)
    finally:
        if bar is not None:
            bar.close()
        if owned is not None:
            owned.close()


def summarise_trials(seq, names, poses, status, rgrid: ReportGrid, seed, noise: NoiseSpec) -> DirectResult:
    """A :class:`DirectResult` from every trial's poses and status codes (entropy, survivors, faults)."""
    n_steps = poses.shape[1]
    faulted = status != OK
    fault_step = np.where(faulted.any(axis=1), faulted.argmax(axis=1), -1).astype(np.int64)
    entropy = np.zeros(n_steps)
    surviving = np.zeros(n_steps, dtype=np.int64)
    occupied = np.zeros(n_steps, dtype=np.int64)
    for k in range(n_steps):
        ok = status[:, k] == OK
        surviving[k] = int(ok.sum())
        if surviving[k]:
            counts = rgrid.counts(poses[ok, k])
            entropy[k] = histogram_entropy_bits(counts)
            occupied[k] = int((counts > 0).sum())
    first = status[np.arange(len(status)), np.maximum(fault_step, 0)]
    faults = {name: int(np.sum((fault_step >= 0) & (first == code)))
              for code, name in enumerate(STATUS_NAMES) if code != OK}
    return DirectResult(sequence=np.asarray(seq, dtype=np.int64), action_names=tuple(names), poses=poses,
                        status=status, fault_step=fault_step, entropy_bits=entropy, surviving=surviving,
                        occupied_voxels=occupied, faults=faults, grid=rgrid, seed=seed, noise=noise)


# ----------------------------------------------------------------------------------------------
# pose files
# ----------------------------------------------------------------------------------------------

def write_poses_csv(path, result: DirectResult) -> str:
    """Write every trial's pose after every tilt to ``path`` (CSV, atomically).

    Columns ``trial,step,x_mm,y_mm,theta_rad,status``; step 0 is the start pose; status is a name
    (``ok, tipped, escaped, unsettled, invalid``). A faulted trial has one row at its faulting step
    with empty pose fields, and no rows after it. Returns the path.

    Parameters
    ----------
    path : str or path-like
        Where to write.
    result : DirectResult
        A direct simulation run (:func:`run_direct`; every trial's poses are kept).

    Returns
    -------
    str
        ``path``.
    """
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    os.makedirs(directory, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".poses-", suffix=".csv.tmp", dir=directory)
    try:
        with os.fdopen(fd, "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(POSES_CSV_COLUMNS)
            n_steps = result.poses.shape[1]
            for t in range(result.trials):
                last = result.fault_step[t] if result.fault_step[t] >= 0 else n_steps - 1
                for k in range(last + 1):
                    code = int(result.status[t, k])
                    if code == OK:
                        x, y, th = (repr(float(v)) for v in result.poses[t, k])
                    else:
                        x = y = th = ""
                    w.writerow((t, k, x, y, th, STATUS_NAMES[code]))
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


@dataclass(frozen=True)
class PoseRecords:
    """Rows of a ``--poses`` CSV file: one (trial, step, pose, status) per row."""

    trial: np.ndarray   # (r,) int64
    step: np.ndarray    # (r,) int64
    poses: np.ndarray   # (r, 3) float64, NaN where the status is a fault
    status: np.ndarray  # (r,) int8 status codes

    @property
    def n_steps(self) -> int:
        """Number of steps (max step + 1; 0 for an empty file)."""
        return int(self.step.max()) + 1 if self.step.size else 0

    @property
    def trials(self) -> int:
        return int(np.unique(self.trial).size)


def read_poses_csv(path) -> PoseRecords:
    """Read a ``--poses`` CSV file (see :func:`write_poses_csv`), e.g. a real robot's camera log.

    The columns ``trial, step, x_mm, y_mm, theta_rad`` are required (any order, extra columns are
    ignored); ``status`` is optional (default ``ok``). Raises :class:`ValueError` naming the line
    and the problem: a missing column, a non-integer trial or step, a non-number coordinate, an
    unknown status, a repeated (trial, step), or an ``ok`` row without a finite pose.

    Parameters
    ----------
    path : str or path-like
        The CSV file.

    Returns
    -------
    PoseRecords
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ValueError(f"poses file {path!r} does not exist")
    status_code = {name: code for code, name in enumerate(STATUS_NAMES)}
    trials, steps, rows, codes = [], [], [], []
    with open(path, newline="", encoding="utf-8") as fh:
        reader = csv.reader(fh)
        try:
            header = next(reader)
        except StopIteration:
            raise ValueError(f"poses file {path!r} is empty") from None
        header = [h.strip().lower() for h in header]
        required = POSES_CSV_COLUMNS[:5]
        missing = [c for c in required if c not in header]
        if missing:
            raise ValueError(f"poses file {path!r}: missing column(s) {', '.join(missing)}; "
                             f"expected {','.join(POSES_CSV_COLUMNS)}")
        col = {c: header.index(c) for c in POSES_CSV_COLUMNS if c in header}
        seen = set()
        for lineno, row in enumerate(reader, start=2):
            if not row or all(not c.strip() for c in row):
                continue
            if len(row) < len(header):
                raise ValueError(f"poses file {path!r} line {lineno}: expected {len(header)} fields, got {len(row)}")
            try:
                t = int(row[col["trial"]])
                k = int(row[col["step"]])
            except ValueError:
                raise ValueError(f"poses file {path!r} line {lineno}: trial and step must be integers") from None
            if k < 0:
                raise ValueError(f"poses file {path!r} line {lineno}: step must be >= 0, got {k}")
            name = row[col["status"]].strip().lower() if "status" in col else "ok"
            if name not in status_code:
                raise ValueError(f"poses file {path!r} line {lineno}: unknown status {name!r}; "
                                 f"expected one of {','.join(STATUS_NAMES)}")
            pose = []
            for c in ("x_mm", "y_mm", "theta_rad"):
                text = row[col[c]].strip()
                if text == "" or text.lower() == "nan":
                    pose.append(math.nan)
                    continue
                try:
                    pose.append(float(text))
                except ValueError:
                    raise ValueError(f"poses file {path!r} line {lineno}: {c} {text!r} is not a number") from None
            if status_code[name] == OK and not all(math.isfinite(v) for v in pose):
                raise ValueError(f"poses file {path!r} line {lineno}: status ok needs a finite pose")
            if (t, k) in seen:
                raise ValueError(f"poses file {path!r} line {lineno}: trial {t} step {k} appears twice")
            seen.add((t, k))
            trials.append(t)
            steps.append(k)
            rows.append(pose)
            codes.append(status_code[name])
    return PoseRecords(trial=np.asarray(trials, dtype=np.int64), step=np.asarray(steps, dtype=np.int64),
                       poses=np.asarray(rows, dtype=np.float64).reshape(-1, 3),
                       status=np.asarray(codes, dtype=np.int8))


def entropy_by_step(records: PoseRecords, grid: ReportGrid) -> np.ndarray:
    """Report-grid entropy (bits) of the ``ok`` poses at every step 0..max step of ``records``.

    Parameters
    ----------
    records : PoseRecords
        Poses by trial and step (:func:`read_poses_csv`).
    grid : ReportGrid
        The report grid.

    Returns
    -------
    ndarray
        Entropy in bits at steps 0, 1, ...
    """
    check_memory(records.n_steps * 8.0 * 4, f"poses with steps up to {records.n_steps - 1:,}",
                 "the step column counts tilts from 0")
    out = np.zeros(records.n_steps)
    for k in range(records.n_steps):
        sel = (records.step == k) & (records.status == OK)
        if sel.any():
            out[k] = histogram_entropy_bits(grid.counts(records.poses[sel]))
    return out
