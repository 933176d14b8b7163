"""The deepest level of the inverse depth-first phase, tested without being stored.

Sets at the level a depth-first descent stops at are only tested against the forward trie, never
expanded again, so they need no store: no duplicate removal, parents or letter arrays (a sixteenth
of them are duplicates on random 8 x 200, docs/plans.md). Their preimages are generated unhashed
slice by slice (:func:`~kruskal_markov._sync_kernels.level_images`) and queried at once; the
trie's size filter (:class:`~kruskal_markov.sync._trie.SizeSplit`) answers the preimages smaller
than every forward set (nine in ten at 8 x 200) without a walk. synchrowords likewise tests the
last level of its inverse search without keeping it (M. Szykula and A. Zyzik, "An improved
algorithm for finding the shortest synchronizing words", ESA 2022, LIPIcs 244). Our own code.
"""
from __future__ import annotations

import numpy as np

from kruskal_markov import _sync_kernels as _k
from kruskal_markov.sync import _rowtrie, _trie

__all__ = ["first_leaf_hit", "first_leaf_hit_batched", "preimage"]

#: preimages generated per slice (about 32 MB of rows at 200 states)
SLICE = 1 << 20


def _preimage_slices(aut, rows, slice_rows, tasks, over_budget, used, emit):
    """Yield ``(lo, hi, preimages of rows[lo:hi] under every letter)`` slice by slice, at most
    ``slice_rows`` preimages (at least ``k``) at a time; ``(lo, hi, None)``, then stop, when
    ``over_budget()`` is true before a slice is generated. Counts the preimages in ``used[0]`` and
    tells ``emit`` ``("dfs-batch", rows in the slice)`` (the shared loop of both leaf tests)."""
    inv_ptr, inv_idx, supcount = aut.inverse
    step = max(1, slice_rows // aut.k)
    for lo in range(0, rows.shape[0], step):
        hi = min(rows.shape[0], lo + step)
        if over_budget is not None and over_budget():
            yield lo, hi, None
            return
        if emit is not None:
            emit("dfs-batch", hi - lo)
        pre = _k.level_images(rows, lo, hi, aut.delta, aut.step_table(False), aut.deterministic, False, inv_ptr,
                              inv_idx, supcount, tasks=tasks)
        if used is not None:
            used[0] += pre.shape[0]
        yield lo, hi, pre
        del pre    # the caller's reference alone keeps a slice alive while the next one is generated


def first_leaf_hit(aut, rows: np.ndarray, fsorted: np.ndarray, fsplit, tasks: int = 1, over_budget=None,
                   used=None, slice_rows: int = SLICE, emit=None):
    """The first preimage of a row of ``rows`` (under any letter) that contains a row of the sorted
    forward trie ``fsorted``: ``(row index, letter)``, ``None`` when none does, or ``"budget"``
    when ``over_budget()`` is true before a slice is generated or before it is tested (as the
    stored levels' sets are counted when generated and checked before their test). At most
    ``slice_rows`` preimages (at least ``k``) are held at a time (the depth-first phase's memory
    cap). ``used[0]`` (if given) is increased by the preimages generated; ``emit`` (if given) is
    told ``("dfs-batch", rows in the slice)``."""
    k = aut.k
    for lo, _, pre in _preimage_slices(aut, rows, slice_rows, tasks, over_budget, used, emit):
        if pre is None or (over_budget is not None and over_budget()):
            return "budget"
        hit = np.flatnonzero(_trie.superset_mask(fsorted, pre, sorted_stored=True, tasks=tasks, split=fsplit))
        if hit.size:
            i = int(hit[0])
            return lo + i // k, i % k
    return None


def first_leaf_hit_batched(aut, rows: np.ndarray, fsorted: np.ndarray, fsplit, batch: int, cfilter=None, tasks: int = 1,
                           over_budget=None, used=None, slice_rows: int = SLICE, emit=None):
    """:func:`first_leaf_hit` with the preimages that may contain a forward set (at least as
    large as the smallest one, and kept by ``cfilter``'s per-block counts,
    :class:`~kruskal_markov.sync._countfilter.CountFilter`, if given) gathered from successive
    slices into one compact batch of about ``batch`` rows, which walks the trie with its rows
    moved in place (:func:`~kruskal_markov.sync._rowtrie.superset_mask_rows`). Returns a
    ``(row index, letter)`` whose preimage contains a forward set (the first within its batch; any
    hit of the deepest level gives a word of the same length), ``None`` when none does, or
    ``"budget"`` when ``over_budget()`` is true before a slice is generated or a batch tested."""
    k = aut.k
    parts, ids, held = [], [], 0
    for lo, hi, pre in _preimage_slices(aut, rows, slice_rows, tasks, over_budget, used, emit):
        if pre is None:
            return "budget"
        keep = cfilter.keep(pre) if cfilter is not None else _k._level_sizes(pre, 0, pre.shape[0]) >= fsplit.min_size
        idx = np.flatnonzero(keep)
        parts.append(pre[idx])
        ids.append(lo * k + idx)
        held += idx.size
        del pre
        if held < batch and hi < rows.shape[0]:
            continue
        if over_budget is not None and over_budget():
            return "budget"
        got = _rowtrie.superset_mask_rows(fsorted, np.concatenate(parts), fsplit, tasks=tasks) if held else None
        if got is not None and got.any():
            g = int(np.concatenate(ids)[np.flatnonzero(got)[0]])
            return g // k, g % k
        parts, ids, held = [], [], 0
    return None


def preimage(aut, row: np.ndarray, letter: int) -> np.ndarray:
    """The preimage of one bitset row under ``letter`` (the set a hit of :func:`first_leaf_hit` names)."""
    inv_ptr, inv_idx, supcount = aut.inverse
    pre = _k.level_images(np.ascontiguousarray(row[None, :], dtype=np.uint64), 0, 1, aut.delta, aut.step_table(False),
                          aut.deterministic, False, inv_ptr, inv_idx, supcount, tasks=1)
    return pre[letter]
