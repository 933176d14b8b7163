"""One tilt engine: every tilt the project runs on an executor goes through this module.

Two kinds of task, one per job (issue 42):

- :func:`tilt_task`: tilt a batch of poses under one action, each pose first perturbed by the
  noise stream named by its key (:func:`transition_builder.noise.noise_rng`); the model builder's
  work (:mod:`transition_builder.builder`).
- :func:`trial_task`: drive a batch of trials through an action sequence (direct Monte Carlo,
  :func:`run_direct`, the paper's method and the ground truth for models).

Both run on one simulator cache (:func:`transition_builder.simulators.simulator_for`), start every
task on fresh worlds (:meth:`transition_builder.sim.TraySimulator.fresh_start`) and pass every
tilt through the same status check (:func:`checked_tilt`: unknown codes are an error, a fault is
never returned as a pose). Work is cut into tasks by one chunker (:func:`chunk_bounds`), whose
sizes depend on the work alone (48 tilts per builder task, :func:`trial_chunk_size` trials per
direct task), and run by one context, :class:`TiltEngine`, which owns (or borrows) the executor and
the progress bar. So every result is the same on every executor and for any number of workers.

:func:`run_direct` and :class:`DirectResult` live here (``analysis.montecarlo`` re-exports them).

Direct Monte Carlo: ``M`` start poses are drawn uniformly from the collision-free configuration
space (from ``seed``, in the parent process), and every trial is driven through the same action
sequence in the physics engine (Mannam et al., Sec. III-B and IV). After every tilt the plug-in
Shannon entropy (bits) of the surviving trials' poses on the report grid is recorded. A trial whose
tilt faults (tipped, escaped, unsettled, invalid) is counted once, by kind, and dropped from all
later steps. Process noise (``noise``, :mod:`transition_builder.noise`) comes from the seed, the
global trial index and the step. Local workers are *spawned* and kept between calls
(:mod:`transition_builder.executors`); a script that calls :func:`run_direct` with ``workers > 1``
must guard its top level with ``if __name__ == "__main__":``.
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field

import numpy as np

from kruskal_markov.entropy import histogram_entropy_bits
from kruskal_markov.limits import check_memory
from kruskal_markov.validation import action_position, check_int, is_int
from transition_builder.executors import Executor, SerialExecutor, make_executor
from transition_builder.grid import ReportGrid, parse_grid
from transition_builder.noise import (
    NoiseSpec,
    check_noise_for_tray,
    noise_rng,
    parse_noise,
    perturb_pose,
    perturb_poses,
)
from transition_builder.sampling import sample_start_poses
from transition_builder.simulators import simulator_for
from transition_builder.status import INVALID, OK, STATUS_NAMES

__all__ = [
    "TILT_CHUNK",
    "DirectResult",
    "TiltEngine",
    "checked_tilt",
    "chunk_bounds",
    "report_grid_for",
    "resolve_sequence",
    "run_direct",
    "run_tilts",
    "stream_tilts",
    "summarise_trials",
    "tilt_task",
    "trial_chunk_size",
    "trial_task",
]

#: tilts per builder task (a build's landings depend on it: a task's tilts share fresh worlds).
TILT_CHUNK = 48

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

        from kruskal_markov.errors import KruskalDeprecationWarning

        warnings.warn("DirectResult.to_json is deprecated; use to_dict", KruskalDeprecationWarning, stacklevel=2)
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

# ----------------------------------------------------------------------------------------------
# the chunker and the context that runs tasks
# ----------------------------------------------------------------------------------------------

def chunk_bounds(n: int, size: int) -> list[tuple[int, int]]:
    """``[(lo, hi), ...]`` cutting ``range(n)`` into consecutive chunks of ``size`` (the last shorter)."""
    size = max(1, int(size))
    return [(lo, min(lo + size, n)) for lo in range(0, int(n), size)]


def trial_chunk_size(trials: int) -> int:
    """Trials per direct-simulation task: a function of ``trials`` only (so results never depend
    on the workers)."""
    return int(min(256, max(16, math.ceil(trials / 64))))


class TiltEngine:
    """The context that runs tilt tasks: the executor (owned or borrowed) and the progress bar.

    Parameters
    ----------
    executor : Executor, optional
        Where the tasks run; borrowed (the caller closes it). Default: made from ``workers`` and
        ``scheduler`` (:func:`~transition_builder.executors.make_executor`; a Dask client made here
        is closed by :meth:`close`), or this process when ``serial``.
    workers : int, optional
        Worker processes (None: every available core).
    scheduler : str, optional
        Address of a Dask scheduler.
    serial : bool
        Run in this process when no executor or scheduler is given (e.g. the work is one task).
    progress : bool or None
        A tqdm bar on standard error; None: only on a terminal.
    unit, desc : str
        The bar's unit and label.
    total : int, optional
        The bar's total.

    Examples
    --------
    >>> with TiltEngine(workers=1) as eng:
    ...     [r for _, r in eng.map(abs, [(-1,), (2,)])]
    [1, 2]
    """

    def __init__(self, executor: Executor | None = None, *, workers: int | None = None,
                 scheduler: str | None = None, serial: bool = False, progress: bool | None = False,
                 unit: str = "tilt", desc: str = "tilt", total: int | None = None):
        if executor is not None and not callable(getattr(executor, "map", None)):
            raise ValueError(f"executor must be a transition_builder.executors.Executor, got {type(executor).__name__}")
        if workers is not None:
            check_int(workers, "workers", lo=1)
        self._owned = None
        if executor is None:
            if scheduler is not None:
                executor = self._owned = make_executor(workers, scheduler)
            elif serial or workers == 1:
                executor = SerialExecutor()
            else:
                executor = self._owned = make_executor(workers)   # the local pool is kept between calls
        self.executor = executor
        if progress is None:
            progress = sys.stderr.isatty()
        self.bar = None
        if progress:
            from tqdm import tqdm

            self.bar = tqdm(total=total, unit=unit, desc=desc, file=sys.stderr, leave=False)

    @property
    def workers(self) -> int:
        """How many tasks can run at the same time."""
        return self.executor.workers

    def map(self, fn, tasks):
        """``executor.map(fn, tasks)``: yields ``(index, result)`` as tasks complete."""
        return self.executor.map(fn, tasks)

    def advance(self, n: int, **postfix) -> None:
        """Progress: ``n`` more units done (``postfix``: figures shown beside the bar)."""
        if self.bar is not None:
            self.bar.update(n)
            if postfix:
                self.bar.set_postfix(refresh=False, **postfix)

    def close(self) -> None:
        """Close the bar and the executor made here (a borrowed one is the caller's)."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None
        if self._owned is not None:
            self._owned.close()
            self._owned = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _as_engine(runner) -> TiltEngine:
    return runner if isinstance(runner, TiltEngine) else TiltEngine(runner)


# ----------------------------------------------------------------------------------------------
# the two task kinds
# ----------------------------------------------------------------------------------------------

def checked_tilt(sim, poses: np.ndarray, action_name: str) -> tuple[np.ndarray, np.ndarray]:
    """``sim.tilt(poses, action_name)`` with its status checked: ``(rest (n, 3) float64, status
    (n,) int8)``. Unknown status codes raise RuntimeError; an OK trial without a finite pose
    becomes ``INVALID``; every faulted trial's pose is NaN (a fault is never returned as a pose)."""
    rest, status = sim.tilt(poses, action_name)
    rest = np.array(rest, dtype=np.float64).reshape(len(poses), 3)
    status = np.array(status, dtype=np.int64).reshape(len(poses))
    if status.size and (status.min() < 0 or status.max() >= len(STATUS_NAMES)):
        raise RuntimeError(f"simulator returned unknown status codes {sorted(set(status.tolist()))}")
    bad_pose = (status == OK) & ~np.all(np.isfinite(rest), axis=1)
    status[bad_pose] = INVALID
    rest[status != OK] = np.nan
    return rest, status.astype(np.int8)


def _fresh_simulator(scene, factory=None):
    """The cached simulator of ``scene``, its next trials independent of every earlier one."""
    sim = simulator_for(scene, factory)
    fresh = getattr(sim, "fresh_start", None)
    if fresh is not None:
        fresh()              # a task's result depends on its own tilts only
    return sim


def tilt_task(scene, action: str, poses: np.ndarray, noise_text: str, seed: int,
              keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tilt every pose under ``action`` after perturbing it with the noise stream of its key.

    Runs in a worker (one cached simulator per scene and process); a task's result depends on its
    own tilts only.

    Parameters
    ----------
    scene : Scene
        The scene.
    action : str
        The tilt action's name.
    poses : ndarray, shape (n, 3)
        Start poses ``(x_mm, y_mm, theta_rad)``.
    noise_text : str
        The process noise spec (``none``: the poses are tilted as given).
    seed : int
        The build's seed.
    keys : ndarray of int, shape (n, m)
        ``keys[i]`` names the noise stream of tilt ``i`` (:func:`transition_builder.noise.noise_rng`).

    Returns
    -------
    rest : ndarray of float64, shape (n, 3)
        Rest poses (NaN where faulted).
    status : ndarray of int8, shape (n,)
        :mod:`transition_builder.status` codes.
    """
    noise = parse_noise(noise_text)
    p = np.array(poses, dtype=np.float64)
    if not noise.is_zero:
        for i in range(len(p)):
            p[i], _ = perturb_pose(scene, p[i], noise, noise_rng(seed, *(int(k) for k in keys[i])))
    return checked_tilt(_fresh_simulator(scene), p, action)


def trial_task(scene, factory, starts, sequence_names, noise=None, noise_seed=0, first_trial=0):
    """Drive the trials ``starts`` (global indices from ``first_trial``) through ``sequence_names``
    on fresh worlds; returns poses (c, N+1, 3) and status (c, N+1) (:func:`_run_chunk`)."""
    return _run_chunk(_fresh_simulator(scene, factory), starts, sequence_names, scene, noise, noise_seed,
                      first_trial)


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
        rest, st = checked_tilt(sim, before, name)
        poses[idx, k] = rest
        status[idx, k] = st
        alive[idx[st != OK]] = False
    return poses, status



# ----------------------------------------------------------------------------------------------
# streams of tilt tasks (the builder)
# ----------------------------------------------------------------------------------------------

def run_tilts(runner, scene, noise_text, seed, jobs, on_done=None):
    """Run ``jobs`` = list of (action_name, poses (n,3), keys (n, m)) on ``runner`` (a
    :class:`TiltEngine` or an executor); returns [(rest, status)] in order."""
    out = []
    stream_tilts(runner, scene, noise_text, seed, [jobs], lambda i, res: out.append(res), on_done)
    return out[0]


def stream_tilts(runner, scene, noise_text, seed, batches, on_batch, on_done=None) -> bool:
    """Run several batches of jobs as one stream of executor tasks.

    ``batches`` is a list of job lists (as for :func:`run_tilts`); ``on_batch(i, results)`` is
    called for batch 0, 1, ... in order, each as soon as it and every batch before it are done,
    while the workers go on with the later batches (so the parent's snapping overlaps the
    simulation, and no batch's last task leaves a worker idle). Each batch is cut into tasks of
    :data:`TILT_CHUNK` exactly as on its own, so the landings are the same as batch after batch.
    When ``on_batch`` returns False the rest is cancelled and False returned; True otherwise.
    ``on_done(n)`` is called as every task's ``n`` tilts come back.
    """
    engine = _as_engine(runner)
    tasks, where, outs, pending = [], [], [], []
    for i, jobs in enumerate(batches):
        outs.append([(np.full((len(p), 3), np.nan), np.zeros(len(p), dtype=np.int8)) for _, p, _ in jobs])
        pending.append(0)
        for j, (action, poses, keys) in enumerate(jobs):
            for lo, hi in chunk_bounds(len(poses), TILT_CHUNK):
                tasks.append((scene, action, poses[lo:hi], noise_text, seed, keys[lo:hi]))
                where.append((i, j, lo))
                pending[i] += 1
    nxt = 0

    def deliver() -> bool:
        nonlocal nxt
        while nxt < len(batches) and pending[nxt] == 0:
            go = on_batch(nxt, outs[nxt])
            outs[nxt] = None
            nxt += 1
            if go is False:
                return False
        return True

    if not deliver():
        return False
    results = engine.map(tilt_task, tasks)
    try:
        for idx, (rest, status) in results:
            i, j, lo = where[idx]
            outs[i][j][0][lo:lo + len(rest)] = rest
            outs[i][j][1][lo:lo + len(rest)] = status
            pending[i] -= 1
            if on_done is not None:
                on_done(len(rest))
            if pending[i] == 0 and i == nxt and not deliver():
                return False
    finally:
        close = getattr(results, "close", None)
        if close is not None:
            close()                     # a stopped stream cancels the tasks not yet run
    return deliver()


# ----------------------------------------------------------------------------------------------
# direct Monte Carlo
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
    bounds = chunk_bounds(trials, trial_chunk_size(trials))
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
    """Run the trial ``tasks`` (rows ``bounds``) in a :class:`TiltEngine` (default executor: a Dask
    client for ``scheduler``, this process for one chunk or one worker, else the kept local pool)
    and fill ``poses`` and ``status`` in place, with a progress bar when asked."""
    with TiltEngine(executor, workers=workers, scheduler=scheduler, serial=len(bounds) == 1,
                    progress=progress, unit="trial", desc="simulate", total=int(bounds[-1][1])) as eng:
        for i, (p, s) in eng.map(trial_task, tasks):
            lo, hi = bounds[i]
            poses[lo:hi], status[lo:hi] = p, s
            eng.advance(hi - lo)


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


