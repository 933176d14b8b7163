"""Every trial's likelihood under a model: the model as a hidden Markov model of the camera's view.

The hidden state is the model state (a representative rest pose, or a start cell before the first
tilt); the observation after a tilt is the logged pose, the state's pose blurred by the camera
(Gaussian, ``sigma_mm`` in x and y and ``sigma_deg`` in theta) and by the model's own snapping
tolerance (a state stands for every rest pose within ``tol`` of it; the two add in quadrature).
A small share ``outlier`` of the observations is allowed to come from anywhere in the tray
(uniform density): without it one pose that a model cannot produce makes its likelihood zero.

The forward algorithm (Rabiner 1989, "A tutorial on hidden Markov models", eq. 19-21) gives each
trial's log-likelihood ``log p(y_0..y_L | model)``: predict ``alpha P_a``, weight by the emission
density of the observation, sum, normalise. A missing observation has no emission term (the
prediction is carried on). Step 0 is the uniform start: the observed pose fixes its start cell
(the start density is uniform, the same under every model, so it adds a constant).

Approximation, stated: the emission sum runs over the states within ``radius`` standardized units
of the observation (4.5 sigma: the Gaussian beyond is below 4e-5 of its peak), found with a k-d
tree; the filtered distribution keeps the Gaussian part of the posterior (the outlier part, at
most half of it, is dropped), and when no state near the observation is predicted (the
observation is an outlier), the filter restarts from the states near the observation.
"""
from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["EmissionSettings", "model_tolerance", "trial_loglik"]


class EmissionSettings:
    """Camera noise, outlier share and search radius of the observation model.

    Parameters
    ----------
    sigma_mm, sigma_deg : float
        Camera noise (standard deviation) of x, y and of theta.
    outlier : float, default 1e-3
        Share of observations from a uniform density over the tray.
    radius : float, default 4.5
        Standardized distance beyond which a state's emission term is dropped.
    """

    def __init__(self, sigma_mm: float, sigma_deg: float, outlier: float = 1e-3, radius: float = 4.5):
        for name, v in (("camera noise (mm)", sigma_mm), ("camera noise (deg)", sigma_deg)):
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number, got {v!r}")
        if not 0 < outlier < 1:
            raise ValueError(f"outlier share must lie in (0, 1), got {outlier!r}")
        self.sigma_mm, self.sigma_deg, self.outlier, self.radius = float(sigma_mm), float(sigma_deg), outlier, radius

    def __repr__(self) -> str:
        return f"EmissionSettings({self.sigma_mm:g} mm, {self.sigma_deg:g} deg, outlier {self.outlier:g})"


def model_tolerance(model) -> tuple[float, float]:
    """The snapping tolerance ``(mm, deg)`` a model was built with (0 when not recorded): the spread
    of a state's members, which the emission adds to the camera noise."""
    bs = (model.metadata or {}).get("build_settings", {})
    return float(bs.get("tol_mm") or 0.0), float(bs.get("tol_deg") or 0.0)


def _neighbours(model, obs_flat, em: EmissionSettings, period: float):
    """CSR lists of the rest states near every observation and their log emission densities."""
    from scipy.spatial import cKDTree

    tol_mm, tol_deg = model_tolerance(model)
    s_xy = math.hypot(em.sigma_mm, tol_mm)
    s_th = math.radians(math.hypot(em.sigma_deg, tol_deg))
    poses = np.asarray(model.extras["state_poses"], dtype=np.float64)
    rest = np.flatnonzero(np.all(np.isfinite(poses), axis=1))

    def scaled(p):
        return np.column_stack([p[:, 0] / s_xy, p[:, 1] / s_xy, np.mod(p[:, 2], period) / s_th])

    big = 1e9
    box = np.array([big, big, period / s_th])
    pts = np.mod(scaled(poses[rest]), box)
    q = np.mod(scaled(obs_flat), box)
    tree = cKDTree(pts, boxsize=box)
    lists = tree.query_ball_point(q, em.radius, return_sorted=True)
    counts = np.fromiter((len(x) for x in lists), dtype=np.int64, count=len(lists))
    ptr = np.zeros(len(lists) + 1, dtype=np.int64)
    np.cumsum(counts, out=ptr[1:])
    idx = np.fromiter((j for x in lists for j in x), dtype=np.int64, count=int(ptr[-1]))
    d = pts[idx] - np.repeat(q, counts, axis=0)
    d[:, 2] = (d[:, 2] + box[2] / 2) % box[2] - box[2] / 2
    log_norm = -1.5 * math.log(2 * math.pi) - 2 * math.log(s_xy) - math.log(s_th)
    logpdf = log_norm - 0.5 * np.einsum("ij,ij->i", d, d)
    return ptr, rest[idx], logpdf


def trial_loglik(model, log, em: EmissionSettings, grid) -> np.ndarray:
    """Each trial's log-likelihood (nats) under ``model`` (see the module docstring).

    Parameters
    ----------
    model : TransitionModel
        A built model (``extras["state_poses"]``, a partition of its start states onto ``grid``).
    log : FitLog
        The observations (:func:`analysis.fit.log.read_fit_log`).
    em : EmissionSettings
        Camera noise and outlier share.
    grid : ReportGrid
        The model's report grid (to find the start cell of an observed start pose).

    Returns
    -------
    ndarray (T,)
        Log-likelihood of every trial; observations at steps >= 1 only (step 0 adds the same
        constant under every model).
    """
    if model.extras is None or "state_poses" not in model.extras:
        raise ValueError("the model has no state poses (extras['state_poses']): build it with kruskal build")
    if list(model.actions) != list(log.action_names):
        raise ValueError(f"the model's actions {model.actions} differ from the log's {log.action_names}")
    T, L1 = log.obs.shape[:2]
    observed = log.observed
    flat = log.obs.reshape(-1, 3)
    sel = np.flatnonzero(observed.ravel())
    ptr_o, nb, lp = _neighbours(model, flat[sel], em, grid.theta_period)
    obs_slot = np.full(T * L1, -1, dtype=np.int64)
    obs_slot[sel] = np.arange(len(sel))
    # step 0: the start state of the observed cell (-1: unobserved, start from the initial distribution)
    n = model.n_states
    start_of_cell = np.full(grid.n_voxels, -1, dtype=np.int64)
    init = np.asarray(model.initial, dtype=np.float64)
    starts = np.flatnonzero(init > 0)
    start_of_cell[np.asarray(model.partition)[starts]] = starts
    start_state = np.full(T, -1, dtype=np.int64)
    o0 = observed[:, 0]
    if o0.any():
        start_state[o0] = start_of_cell[grid.voxel_index(log.obs[o0, 0])]
    ptrs = np.stack([m.indptr.astype(np.int64) for m in model.matrices])
    offs = np.concatenate([[0], np.cumsum([m.nnz for m in model.matrices])]).astype(np.int64)
    idxs = np.concatenate([m.indices.astype(np.int64) for m in model.matrices])
    vals = np.concatenate([m.data.astype(np.float64) for m in model.matrices])
    volume = grid.tray_x_mm * grid.tray_y_mm * grid.theta_period
    log_out = math.log(em.outlier / volume)
    out = np.zeros(T)
    _forward(ptrs, offs, idxs, vals, n, init, start_state, log.actions, log.length, obs_slot.reshape(T, L1),
             ptr_o, nb, lp, math.log1p(-em.outlier), log_out, out)
    return out


@numba.njit(cache=True)
def _start(t, n, init, start_state, alpha, sup):  # pragma: no cover - compiled
    """Step 0: the observed start cell's state, else the initial distribution; returns the support size."""
    if start_state[t] >= 0:
        sup[0] = start_state[t]
        alpha[sup[0]] = 1.0
        return 1
    nsup = 0
    for s in range(n):
        if init[s] > 0:
            sup[nsup] = s
            alpha[s] = init[s]
            nsup += 1
    return nsup


@numba.njit(cache=True)
def _predict(ptrs, offs, idxs, vals, a, alpha, sup, nsup, pred, touched, mark):  # pragma: no cover - compiled
    """``pred = alpha P_a`` over the support (alpha is cleared); returns the number of touched states."""
    base = offs[a]
    nt = 0
    for ii in range(nsup):
        i = sup[ii]
        w = alpha[i]
        alpha[i] = 0.0
        for p in range(ptrs[a, i], ptrs[a, i + 1]):
            j = idxs[base + p]
            if not mark[j]:
                mark[j] = True
                touched[nt] = j
                nt += 1
            pred[j] += w * vals[base + p]
    return nt


@numba.njit(cache=True)
def _carry(pred, touched, nt, mark, alpha, sup):  # pragma: no cover - compiled
    """No emission (a missed observation, or no state near it): the prediction becomes the filter."""
    for ii in range(nt):
        j = touched[ii]
        sup[ii] = j
        alpha[j] = pred[j]
        pred[j] = 0.0
        mark[j] = False
    return nt


@numba.njit(cache=True)
def _emission_loglik(pred, lo, hi, nb, lp, log_in, log_out):  # pragma: no cover - compiled
    """(log p(y | prediction) with the outlier share, the Gaussian part's log, the largest log density)."""
    m = -1e300
    for p in range(lo, hi):
        m = max(m, lp[p])
    lik = 0.0
    for p in range(lo, hi):
        lik += pred[nb[p]] * np.exp(lp[p] - m)
    gauss = log_in + m + np.log(lik) if (hi > lo and lik > 0.0) else -1e300
    big = max(gauss, log_out)
    return big + np.log(np.exp(gauss - big) + np.exp(log_out - big)), gauss, m


@numba.njit(cache=True)
def _update(pred, touched, nt, mark, alpha, sup, lo, hi, nb, lp, m, restart):  # pragma: no cover - compiled
    """The filter after an observation: the Gaussian part of the posterior on the states near it (or,
    for an outlier, those states weighted by the emission alone); returns the support size."""
    nsup = 0
    total = 0.0
    for p in range(lo, hi):         # the neighbours of one observation are distinct
        j = nb[p]
        w = np.exp(lp[p] - m) if restart else pred[j] * np.exp(lp[p] - m)
        if w > 0.0:
            sup[nsup] = j
            nsup += 1
            alpha[j] = w
            total += w
    if total <= 0.0:
        return _carry(pred, touched, nt, mark, alpha, sup)
    for ii in range(nsup):
        alpha[sup[ii]] /= total
    for ii in range(nt):
        j = touched[ii]
        pred[j] = 0.0
        mark[j] = False
    return nsup


@numba.njit(cache=True)
def _forward(ptrs, offs, idxs, vals, n, init, start_state, actions, length, obs_slot, ptr_o, nb, lp,
             log_in, log_out, out):  # pragma: no cover - compiled
    alpha = np.zeros(n)
    pred = np.zeros(n)
    sup = np.empty(n, dtype=np.int64)
    touched = np.empty(n, dtype=np.int64)
    mark = np.zeros(n, dtype=np.bool_)
    for t in range(len(length)):
        nsup = _start(t, n, init, start_state, alpha, sup)
        ll = 0.0
        for k in range(1, length[t] + 1):
            nt = _predict(ptrs, offs, idxs, vals, actions[t, k - 1], alpha, sup, nsup, pred, touched, mark)
            slot = obs_slot[t, k]
            if slot < 0:                    # missed observation: carry the prediction on
                nsup = _carry(pred, touched, nt, mark, alpha, sup)
                continue
            lo, hi = ptr_o[slot], ptr_o[slot + 1]
            step, gauss, m = _emission_loglik(pred, lo, hi, nb, lp, log_in, log_out)
            ll += step
            nsup = _update(pred, touched, nt, mark, alpha, sup, lo, hi, nb, lp, m, gauss < log_out)
        out[t] = ll
        for ii in range(nsup):
            alpha[sup[ii]] = 0.0
