"""A tray's pose log as the fit reads it: trials of observed poses, the tilts between them, gaps.

The log is the ``--poses`` CSV of docs/commands.md (``trial,step,x_mm,y_mm,theta_rad,status`` and
an optional ``action`` column; e.g. a camera reading a tag after every tilt). Rows are read by
:func:`analysis.montecarlo.read_poses_csv`; this module adds what a fit needs and checks the rest:

- a missing row or a status other than ``ok`` is a *missing observation* (a missed detection), not
  an error; a trial ends at its last row, so trials may have unequal lengths;
- the tilt before step ``k`` is the ``action`` column of that row, or step ``k`` of ``--sequence``
  (both given: they must agree); a trial whose tilt at some step is unknown (no row there and no
  sequence, and the trials that have a row there disagree on it) ends before it;
- an ``ok`` pose outside the tray is a camera's misread, read as a missed observation (counted in
  ``FitLog.outside_tray``), unless more than :data:`MAX_OUTSIDE_SHARE` of them are: then the log
  is of another tray or in other units;
- unreadable logs raise :class:`ValueError` with one line: no header, an unknown action, over a tenth
  of the poses outside the tray, NaN, a duplicated (trial, step), no ``ok`` row at all.
"""
from __future__ import annotations

import csv
import os
from dataclasses import dataclass

import numpy as np

from kruskal_markov.validation import action_position
from transition_builder.status import OK

__all__ = ["FitLog", "read_fit_log", "add_camera_noise_to", "outside_tray"]


@dataclass(frozen=True)
class FitLog:
    """Observed poses by trial and step, ready for the forward algorithm.

    Attributes
    ----------
    obs : ndarray (T, L+1, 3)
        Observed pose of trial ``t`` after step ``k`` (step 0 = start); NaN where missing.
    actions : ndarray (T, L) int64
        Index of the tilt leading to step ``k+1``; -1 past the trial's end.
    length : ndarray (T,) int64
        Number of tilts of every trial (its last step).
    trial_ids : ndarray (T,) int64
        The log's trial numbers.
    action_names : tuple of str
    source : str
        Where the tilts came from: ``"sequence"`` or ``"action column"``.
    outside_tray : int
        ``ok`` poses outside the tray, read as misreads (missed observations).
    """

    obs: np.ndarray
    actions: np.ndarray
    length: np.ndarray
    trial_ids: np.ndarray
    action_names: tuple
    source: str
    outside_tray: int = 0

    @property
    def trials(self) -> int:
        return int(self.obs.shape[0])

    @property
    def tilts(self) -> int:
        """The longest trial's number of tilts."""
        return int(self.length.max()) if self.length.size else 0

    @property
    def observed(self) -> np.ndarray:
        """(T, L+1) bool: where a pose was observed."""
        return np.all(np.isfinite(self.obs), axis=2)

    @property
    def n_observations(self) -> int:
        return int(self.observed.sum())

    def common_sequence(self) -> np.ndarray | None:
        """The one tilt sequence every trial follows (as far as it goes), or None."""
        seq = np.full(self.tilts, -1, dtype=np.int64)
        for k in range(self.tilts):
            col = self.actions[:, k]
            known = np.unique(col[col >= 0])
            if len(known) != 1:
                return None
            seq[k] = known[0]
        return seq

    def subset(self, rows) -> "FitLog":
        """The log of the trials ``rows`` (indices, repeats allowed: a bootstrap resample)."""
        rows = np.asarray(rows, dtype=np.int64)
        return FitLog(self.obs[rows], self.actions[rows], self.length[rows], self.trial_ids[rows],
                      self.action_names, self.source, self.outside_tray)


def _action_column(path) -> dict:
    """(trial, step) -> action name of the optional ``action`` column ({} when there is none)."""
    with open(path, newline="", encoding="utf-8") as fh:
        reader = csv.reader(fh)
        header = [h.strip().lower() for h in next(reader)]
        if "action" not in header:
            return {}
        ia, it, ik = header.index("action"), header.index("trial"), header.index("step")
        out = {}
        for row in reader:
            if len(row) > max(ia, it, ik) and row[ia].strip():
                out[(int(row[it]), int(row[ik]))] = row[ia].strip()
        return out


#: the largest share of ``ok`` poses outside the tray read as the camera's misreads (missed
#: observations); more is a log of another tray, or in other units: refused.
MAX_OUTSIDE_SHARE = 0.1


def outside_tray(poses: np.ndarray, tray) -> np.ndarray:
    """Where a pose (``(..., 3)``: x, y in mm) lies outside the ``tray`` (x mm, y mm) rectangle (NaN: not)."""
    a, b = tray
    return (poses[..., 0] < 0) | (poses[..., 0] > a) | (poses[..., 1] < 0) | (poses[..., 1] > b)


def add_camera_noise_to(poses: np.ndarray, sigma_mm: float, sigma_deg: float, rng: np.random.Generator) -> np.ndarray:
    """A copy of ``poses`` (``(..., 3)``) with Gaussian camera noise: x and y ``N(0, sigma_mm)``, then
    theta ``N(0, sigma_deg)`` in degrees, wrapped to [0, 2 pi); NaN stays NaN."""
    p = poses.copy()
    p[..., :2] += rng.normal(0.0, sigma_mm, p[..., :2].shape)
    p[..., 2] = np.mod(p[..., 2] + rng.normal(0.0, np.radians(sigma_deg), p[..., 2].shape), 2 * np.pi)
    return p


def _check_poses(path, rec, tray) -> np.ndarray:
    """The ``ok`` rows whose pose lies outside the tray (bool, by row): a camera's misreads, read as
    missed observations; refused (one line) when they are more than :data:`MAX_OUTSIDE_SHARE`."""
    ok = rec.status == OK
    if not ok.any():
        raise ValueError(f"poses file {path!r} has no row with status ok: nothing was observed")
    a, b = tray
    p = rec.poses
    outside = ok & outside_tray(p, tray)
    if outside.sum() > MAX_OUTSIDE_SHARE * ok.sum():
        i = int(np.argmax(outside))
        raise ValueError(f"poses file {path!r}: {int(outside.sum())} of {int(ok.sum())} observed poses lie outside "
                         f"the {a:g} x {b:g} mm tray (e.g. trial {rec.trial[i]} step {rec.step[i]} at "
                         f"({p[i, 0]:g}, {p[i, 1]:g}) mm): another tray size or units?")
    return outside


def read_fit_log(path, action_names, tray, sequence=None) -> FitLog:
    """Read a pose log for fitting (see the module docstring for the rules).

    Parameters
    ----------
    path : str or path-like
        The ``--poses`` CSV file.
    action_names : sequence of str
        The scene's actions (the ``action`` column and ``sequence`` use these names).
    tray : (float, float)
        The tray's inner size (mm); an ``ok`` pose outside it is a misread (see the module).
    sequence : array_like of int, optional
        Action indices of the tilts (``--sequence``); required when the log has no ``action`` column.

    Returns
    -------
    FitLog
    """
    from analysis.montecarlo import read_poses_csv

    path = os.fspath(path)
    rec = read_poses_csv(path)
    if rec.trial.size == 0:
        raise ValueError(f"poses file {path!r} has no rows")
    outside = _check_poses(path, rec, tray)
    names = [str(n) for n in action_names]
    column = _action_column(path)
    col_idx = {}
    for (t, k), name in column.items():
        try:
            col_idx[(t, k)] = action_position(names, name, f" in the action column of {path!r} (trial {t} step {k})")
        except ValueError as exc:
            raise ValueError(str(exc)) from None
    if sequence is None and not column:
        raise ValueError(f"poses file {path!r} has no action column: give the tilts with --sequence")
    ids, inv = np.unique(rec.trial, return_inverse=True)
    n_tilts = int(rec.step.max())
    if sequence is not None:
        sequence = np.asarray(sequence, dtype=np.int64)
        if len(sequence) < n_tilts:
            raise ValueError(f"poses file {path!r} has steps up to {n_tilts} but --sequence has {len(sequence)} tilts")
    T = len(ids)
    obs = np.full((T, n_tilts + 1, 3), np.nan)
    ok = (rec.status == OK) & ~outside
    obs[inv[ok], rec.step[ok]] = rec.poses[ok]
    last = np.zeros(T, dtype=np.int64)
    np.maximum.at(last, inv, rec.step)
    actions = np.full((T, n_tilts), -1, dtype=np.int64)
    for (t, k), a in col_idx.items():
        if k == 0:
            continue
        i = int(np.searchsorted(ids, t))
        if sequence is not None and a != sequence[k - 1]:
            raise ValueError(f"poses file {path!r}: trial {t} step {k} has action {names[a]} but --sequence "
                             f"has {names[sequence[k - 1]]}")
        actions[i, k - 1] = a
    if sequence is not None:
        actions[:, :] = sequence[None, :n_tilts]
    for k in range(n_tilts):                # a missed row: the tilt every other trial took there
        known = np.unique(actions[:, k][actions[:, k] >= 0])
        if len(known) == 1:
            actions[actions[:, k] < 0, k] = known[0]
    length = last.copy()
    for i in range(T):                      # a trial ends before its first unknown tilt
        unknown = np.flatnonzero(actions[i, :last[i]] < 0)
        if unknown.size:
            length[i] = unknown[0]
        actions[i, length[i]:] = -1
        obs[i, length[i] + 1:] = np.nan
    return FitLog(obs=obs, actions=actions, length=length, trial_ids=ids, action_names=tuple(names),
                  source="sequence" if sequence is not None else "action column", outside_tray=int(outside.sum()))
