"""Numba kernels of the kit answers (:mod:`kruskal_markov.kit`): Monte Carlo runs over the disjoint
union of the compartments' automata or models, a run finishing when every compartment has (at the
same step).

Randomness never originates here: letters are drawn in Python and passed in. The per-compartment
arithmetic repeats :func:`kruskal_markov._convergence_kernels.mc_sync_steps` and
``mc_entropy_steps`` in the same order, so a one-compartment kit gives the single part's numbers
bit for bit.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from kruskal_markov._convergence_kernels import _ctz, _image


@njit(cache=True)
def mc_kit_sync_steps(cur, letters, delta, sup, det, comp_of, n_comp, steps, done):
    """Advance every unfinished run ``i`` through ``letters[i, :]`` on the union automaton;
    ``steps[i]`` counts letters applied, ``done[i]`` becomes True when the run's set holds exactly
    one state of every compartment (``comp_of[q]`` is the compartment of union state ``q``)."""
    R, C = letters.shape
    W = cur.shape[1]
    tmp = np.empty(W, dtype=np.uint64)
    count = np.zeros(n_comp, dtype=np.int64)
    for i in range(R):
        if done[i]:
            continue
        for t in range(C):
            _image(cur[i], tmp, letters[i, t], delta, sup, det)
            for c in range(n_comp):
                count[c] = 0
            for w in range(W):
                cur[i, w] = tmp[w]
                x = tmp[w]
                while x != np.uint64(0):
                    b = _ctz(x)
                    x &= x - np.uint64(1)
                    count[comp_of[w * 64 + b]] += 1
            steps[i] += 1
            single = True
            for c in range(n_comp):
                if count[c] != 1:
                    single = False
                    break
            if single:
                done[i] = True
                break


@njit(cache=True)
def mc_kit_entropy_steps(p0, indptr, indices, data, partition, cell_comp, n_cells, n_comp, letters, epsilon,
                         out_steps):
    """For each run ``i``, propagate ``p0`` (every compartment's start distribution, side by side)
    through ``letters[i, :]`` until every compartment's report-cell entropy (bits, its own mass
    normalised) is ``<= epsilon`` at once; ``out_steps[i]`` = tilts, or ``-1`` if never within
    the row. ``partition`` maps union states to union cells, ``cell_comp`` cells to compartments."""
    R, C = letters.shape
    n = p0.shape[0]
    cur = np.empty(n)
    nxt = np.empty(n)
    cells = np.empty(n_cells)
    tot = np.empty(n_comp)
    h = np.empty(n_comp)
    for i in range(R):
        for s in range(n):
            cur[s] = p0[s]
        out_steps[i] = -1
        for t in range(C):
            a = letters[i, t]
            for s in range(n):
                nxt[s] = 0.0
            for s in range(n):
                x = cur[s]
                if x == 0.0:
                    continue
                for e in range(indptr[a, s], indptr[a, s + 1]):
                    nxt[indices[e]] += x * data[e]
            for c in range(n_cells):
                cells[c] = 0.0
            for k in range(n_comp):
                tot[k] = 0.0
                h[k] = 0.0
            for s in range(n):
                cur[s] = nxt[s]
                cells[partition[s]] += nxt[s]
                tot[cell_comp[partition[s]]] += nxt[s]
            for c in range(n_cells):
                if cells[c] > 0.0:
                    k = cell_comp[c]
                    pc = cells[c] / tot[k]
                    h[k] -= pc * np.log2(pc)
            ok = True
            for k in range(n_comp):
                if h[k] > epsilon:
                    ok = False
                    break
            if ok:
                out_steps[i] = t + 1
                break
