"""The largest probability each state reaches along many random sequences (the builder's row weights).

The builder weighs its rows (``builder._orbit_weights``) by pushing one distribution per random
sequence through the model built so far and keeping, for every state, the largest probability it
holds at any step. Done as sparse matrix products over blocks of columns (``P_a^T @ dist[:, cols]``)
this spent 3 s of a build on gathering and scattering columns while the simulation workers waited.
This kernel walks each sequence on its own instead (threads over sequences), with the same
arithmetic as scipy's product: row ``i`` of ``P_a^T`` summed in stored order from 0, no fused
multiply-add, so the weights are the same to the last bit.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit, prange


@njit(cache=True, parallel=True)
def _sequence_maxima(indptr, indices, data, initial, seqs):      # pragma: no cover - compiled
    n_seq, length = seqs.shape
    n = initial.shape[0]
    out = np.empty((n_seq, n))
    for s in prange(n_seq):
        cur = initial.copy()
        best = initial.copy()
        nxt = np.empty(n)
        for t in range(length):
            a = seqs[s, t]
            for i in range(n):
                acc = 0.0
                for jj in range(indptr[a, i], indptr[a, i + 1]):
                    acc += data[jj] * cur[indices[jj]]
                nxt[i] = acc
                if acc > best[i]:
                    best[i] = acc
            cur, nxt = nxt, cur
        out[s] = best
    return out


def max_probability_along(matrices, initial: np.ndarray, sequences: np.ndarray) -> np.ndarray:
    """For every state, the largest probability it holds at any step of any of ``sequences``.

    Parameters
    ----------
    matrices : list of scipy.sparse matrices (n, n)
        Row-stochastic transition matrices, one per action.
    initial : ndarray (n,)
        The distribution before the first action (step 0 counts).
    sequences : ndarray (count, length) int
        Action indices.

    Returns
    -------
    ndarray (n,)
        ``max over sequences s and steps t of (initial @ P_{s_1} ... P_{s_t})[i]``.
    """
    init = np.ascontiguousarray(initial, dtype=np.float64).view()
    init.flags.writeable = False        # whether or not the caller's was: one compiled signature
    seqs = np.ascontiguousarray(sequences, dtype=np.int64)
    n = len(init)
    if seqs.ndim != 2 or (seqs.size and (seqs.min() < 0 or seqs.max() >= len(matrices))):
        raise ValueError("sequences must be a 2-d array of action indices")
    transposed = [sp.csr_matrix(P).T.tocsr() for P in matrices]
    if any(T.shape != (n, n) for T in transposed):
        raise ValueError("every matrix must be n x n with n = len(initial)")
    offsets = np.cumsum([0] + [T.nnz for T in transposed])
    indptr = np.stack([T.indptr.astype(np.int64) + off for T, off in zip(transposed, offsets)])
    indices = np.concatenate([T.indices.astype(np.int64) for T in transposed])
    data = np.concatenate([T.data.astype(np.float64) for T in transposed])
    if len(seqs) == 0:
        return init.copy()
    return _sequence_maxima(indptr, indices, data, init, seqs).max(axis=0)
