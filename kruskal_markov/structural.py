"""A model's structural error: the entropy range of every distribution near the model's own.

A built model is wrong in two ways. Its rows carry sampling noise, which the Dirichlet posterior
of :mod:`kruskal_markov.posterior` knows. And it is *structurally* wrong: snapping landings to
representative poses, probe-spread rows and the Markov assumption itself put some of the part's
probability in other report cells than the physics would — a chunk of trials that, near a
bifurcation of the physics, takes the other branch. The posterior cannot see that; measured on the
allen key, a band from it alone held the direct-simulation reference at 57-60% of steps.

The structural term used here: at step ``t`` the model's report-cell distribution ``p`` may have
misplaced a share ``delta_eff = delta * (1 - max(p))`` of the probability, so the truth lies
within total-variation distance ``delta_eff`` of ``p``. The structural error scales with the mass
not yet gathered in the most likely cell: a model that has converged (all mass in one cell) is
taken at its word — its plans replay at 99.9-99.99% in direct simulation (docs/plans.md).

:func:`structural_flow` measures ``V_t``, the Dirichlet row variance (:func:`row_variance`) a
sequence's probability has flowed through by step ``t``. A radius ``delta (1 - max(p)) V_t`` (the
*flow* rule) calibrated more stably than the one above on the kept validation runs, but failed its
held-out test (68% coverage on the key's new seeds against 98% for the rule above,
docs/uncertainty.md): it is kept as a diagnostic (``flow`` of :func:`analysis.validate.model_band`),
not used by any band or interval.

The entropy range of that total-variation ball is exact (Ho and Yeung, "The interplay between
entropy and variational distance", IEEE Trans. Inf. Theory 56(12), 2010): the largest entropy
clips ``p`` from above and below (the water-filling of :func:`entropy_range_tv`), the smallest
moves the mass of the smallest cells onto the largest.

``delta`` is calibrated by split conformal prediction (Vovk, Gammerman and Shafer, *Algorithmic
Learning in a Random World*, 2005; Angelopoulos and Bates, "A gentle introduction to conformal
prediction", 2021): on validation runs not used for testing, each step's score is the smallest
``delta`` whose band holds the reference (:func:`structural_score`), and ``delta`` is the
``ceil((n + 1) 0.9) / n`` empirical quantile of the scores (:func:`conformal_quantile`). The
default, :data:`STRUCTURAL_DELTA`, was calibrated so on the allen key's default model (seeds 2031
and 3, 150 steps; docs/uncertainty.md) and tested on seeds chosen before.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["STRUCTURAL_DELTA", "STRUCTURAL_RULE", "entropy_range_tv", "structural_share", "band_with_structure",
           "structural_score", "conformal_quantile", "StructuralTerm", "structural_term", "with_calibration",
           "is_sampled", "row_variance", "structural_flow", "flow_scores", "MIN_CALIBRATION_SEQUENCES",
           "calibration_warning"]

#: The fallback relative structural error of a *built* model that carries no calibration of its own:
#: the share of the not-yet-gathered probability that the model may have misplaced (split-conformal
#: 90% quantile on the key's calibration seeds 2031 and 3). Models calibrated by
#: ``kruskal validate --calibrate`` use their own value (:func:`structural_term`).
STRUCTURAL_DELTA = 0.105

#: The rule of the bands and intervals (radius ``delta (1 - p_max)``); a stored calibration names it,
#: and one naming another rule (e.g. ``"flow"``, measured and not adopted) is ignored: its delta is on
#: another scale. A record without a rule predates the name and is of this rule.
STRUCTURAL_RULE = "relative"

#: The fewest random sequences a stored calibration should pool before its delta is trusted. A chunk
#: error is an event of a whole sequence, so a 90% quantile of a few sequences' steps varies widely: on the
#: key's 17 kept sequences, calibrations resampled from 2 of them gave deltas whose coverage of all 17
#: ranged over 65-99% (5-95%), from 8 over 80-95%, from 12 over 84-93% (docs/uncertainty.md, "How many
#: sequences a calibration needs"). Below it the calibration and the model's note say so.
MIN_CALIBRATION_SEQUENCES = 12

#: What the output says for a model that was not sampled.
NO_TERM_NOTE = ("no structural term: the model was not sampled from physics (an automaton given exactly, "
                "or a model without build statistics), so it has no snapping error")


@dataclass(frozen=True)
class StructuralTerm:
    """A model's relative structural error and where it comes from.

    Attributes
    ----------
    delta : float
        The relative total-variation radius (0: no structural term).
    source : str
        ``"calibrated"`` (stored in the model by ``kruskal validate --calibrate``), ``"default"``
        (a built model without a calibration: :data:`STRUCTURAL_DELTA`), ``"none"`` (a model that
        was not sampled) or ``"given"`` (set by the caller, e.g. ``--structural-delta``).
    note : str
        One line for the output.
    """

    delta: float
    source: str
    note: str

    def to_dict(self) -> dict:
        """``structural_delta``, ``structural_source`` and ``structural_note`` (JSON keys)."""
        return {"structural_delta": self.delta, "structural_source": self.source, "structural_note": self.note}


def is_sampled(model) -> bool:
    """True for a model sampled from physics by ``kruskal build``: its metadata records the build
    statistics and it carries the sample counts of every action (an automaton given as JSON cannot)."""
    from kruskal_markov.posterior import has_counts

    md = getattr(model, "metadata", None) or {}
    return md.get("kind") == "kruskal.built_model" and isinstance(md.get("stats"), dict) and has_counts(model)


def structural_term(model, delta: float | None = None) -> StructuralTerm:
    """The structural term of ``model``: ``delta`` if given, else the model's own.

    Parameters
    ----------
    model : TransitionModel
    delta : float, optional
        An explicit relative error (the caller's ``--structural-delta``); None: the model's own —
        its stored calibration (``metadata["structural"]["delta"]``), else :data:`STRUCTURAL_DELTA`
        for a built model, else 0 for a model that was not sampled (:func:`is_sampled`).

    Returns
    -------
    StructuralTerm
    """
    if delta is not None:
        d = float(delta)
        if not (math.isfinite(d) and d >= 0):
            raise ValueError(f"structural delta must be a non-negative number, got {delta!r}")
        return StructuralTerm(d, "given", f"structural delta {d:g} given by the caller")
    if not is_sampled(model):
        return StructuralTerm(0.0, "none", NO_TERM_NOTE)
    rec = model.metadata.get("structural")
    if isinstance(rec, dict) and rec.get("rule", STRUCTURAL_RULE) != STRUCTURAL_RULE:
        return StructuralTerm(STRUCTURAL_DELTA, "default",
                              f"structural delta {STRUCTURAL_DELTA:g}: the allen key's calibration; the model's "
                              f"stored calibration is of another rule ({rec.get('rule')!r}; `kruskal validate "
                              "--calibrate` renews it)")
    if isinstance(rec, dict) and isinstance(rec.get("delta"), (int, float)) and math.isfinite(rec["delta"]) \
            and rec["delta"] >= 0:
        seqs = rec.get("sequences")
        of = f" of {seqs} sequences" if isinstance(seqs, int) else ""
        warn = calibration_warning(seqs)
        return StructuralTerm(float(rec["delta"]), "calibrated",
                              f"structural delta {rec['delta']:.4g} calibrated on this model "
                              f"({rec.get('steps', '?')} steps{of} of `kruskal validate --calibrate`, seeds "
                              f"{', '.join(map(str, rec.get('seeds', []))) or '?'})" + (f"; {warn}" if warn else ""))
    return StructuralTerm(STRUCTURAL_DELTA, "default",
                          f"structural delta {STRUCTURAL_DELTA:g}: the allen key's calibration, this model has "
                          "none of its own (`kruskal validate --calibrate` stores one)")


def calibration_warning(sequences) -> str | None:
    """None for a calibration pooled from at least :data:`MIN_CALIBRATION_SEQUENCES` sequences, else one
    line saying it rests on fewer (or on an unknown number: a record that predates the count).

    Parameters
    ----------
    sequences : int or None
        The sequences the calibration pooled (``metadata["structural"]["sequences"]``).
    """
    if isinstance(sequences, int) and not isinstance(sequences, bool) and sequences >= MIN_CALIBRATION_SEQUENCES:
        return None
    n = f"{sequences} sequences" if isinstance(sequences, int) and not isinstance(sequences, bool) \
        else "an unrecorded number of sequences"
    return (f"calibrated on {n}, fewer than {MIN_CALIBRATION_SEQUENCES}: such a delta is unstable "
            "(docs/uncertainty.md); pool more `kruskal validate --calibrate` runs of other seeds")


def with_calibration(model, delta: float, **record):
    """A copy of ``model`` whose metadata stores the calibrated structural ``delta`` (and ``record``).

    Parameters
    ----------
    model : TransitionModel
        A built model (:func:`is_sampled`; ValueError otherwise).
    delta : float
        The calibrated relative structural error (finite, >= 0).
    **record
        JSON-serialisable facts of the calibration (seed, steps, level, ...).

    Returns
    -------
    TransitionModel
    """
    from kruskal_markov.model import TransitionModel

    if not is_sampled(model):
        raise ValueError("only a built model has a structural term to calibrate")
    d = float(delta)
    if not (math.isfinite(d) and d >= 0):
        raise ValueError(f"calibrated delta must be a finite non-negative number, got {delta!r}")
    md = dict(model.metadata)
    md["structural"] = {"delta": d, **record, "rule": STRUCTURAL_RULE}
    return TransitionModel(model.actions, model.matrices, initial=model.initial, partition=model.partition,
                           n_cells=model.n_cells, metadata=md, tol=model.tol, extras=model.extras)

def row_variance(model) -> list[np.ndarray]:
    """Per action, each row's Dirichlet variance summed over report cells, ``(1 - sum_j c_j^2) / (n + 1)``.

    ``c`` is the row's distribution over report cells (``model.partition``; states without one) and
    ``n`` the row's sample count (:func:`kruskal_markov.posterior.row_counts`). It is the summed
    variance of the cells' probabilities under a Dirichlet posterior of concentration ``n + 1``
    centred on the row: zero for a row sampled once or whose samples agree on one cell.

    Parameters
    ----------
    model : TransitionModel
        A model with sample counts (zeros for every row of one without).

    Returns
    -------
    list of numpy.ndarray
        One array of length ``n_states`` per action.
    """
    import scipy.sparse as sp

    from kruskal_markov.posterior import has_counts, row_counts

    cached = getattr(model, "_structural_row_variance", None)
    if cached is not None:
        return cached
    if not has_counts(model):
        out = [np.zeros(model.n_states) for _ in range(model.n_actions)]
    else:
        part = np.asarray(model.partition) if model.partition is not None else np.arange(model.n_states)
        ncells = int(model.n_cells) if model.partition is not None else model.n_states
        out = []
        for a in range(model.n_actions):
            m = sp.csr_matrix(model.matrices[a])
            rows = np.repeat(np.arange(m.shape[0]), np.diff(m.indptr))
            n = np.bincount(rows, weights=row_counts(model, a).astype(np.float64), minlength=m.shape[0])
            c = sp.csr_matrix((np.array(m.data, dtype=np.float64), part[m.indices], m.indptr.copy()),
                              shape=(m.shape[0], ncells))
            c.sum_duplicates()
            tot = np.asarray(c.sum(1)).ravel()
            sq = np.asarray(c.multiply(c).sum(1)).ravel()
            with np.errstate(divide="ignore", invalid="ignore"):
                v = np.where(tot > 0, (1.0 - sq / np.where(tot > 0, tot, 1.0) ** 2) / (n + 1.0), 0.0)
            out.append(np.clip(v, 0.0, None))
    try:
        object.__setattr__(model, "_structural_row_variance", out)
    except (AttributeError, TypeError):  # pragma: no cover - a model type without attributes
        pass
    return out


def structural_flow(model, sequence, distributions) -> np.ndarray:
    """``V_t``: the row variance the sequence's probability has flowed through by step ``t`` (0 at step 0).

    Parameters
    ----------
    model : TransitionModel
    sequence : sequence of int
        Action indices, ``N`` of them.
    distributions : array_like, shape (N + 1, n_states)
        The state distribution at steps 0..N (``entropy_trajectory(..., return_distributions=True)``).

    Returns
    -------
    numpy.ndarray, shape (N + 1,)
        ``V_t = sum_{k <= t} E_{p_{k-1}} v(s, a_k)`` (:func:`row_variance`).
    """
    v = row_variance(model)
    p = np.asarray(distributions, dtype=np.float64)
    seq = [int(a) for a in sequence]
    if len(p) != len(seq) + 1:
        raise ValueError(f"need {len(seq) + 1} distributions for {len(seq)} actions, got {len(p)}")
    step = np.zeros(len(p))
    for k, a in enumerate(seq, start=1):
        tot = p[k - 1].sum()
        step[k] = float(p[k - 1] @ v[a]) / tot if tot > 0 else 0.0
    return np.cumsum(step)


def flow_scores(relative_scores, flow) -> np.ndarray:
    """The flow rule's per-step score from the relative one (:func:`structural_score`): ``score / V_t``.

    0 where no term is needed; inf where one is needed but no variance has flowed (``V_t = 0``).
    """
    s = np.asarray(relative_scores, dtype=np.float64)
    f = np.asarray(flow, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(s <= 0, 0.0, np.where(f > 0, s / np.where(f > 0, f, 1.0), np.inf))


def _entropy_rows(q: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(q > 0, -q * np.log2(np.where(q > 0, q, 1.0)), 0.0)
    return np.maximum(t.sum(axis=-1), 0.0)


def entropy_range_tv(p, delta) -> tuple[np.ndarray, np.ndarray]:
    """Smallest and largest entropy, in bits, of the distributions within total variation ``delta`` of ``p``.

    Parameters
    ----------
    p : array_like, shape (n,) or (rows, n)
        Probability distributions (each row is normalised; negative entries are refused).
    delta : float or array_like of shape (rows,)
        Total-variation radius, ``0.5 * sum |q - p| <= delta`` (0 gives ``H(p)`` twice).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        The smallest and the largest entropy (scalars as 0-d arrays for a 1-D ``p``).

    Notes
    -----
    Largest: clip ``p`` to ``[l, u]`` with ``sum (p - u)+ = sum (l - p)+ = delta`` (uniform once
    ``delta`` reaches ``p``'s distance to it). Smallest: take ``delta`` from the smallest cells,
    emptying them in turn, and add it to the largest. Both are the extremes of Ho and Yeung (2010),
    since entropy is Schur-concave. Both levels are found exactly on each sorted row, in parallel
    over rows (Numba, :mod:`kruskal_markov._structural_kernels`).

    References
    ----------
    S.-W. Ho and R. W. Yeung, "The interplay between entropy and variational distance",
    IEEE Trans. Inf. Theory 56(12):5906-5929, 2010.

    Examples
    --------
    >>> lo, hi = entropy_range_tv([1.0, 0.0], 0.5)
    >>> float(lo), float(hi)
    (0.0, 1.0)
    """
    from kruskal_markov._structural_kernels import entropy_range_rows

    p = np.asarray(p, dtype=np.float64)
    one = p.ndim == 1
    p = np.atleast_2d(p)
    if not np.all(np.isfinite(p)) or np.any(p < 0):
        raise ValueError("distributions must be finite and non-negative")
    s = p.sum(1, keepdims=True)
    if np.any(s <= 0):
        raise ValueError("every distribution needs positive mass")
    p = np.ascontiguousarray(p / s)
    d = np.broadcast_to(np.asarray(delta, dtype=np.float64), (len(p),)).copy()
    if not np.all(np.isfinite(d)) or np.any(d < 0):
        raise ValueError(f"delta must be finite and non-negative, got {delta!r}")
    d = np.minimum(d, 1.0)
    hmin = np.empty(len(p))
    hmax = np.empty(len(p))
    entropy_range_rows(p, d, hmin, hmax)
    return (hmin[0], hmax[0]) if one else (hmin, hmax)


def structural_share(p) -> np.ndarray:
    """The probability not in the most likely cell, ``1 - max(p)`` (per row), which scales ``delta``.

    Parameters
    ----------
    p : array_like, shape (n,) or (rows, n)

    Returns
    -------
    numpy.ndarray
    """
    p = np.atleast_2d(np.asarray(p, dtype=np.float64))
    out = 1.0 - p.max(1) / p.sum(1)
    return np.clip(out, 0.0, 1.0)


def band_with_structure(cells, centre, width, delta):
    """A band's ends widened by the structural term: the entropy range of the relative TV ball.

    Parameters
    ----------
    cells : array_like, shape (steps, n)
        The model's report-cell distribution at each step.
    centre, width : array_like, shape (steps,)
        The band without structure (:mod:`analysis.validate`: the posterior's 90% band moved by
        the plug-in bias and widened by the reference's noise), ``centre +- width``.
    delta : float or array_like of shape (steps,)
        Relative structural error, per step or one for all: the ball's radius is
        ``delta (1 - p_max)`` (0: the band unchanged).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        Lower and upper ends.
    """
    cells = np.atleast_2d(np.asarray(cells, dtype=np.float64))
    centre = np.asarray(centre, dtype=np.float64)
    width = np.asarray(width, dtype=np.float64)
    d = np.asarray(delta, dtype=np.float64)
    if not (np.all(np.isfinite(d)) and np.all(d >= 0)):
        raise ValueError(f"structural delta must be a non-negative number, got {delta!r}")
    if not np.any(d > 0):
        return centre - width, centre + width
    p = cells / cells.sum(1, keepdims=True)
    h = _entropy_rows(p)
    hmin, hmax = entropy_range_tv(p, d * structural_share(p))
    return centre - width - (h - hmin), centre + width + (hmax - h)


def structural_score(cells, centre, width, reference, hi_delta: float = 1e6) -> np.ndarray:
    """Per step, the smallest relative ``delta`` whose band holds ``reference`` (inf if none does).

    Parameters
    ----------
    cells : array_like, shape (steps, n)
    centre, width, reference : array_like, shape (steps,)
    hi_delta : float
        The largest ``delta`` tried (the ball then covers every distribution).

    Returns
    -------
    numpy.ndarray
        0 where the band without structure holds the reference already.
    """
    cells = np.atleast_2d(np.asarray(cells, dtype=np.float64))
    ref = np.asarray(reference, dtype=np.float64)

    def holds(dl):
        lo, hi = band_with_structure(cells, centre, width, dl)
        return (ref >= lo - 1e-12) & (ref <= hi + 1e-12)

    out = np.where(holds(np.zeros(len(ref))), 0.0, np.inf)
    reach = holds(np.full(len(ref), hi_delta)) & ~np.isfinite(out)
    lo = np.zeros(len(ref))
    hi = np.full(len(ref), hi_delta)
    for _ in range(80):
        mid = np.sqrt(np.maximum(lo, 1e-9) * hi) if hi_delta > 1 else 0.5 * (lo + hi)
        ok = holds(mid)
        hi = np.where(ok, mid, hi)
        lo = np.where(ok, lo, mid)
    out[reach] = hi[reach]
    return out


def conformal_quantile(scores, level: float = 0.9) -> float:
    """The split-conformal quantile: the ``ceil((n + 1) level)``-th smallest of ``n`` scores.

    Parameters
    ----------
    scores : array_like
        Calibration scores (:func:`structural_score`), inf allowed.
    level : float
        Target coverage in (0, 1).

    Returns
    -------
    float
        inf when ``ceil((n + 1) level) > n`` (too few scores for the level).

    Examples
    --------
    >>> conformal_quantile(range(1, 10), 0.8)
    8.0
    """
    s = np.sort(np.asarray(scores, dtype=np.float64).ravel())
    if not 0 < level < 1:
        raise ValueError(f"level must lie in (0, 1), got {level!r}")
    n = len(s)
    k = math.ceil((n + 1) * level)
    return float(s[k - 1]) if 0 < k <= n else math.inf
