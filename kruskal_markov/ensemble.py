"""Random-sequence ensembles: the paper's Fig. 3 statistics.

K random action sequences of length N (actions independent, uniform or with given weights), their
entropy after every step (on the report partition, or on the states when the model has none),
and per step the mean and the 25% / 75% quantiles; per sequence the convergence step (the first
step whose entropy is <= epsilon), how many converged, and the best sequence.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from kruskal_markov.entropy import ZERO_BITS, batch_entropy
from kruskal_markov.limits import check_memory
from kruskal_markov.model import ModelError, TransitionModel
from kruskal_markov.validation import action_weights

__all__ = ["random_sequences", "EnsembleResult", "run_ensemble", "convergence_steps", "best_sequence_index"]


def _as_weights(n_actions: int, weights) -> np.ndarray | None:
    """None (uniform) or the validated probabilities (:func:`kruskal_markov.validation.action_weights`)."""
    return None if weights is None else action_weights(n_actions, weights)


def random_sequences(n_actions: int, count: int, length: int, seed=None, weights=None) -> np.ndarray:
    """``count x length`` random action indices (uint8 when ``n_actions <= 256``).

    Actions are independent and uniform, or drawn with probabilities proportional to ``weights``.
    Every draw comes from ``numpy.random.default_rng(seed)``.

    >>> random_sequences(8, 2, 3, seed=1).shape
    (2, 3)

    Parameters
    ----------
    n_actions, count, length : int
        Actions to draw from, sequences, and actions per sequence.
    seed : int or None
        Seed of ``numpy.random.default_rng``.
    weights : array_like, optional
        Action probabilities up to a factor (default uniform).

    Returns
    -------
    ndarray (count, length)
    """
    for name, v in (("count", count), ("length", length), ("n_actions", n_actions)):
        if isinstance(v, bool) or int(v) != v or v < 0:
            raise ModelError(f"{name} must be a non-negative integer, got {v!r}")
    if n_actions < 1:
        raise ModelError("n_actions must be >= 1")
    count, length, n_actions = int(count), int(length), int(n_actions)
    rng = np.random.default_rng(seed)
    dtype = np.uint8 if n_actions <= 256 else np.int32
    w = _as_weights(n_actions, weights)
    if w is None:
        return rng.integers(0, n_actions, size=(count, length), dtype=dtype)
    cdf = np.cumsum(w)
    cdf[-1] = 1.0
    out = np.empty((count, length), dtype=dtype)
    rows = max(1, (1 << 22) // max(1, length))  # draw in chunks: bounded temporary memory
    for start in range(0, count, rows):
        u = rng.random((min(rows, count - start), length))
        idx = np.searchsorted(cdf, u, side="right")
        np.minimum(idx, n_actions - 1, out=idx)  # u < 1 always; guards zero-weight tail actions
        out[start:start + idx.shape[0]] = idx
    return out


def convergence_steps(entropy: np.ndarray, epsilon: float = ZERO_BITS) -> np.ndarray:
    """First step (column) with entropy <= ``epsilon`` for every row; -1 where never (int64)."""
    h = np.asarray(entropy)
    if h.ndim != 2:
        raise ValueError("entropy must be a 2-D array (sequences x steps)")
    if h.shape[1] == 0:
        return np.full(h.shape[0], -1, dtype=np.int64)
    hit = h <= epsilon
    first = np.argmax(hit, axis=1).astype(np.int64)
    first[~hit[np.arange(h.shape[0]), first]] = -1
    return first


def best_sequence_index(steps: np.ndarray, final_entropy: np.ndarray) -> int:
    """Index of the sequence that converges first; ties by lowest final entropy, then lowest index.

    If no sequence converges, the one with the lowest final entropy (then lowest index).
    """
    steps = np.asarray(steps)
    final_entropy = np.asarray(final_entropy)
    if steps.size == 0:
        raise ValueError("no sequences")
    big = np.iinfo(np.int64).max
    key_steps = np.where(steps >= 0, steps, big)
    order = np.lexsort((np.arange(steps.size), final_entropy, key_steps))
    return int(order[0])


@dataclasses.dataclass(frozen=True)
class EnsembleResult:
    """Statistics of a random-sequence ensemble (arrays of length N+1 are per step, index 0 = start).

    ``entropy`` (K x (N+1)) is kept only when asked for (``keep_entropy=True``).

    Attributes
    ----------
    sequences : ndarray (K, N)
        The random sequences (action indices).
    mean, q25, q75 : ndarray (N+1,)
        Mean and quartiles of the entropy (report partition) after every step.
    mean_states : ndarray (N+1,)
        Mean entropy on the states.
    convergence_steps : ndarray (K,)
        First step with entropy <= ``epsilon`` per sequence, -1 where never.
    converged : int
        Sequences that converged.
    best_index : int
        Index of the best sequence (first to converge; ties: lowest final entropy).
    best_sequence : ndarray (N,)
        That sequence.
    best_entropy : ndarray (N+1,)
        Its entropy after every step.
    epsilon : float
        The convergence threshold (bits).
    max_mass_drift : float
        Largest deviation of the total mass over all sequences.
    entropy : ndarray (K, N+1) or None
        Every entropy, kept with ``keep_entropy=True``.
    """

    sequences: np.ndarray
    mean: np.ndarray
    q25: np.ndarray
    q75: np.ndarray
    mean_states: np.ndarray
    convergence_steps: np.ndarray
    converged: int
    best_index: int
    best_sequence: np.ndarray
    best_entropy: np.ndarray
    epsilon: float
    max_mass_drift: float
    entropy: np.ndarray | None = None


def run_ensemble(model: TransitionModel, count: int, length: int, seed=None, epsilon: float = ZERO_BITS,
                 weights=None, initial=None, keep_entropy: bool = False,
                 threads: int | None = None) -> EnsembleResult:
    """Run K = ``count`` random sequences of ``length`` actions through ``model``.

    Parameters
    ----------
    model : TransitionModel
    count, length : int
    seed : int or None
        Seeds the generator of the sequences (the only randomness).
    epsilon : float
        Convergence threshold in bits (default :data:`~kruskal_markov.entropy.ZERO_BITS`, 1e-9;
        the report's "converged" is :data:`~kruskal_markov.entropy.CONVERGED_BITS`).
    weights : array_like, optional
        Action probabilities (up to a factor); default uniform.
    initial : array_like, optional
        Start distribution (default the model's).
    keep_entropy : bool
        Keep the full K x (N+1) entropy array in the result.

    Returns
    -------
    EnsembleResult

    See Also
    --------
    kruskal_markov.convergence.monte_carlo_entropy_tilts : random tilts until converged, without a length cap.
    kruskal_markov.sync.shortest.shortest_word : the shortest word instead of random ones.

    Notes
    -----
    Statistics are taken on the report partition (``entropy_bits``; on the states for a model
    without partition). Quantiles are numpy's default (linear interpolation). The best sequence
    reaches entropy <= epsilon first (ties: lowest final entropy, then lowest index); if none
    converges, it is the one with the lowest final entropy.
    """
    try:
        epsilon = float(epsilon)
    except (TypeError, ValueError):
        raise ModelError(f"epsilon must be a number, got {epsilon!r}") from None
    if not np.isfinite(epsilon) or epsilon < 0:
        raise ModelError(f"epsilon must be finite and >= 0, got {epsilon!r}")
    if isinstance(count, bool) or int(count) != count or count < 1:
        raise ModelError(f"count must be a positive integer, got {count!r}")
    check_memory(float(count) * (length + 1) * (8 * 3 + 1), f"{count:,} random sequences of {length:,} tilts",
                 "use a smaller --count or --length")
    seqs = random_sequences(model.n_actions, count, length, seed=seed, weights=weights)
    res = batch_entropy(model, seqs, initial=initial, threads=threads)
    h = res.entropy_bits
    mean = h.mean(axis=0)
    q25, q75 = np.quantile(h, [0.25, 0.75], axis=0)
    mean_states = res.entropy_bits_states.mean(axis=0)
    steps = convergence_steps(h, epsilon)
    best = best_sequence_index(steps, h[:, -1])
    return EnsembleResult(
        sequences=seqs, mean=mean, q25=q25, q75=q75, mean_states=mean_states,
        convergence_steps=steps, converged=int(np.count_nonzero(steps >= 0)), best_index=best,
        best_sequence=seqs[best].astype(np.int64), best_entropy=h[best].copy(), epsilon=epsilon,
        max_mass_drift=float(res.mass_drift.max()), entropy=h if keep_entropy else None)
