"""Direct Monte Carlo's files and re-exports: the paper's method, and the ground truth for models.

The engine (:func:`run_direct`, :class:`DirectResult`, the trial tasks, chunking and executors)
lives in :mod:`transition_builder.tilting`, the one home of every tilt run on an executor; it is
re-exported here. This module keeps the pose files of ``kruskal simulate --poses``
(:func:`write_poses_csv`, :func:`read_poses_csv`) and the entropy of a pose file per step
(:func:`entropy_by_step`).
"""
from __future__ import annotations

import csv
import math
import os
import tempfile
from dataclasses import dataclass

import numpy as np

from kruskal_markov.entropy import histogram_entropy_bits
from kruskal_markov.limits import check_memory
from transition_builder.executors import shutdown_workers
from transition_builder.grid import ReportGrid
from transition_builder.status import OK, STATUS_NAMES
from transition_builder.tilting import (
    DirectResult,
    report_grid_for,
    resolve_sequence,
    run_direct,
    summarise_trials,
)

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
