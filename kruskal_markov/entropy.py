"""Entropy of distributions and histograms, and its evolution under action sequences.

Bits, Shannon, 0 log 0 = 0. :func:`histogram_entropy_bits` / :func:`distribution_entropy_bits`
for single histograms and vectors; :func:`entropy_trajectory` (one sequence: entropies on the
report partition and on the states, the total mass, optionally the distributions) and
:func:`batch_entropy` (S sequences x N steps, Numba-parallel) for the model.

Numerics (see :mod:`kruskal_markov._entropy_kernels`): distributions are sparse support lists
propagated with mass-conservative row splitting; no renormalisation, the total mass is tracked
and returned (``mass``, ``mass_drift``); probabilities can never come out negative (products and
sums of non-negative numbers; the one subtraction, a row's round-off correction, is clipped at
0); entropies are clamped to their exact range ``[0, log2(#support)]``, which only removes
round-off; subnormal probabilities count exactly.

The batch engine exploits the structure of tilt sequences (Mannam et al.'s Kruskal effect):
sequences that share their first actions share those distributions (a depth-first walk of the
prefix trie), an oriented part is a point mass whose steps cost O(1), and when actions map into
small images a distribution filling an image is advanced by a precomputed gather block.
"""
from __future__ import annotations

import dataclasses

import numba
import numpy as np

from kruskal_markov import _entropy_kernels as _k
from kruskal_markov.model import ModelError, TransitionModel
from kruskal_markov.validation import distribution


def histogram_entropy_bits(counts) -> float:
    """Plug-in Shannon entropy, in bits, of a histogram of non-negative counts.

    Empty bins contribute nothing (0 log 0 = 0). An all-zero histogram has entropy 0.

    >>> histogram_entropy_bits([5, 5, 0, 0])
    1.0

    Parameters
    ----------
    counts : array_like
        Non-negative counts.

    Returns
    -------
    float
    """
    c = np.asarray(counts, dtype=np.float64).ravel()
    if c.size and (not np.all(np.isfinite(c)) or np.any(c < 0)):
        raise ValueError("histogram counts must be finite and non-negative")
    total = c.sum()
    if total <= 0:
        return 0.0
    p = c[c > 0] / total
    return float(max(0.0, -np.sum(p * np.log2(p))))


# --------------------------------------------------------------------------------------------
# Entropy evolution under action sequences (the engine; kernels in _entropy_kernels.py)
# --------------------------------------------------------------------------------------------
__all__ = ["histogram_entropy_bits", "distribution_entropy_bits", "partition_entropy_bits",
           "EntropyTrajectory", "BatchEntropy", "entropy_trajectory", "propagate", "batch_entropy",
           "as_sequence", "as_sequences", "prefers_images", "CONVERGED_BITS", "ZERO_BITS"]

#: "converged" for a model's predicted entropy (bits): the report's, the ranking's and the answers'
#: threshold. A leak of about 1e-4 of the mass into a second cell gives 1e-3 bits, i.e. about one
#: trial in 10,000 of a direct simulation (the paper's zero entropy at M = 10,000).
CONVERGED_BITS = 1e-3

#: numerically zero entropy (bits): the default threshold of :func:`kruskal_markov.ensemble.run_ensemble`
#: and ``kruskal ensemble --epsilon``, where "converged" means one cell up to rounding.
ZERO_BITS = 1e-9


def distribution_entropy_bits(p) -> float:
    """Shannon entropy, in bits, of a probability vector (0 log 0 = 0).

    The vector is read as a distribution up to its total mass: ``H = log2(m) - sum(p log2 p)/m``
    with ``m = sum(p)``, clamped to ``[0, log2(#non-zeros)]`` (its exact range) so round-off never
    makes it negative or too large. Values down to the smallest subnormal are handled.

    >>> distribution_entropy_bits([0.25, 0.25, 0.5, 0.0])
    1.5

    Parameters
    ----------
    p : array_like
        Non-negative weights.

    Returns
    -------
    float
    """
    p = np.asarray(p, dtype=np.float64).ravel()
    if p.size and (not np.all(np.isfinite(p)) or np.any(p < 0)):
        raise ValueError("a distribution must be finite and non-negative")
    nz = p[p > 0]
    if nz.size == 0:
        return 0.0
    return float(_k.entropy_of(np.ascontiguousarray(nz)))


def partition_entropy_bits(p, partition, n_cells: int | None = None) -> float:
    """Entropy (bits) of the distribution ``p`` coarse-grained by ``partition`` (state -> cell).

    Parameters
    ----------
    p : array_like (n,)
        A distribution over states.
    partition : array_like (n,) of int
        State -> cell.
    n_cells : int, optional
        Number of cells (default ``max(partition) + 1``).

    Returns
    -------
    float
    """
    p = np.asarray(p, dtype=np.float64).ravel()
    partition = np.asarray(partition).ravel()
    if partition.shape != p.shape:
        raise ValueError(f"partition has {partition.size} entries, distribution has {p.size}")
    if n_cells is None:
        n_cells = int(partition.max()) + 1 if partition.size else 0
    return distribution_entropy_bits(np.bincount(partition, weights=p, minlength=n_cells))


def as_sequence(model: TransitionModel, sequence) -> np.ndarray:
    """Validate one sequence (action names or indices) and return it as an int64 array.

    Raises :class:`~kruskal_markov.model.ModelError` naming the bad entry.
    """
    if isinstance(sequence, str):
        sequence = [s for s in (t.strip() for t in sequence.split(",")) if s] if sequence.strip() else []
    seq = list(sequence) if not isinstance(sequence, np.ndarray) else sequence
    if isinstance(seq, list) and any(isinstance(s, str) for s in seq):
        return np.asarray([model.action_index(s) if isinstance(s, str) else _bad_entry(model, i, s)
                           for i, s in enumerate(seq)], dtype=np.int64)
    arr = np.asarray(seq)
    if arr.size == 0:
        return np.zeros(0, dtype=np.int64)
    if arr.ndim != 1:
        raise ModelError(f"a sequence must be 1-dimensional, got shape {arr.shape}")
    return _check_indices(model, arr, "sequence")


def _bad_entry(model, i, s):
    raise ModelError(f"sequence entry {i} is {s!r}, not an action name; known actions: "
                     f"{','.join(model.actions)}")


def _check_indices(model, arr, what):
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
        raise ModelError(f"{what} must hold action indices or names, got dtype {arr.dtype}")
    if np.issubdtype(arr.dtype, np.floating):
        bad = ~np.isfinite(arr) | (arr != np.round(arr))
        if np.any(bad):
            pos = np.unravel_index(int(np.flatnonzero(bad.ravel())[0]), arr.shape)
            raise ModelError(f"{what} entry {tuple(int(x) for x in pos) if arr.ndim > 1 else int(pos[0])} "
                             f"is {arr[pos].item()!r}, not an integer action index")
    k = model.n_actions
    bad = (arr < 0) | (arr >= k)
    if np.any(bad):
        flat = int(np.flatnonzero(bad.ravel())[0])
        pos = np.unravel_index(flat, arr.shape)
        where = int(pos[0]) if arr.ndim == 1 else tuple(int(x) for x in pos)
        raise ModelError(f"{what} entry {where} is {arr[pos].item()!r}, not an action index in [0, {k})")
    return arr.astype(np.int64)


def as_sequences(model: TransitionModel, sequences) -> np.ndarray:
    """Validate a batch (``S x N`` action indices) and return it compact (uint8 if <= 256 actions)."""
    arr = np.asarray(sequences)
    if arr.dtype.kind in "US" or arr.dtype == object:
        arr = np.asarray([as_sequence(model, s) for s in sequences])
    if arr.ndim != 2:
        raise ModelError(f"a batch of sequences must be 2-dimensional (S x N), got shape {arr.shape}")
    if arr.size:
        if arr.dtype == np.uint8 and model.n_actions <= 256:
            if int(arr.max()) >= model.n_actions:
                _check_indices(model, arr, "sequences")
            return arr
        _check_indices(model, arr, "sequences")
    return arr.astype(np.uint8 if model.n_actions <= 256 else np.int32)


def _initial_support(model: TransitionModel, initial):
    if initial is None:
        p = model.initial
    else:
        p = distribution(initial, model.n_states, model.tol)
    idx = np.flatnonzero(p > 0).astype(np.int32)
    return idx, np.ascontiguousarray(p[idx]), float(p[idx].sum())


def _kernel_arrays(model: TransitionModel):
    """Packed matrices with each row's pivot first (cached on the model), and the partition."""
    def pack():
        indptr, indices, data = model.packed()
        indices, data = indices.copy(), data.copy()
        _k.pivot_first(indptr, indices, data)
        img_ptr, img_idx = _k.action_images(indptr, indices, model.n_states)
        for arr in (indices, data, img_ptr, img_idx):
            arr.flags.writeable = False
        return indptr, indices, data, img_ptr, img_idx

    indptr, indices, data, img_ptr, img_idx = model.memo("entropy_packed", pack)
    if model.partition is None:
        partition, n_cells, has = _NO_PARTITION, 1, False
    else:
        partition, n_cells, has = model.partition, model.n_cells, True
    return indptr, indices, data, img_ptr, img_idx, partition, n_cells, has


def _frozen(arr: np.ndarray) -> np.ndarray:
    """``arr`` made read-only. The kernels take the model's cached arrays, which are read-only, and
    Numba compiles a kernel once per signature, read-only flags included: placeholders passed in
    their place are read-only too, so that each kernel compiles once instead of once per mix."""
    arr.flags.writeable = False
    return arr


_NO_BLOCKS = tuple(_frozen(a) for a in (np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64),
                                        np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int32),
                                        np.zeros(0, dtype=np.float64)))
_NO_PARTITION = _frozen(np.zeros(1, dtype=np.int64))

#: image blocks are built when they hold at most this many times the model's non-zeros
_BLOCK_BUDGET = 2.0


def _image_blocks(model: TransitionModel, conservative: bool):
    """The per-(previous action, action) gather blocks of :func:`_entropy_kernels.image_blocks`,
    cached on the model; None when they would be too large (images close to the full state set)."""
    def build():
        indptr, indices, data, img_ptr, img_idx, _, _, _ = _kernel_arrays(model)
        row_len = np.diff(indptr, axis=1)
        total = sum(int(row_len[a, img_idx[img_ptr[b]:img_ptr[b + 1]]].sum())
                    for b in range(model.n_actions) for a in range(model.n_actions))
        nnz = int(indptr[-1, -1])
        if total > _BLOCK_BUDGET * nnz + 10_000:
            return None
        blocks = _k.image_blocks(indptr, indices, data, img_ptr, img_idx, model.n_states,
                                 bool(conservative))
        for arr in blocks:
            arr.flags.writeable = False
        return blocks

    return model.memo(("image_blocks", bool(conservative)), build)


@dataclasses.dataclass(frozen=True)
class EntropyTrajectory:
    """Entropy along one sequence.

    Attributes
    ----------
    entropy_bits : ndarray (N+1,)
        Entropy on the report partition (on the states when the model has no partition).
    entropy_bits_states : ndarray (N+1,)
        Entropy on the model states.
    mass : ndarray (N+1,)
        Total probability mass after every step (1 up to round-off; never renormalised).
    distributions : ndarray (N+1, n) or None
        The distributions, when asked for.
    support : ndarray (N+1,) or None
        Number of states with positive probability after every step.
    """

    entropy_bits: np.ndarray
    entropy_bits_states: np.ndarray
    mass: np.ndarray
    distributions: np.ndarray | None = None
    support: np.ndarray | None = None

    @property
    def mass_drift(self) -> float:
        """Largest ``|mass[t] - mass[0]|`` along the sequence."""
        return float(np.max(np.abs(self.mass - self.mass[0]))) if self.mass.size else 0.0


def entropy_trajectory(model: TransitionModel, sequence, initial=None, return_distributions=False,
                       conservative: bool = True) -> EntropyTrajectory:
    """Propagate ``initial`` (default ``model.initial``) along ``sequence``; entropies after every step.

    Parameters
    ----------
    model : TransitionModel
    sequence : sequence of action names or indices (length N)
    initial : array_like, optional
    return_distributions : bool
        Also return the dense ``(N+1) x n`` distributions (memory!).
    conservative : bool
        Mass-conservative splitting of every row (see :mod:`kruskal_markov._entropy_kernels`);
        ``False`` gives the plain product ``p @ P``.

    Returns
    -------
    EntropyTrajectory
        Entropies after steps 0..N (report partition and states) and, if asked, the distributions.

    Notes
    -----
    Work per step is proportional to the non-zeros of the rows in the current support, not to
    ``n`` (the support shrinks as the tray orients the part), so a 10^6-step sequence is cheap.
    Row ``t`` of the result is the distribution after the first ``t`` actions:
    ``p_t = p_0 P_{a_1} ... P_{a_t}`` (row vector times matrices).
    """
    seq = as_sequence(model, sequence)
    init_idx, init_p, _ = _initial_support(model, initial)
    indptr, indices, data, img_ptr, img_idx, partition, n_cells, has = _kernel_arrays(model)
    n_out = seq.size + 1
    hc = np.empty(n_out)
    hs = np.empty(n_out) if has else hc
    mass = np.empty(n_out)
    dist = np.zeros((n_out, model.n_states)) if return_distributions else np.zeros((1, 1))
    hs_buf = hs if has else np.empty(n_out)
    support = np.empty(n_out, dtype=np.int64)
    _k.walk(indptr, indices, data, img_ptr, img_idx, init_idx, init_p, seq, partition, n_cells, has,
            conservative, hc, hs_buf, mass, support, dist, return_distributions)
    return EntropyTrajectory(hc, hs_buf if has else hc, mass, dist if return_distributions else None,
                             support)


def propagate(model: TransitionModel, sequence, initial=None) -> np.ndarray:
    """The distributions after every step of ``sequence``: a dense ``(N+1) x n`` array.

    Parameters
    ----------
    model : TransitionModel
        The model.
    sequence : sequence of action names or indices
        Length N.
    initial : array_like, optional
        Start distribution (default ``model.initial``).

    Returns
    -------
    ndarray (N+1, n)
    """
    return entropy_trajectory(model, sequence, initial, return_distributions=True).distributions


@dataclasses.dataclass(frozen=True)
class BatchEntropy:
    """Entropies of S sequences: arrays ``(S, N+1)`` and the per-sequence mass drift ``(S,)``.

    ``entropy_bits`` is on the report partition (the same array as ``entropy_bits_states`` when
    the model has no partition); ``mass_drift[s]`` is ``max_t |mass_t - mass_0|``.

    Attributes
    ----------
    entropy_bits : ndarray (S, N+1)
        Entropy on the report partition after every step.
    entropy_bits_states : ndarray (S, N+1)
        Entropy on the states.
    mass_drift : ndarray (S,)
        Largest deviation of the total mass from its start, per sequence.
    engine : str
        The engine that ran (``images``, ``trie`` or ``independent``; :func:`batch_entropy`'s
        ``method`` after ``auto`` and ``share_prefixes`` were resolved).
    gather_blocks : bool
        Whether the gather blocks of the actions' images were used.
    """

    entropy_bits: np.ndarray
    entropy_bits_states: np.ndarray
    mass_drift: np.ndarray
    engine: str = "trie"
    gather_blocks: bool = False


def _images_layout(model: TransitionModel):
    """Per action: local report cell of every image state (for the image engine)."""
    def layout():
        _, _, _, img_ptr, img_idx, partition, _, has = _kernel_arrays(model)
        k = model.n_actions
        cell_ptr = img_ptr[:-1].astype(np.int64)
        cell_loc = np.zeros(img_idx.size, dtype=np.int64)
        n_cells_img = np.ones(k, dtype=np.int64)
        if has:
            for a in range(k):
                uniq, loc = np.unique(partition[img_idx[img_ptr[a]:img_ptr[a + 1]]], return_inverse=True)
                cell_loc[img_ptr[a]:img_ptr[a + 1]] = loc
                n_cells_img[a] = max(1, uniq.size)
        return cell_ptr, cell_loc, n_cells_img

    return model.memo("images_layout", layout)


def prefers_images(model: TransitionModel, conservative: bool) -> bool:
    """Deterministic choice of the image engine: the gather blocks exist, every image has at
    least 64 states, and on 16 fixed random sequences the support fills on average at least
    half of the image after each of the first 6 steps (mixing, tray-like models -- not a
    contracting tray whose supports shrink to a few states, where the trie is faster)."""
    def verdict():
        img_ptr = _kernel_arrays(model)[3]
        sizes = np.diff(img_ptr)
        if sizes.min() < 64 or _image_blocks(model, conservative) is None:
            return False
        rng = np.random.default_rng(12345)
        fills = [entropy_trajectory(model, seq, conservative=conservative).support[1:] / sizes[seq]
                 for seq in rng.integers(0, model.n_actions, size=(16, 6))]
        return bool(np.mean(fills) >= 0.5)

    return model.memo(("prefer_images", bool(conservative)), verdict)


def batch_entropy(model: TransitionModel, sequences, initial=None, *, share_prefixes: bool = True,
                  conservative: bool = True, threads: int | None = None,
                  image_blocks: bool | None = None, method: str = "auto",
                  chunk: int = 4096) -> BatchEntropy:
    """Entropies after every step of S sequences of length N, in parallel (Numba).

    Parameters
    ----------
    model : TransitionModel
    sequences : array_like (S, N)
        Action indices (or names).
    initial : array_like, optional
        Start distribution (default ``model.initial``).
    share_prefixes : bool
        Walk the prefix trie of the sequences (default): sequences sharing their first ``d``
        actions share the distribution after ``d`` steps, computed once. ``False`` propagates
        every sequence on its own (same arithmetic, used as a check and for benchmarks).
    conservative : bool
        Mass-conservative row splitting (see :func:`entropy_trajectory`).
    threads : int, optional
        Numba threads (default: Numba's setting).
    image_blocks : bool, optional
        Use the gather blocks of :func:`kruskal_markov._entropy_kernels.image_blocks` for steps
        whose support fills the previous action's image (default: when the blocks are small,
        i.e. when actions map into small images as tray tilts do; False: never).
    method : {"auto", "trie", "independent", "images"}
        ``"trie"``: the prefix-trie walk on sparse supports (``share_prefixes=False`` means
        ``"independent"``: every sequence on its own). ``"images"``: level-synchronous dense
        image vectors, ``chunk`` sequences at a time, grouped at every step by (previous action,
        action) and advanced by vectorized sparse-times-dense products
        (:func:`kruskal_markov._entropy_kernels.batch_images`) -- for models whose
        distributions fill the actions' images. ``"auto"``: ``"images"`` when a deterministic
        test on the model says so (:func:`prefers_images`), else ``"trie"``. All methods agree
        to round-off (~1e-14).
    chunk : int
        Sequences per task of the image engine (memory: 3 x largest image x chunk float64).

    Returns
    -------
    BatchEntropy

    Notes
    -----
    Memory is the output (``2 S (N+1)`` float64, one array when there is no partition), the
    sequences, two int64 permutations of length S, and O(n) scratch per parallel task -- never
    an ``S x n`` array. Distributions are sparse support lists, so work per step is
    proportional to the support's row non-zeros; after a few tilts the support of a tray model
    is tiny (the Kruskal effect), and a point mass on deterministic rows costs O(1) per step.
    Parallel tasks are the groups of sequences sharing their first ``L`` actions
    (``K**L >= 16 * threads``), handed out dynamically (chunk size 1).
    """
    if method not in ("auto", "trie", "independent", "images"):
        raise ValueError(f"unknown method {method!r}; expected auto, trie, independent or images")
    if isinstance(chunk, bool) or int(chunk) != chunk or chunk < 1:
        raise ValueError(f"chunk must be a positive integer, got {chunk!r}")
    seqs = as_sequences(model, sequences)
    s_count, n_steps = seqs.shape
    if not share_prefixes and method in ("auto", "trie"):
        method = "independent"
    if method == "auto":
        method = "images" if (image_blocks is not False and s_count >= 256 and n_steps >= 1
                              and prefers_images(model, conservative)) else "trie"
    if method == "images" and _image_blocks(model, conservative) is None:
        raise ValueError("method 'images' needs gather blocks, too large for this model (its actions "
                         "do not map into small images)")
    init_idx, init_p, m0 = _initial_support(model, initial)
    indptr, indices, data, img_ptr, img_idx, partition, n_cells, has = _kernel_arrays(model)
    hc = np.zeros((s_count, n_steps + 1))
    hs = np.zeros((s_count, n_steps + 1)) if has else hc
    drift = np.zeros(s_count)
    if s_count == 0:
        return BatchEntropy(hc, hs, drift, method)
    prev_threads = numba.get_num_threads()
    if threads is not None:
        threads = int(threads)
        if threads < 1:
            raise ValueError(f"threads must be >= 1, got {threads}")
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        n_threads = numba.get_num_threads()
        k = model.n_actions
        if method == "images":
            _run_images(model, conservative, init_idx, init_p, m0, seqs, chunk, has, hc, hs, drift, n_threads)
            return BatchEntropy(hc, hs, drift, "images", True)
        if method == "trie":
            order, task_lo, task_hi, block_ptr = _trie_tasks(seqs, k, n_threads)
        else:
            order, task_lo, task_hi, block_ptr = _independent_tasks(s_count, n_threads)
        blocks = _image_blocks(model, conservative) if image_blocks is not False else None
        with numba.parallel_chunksize(1):
            _k.batch(indptr, indices, data, img_ptr, img_idx, blocks is not None,
                     *(blocks if blocks is not None else _NO_BLOCKS), init_idx, init_p, m0, seqs,
                     order, task_lo, task_hi, block_ptr, partition, n_cells, has, conservative, hc,
                     hs, drift)
    finally:
        if threads is not None:
            numba.set_num_threads(prev_threads)
    return BatchEntropy(hc, hs, drift, method, blocks is not None)


def _run_images(model, conservative, init_idx, init_p, m0, seqs, chunk, has, hc, hs, drift, n_threads):
    """The image engine (:func:`_entropy_kernels.batch_images`): the distribution after every
    first action, then chunks of sequences advanced level by level; fills ``hc``, ``hs``, ``drift``."""
    _, _, _, img_ptr, img_idx, _, _, _ = _kernel_arrays(model)
    k = model.n_actions
    p0 = np.zeros(model.n_states)
    p0[init_idx] = init_p
    sizes = np.diff(img_ptr)
    first = np.zeros((k, int(sizes.max())))
    for a in range(k):
        d1 = entropy_trajectory(model, [a], p0, return_distributions=True,
                                conservative=conservative).distributions[1]
        first[a, :sizes[a]] = d1[img_idx[img_ptr[a]:img_ptr[a + 1]]]
    start = entropy_trajectory(model, [], p0)
    cell_ptr, cell_loc, n_cells_img = _images_layout(model)
    s_count = seqs.shape[0]
    chunk = int(min(chunk, max(1, -(-s_count // n_threads))))
    with numba.parallel_chunksize(1):
        _k.batch_images(img_ptr, img_idx, *_image_blocks(model, conservative), first, cell_ptr,
                        cell_loc, n_cells_img, float(start.entropy_bits[0]),
                        float(start.entropy_bits_states[0]), m0, seqs, chunk, has, hc, hs, drift)


def _trie_tasks(seqs, k: int, n_threads: int):
    """Parallel tasks of the prefix-trie engine: the groups of sequences sharing their first ``L``
    actions (``k**L >= 16 * threads``). Returns ``order`` (sequences grouped), the groups'
    ``task_lo`` / ``task_hi`` in it, and ``block_ptr`` (one group per block)."""
    s_count, n_steps = seqs.shape
    depth = 0
    while k ** depth < 16 * n_threads and depth < n_steps and k ** depth < s_count and k > 1:
        depth += 1
    if depth == 0:
        order = np.arange(s_count, dtype=np.int64)
        task_lo = np.zeros(1, dtype=np.int64)
        task_hi = np.full(1, s_count, dtype=np.int64)
    else:
        key = np.zeros(s_count, dtype=np.int64)
        for t in range(depth):
            key *= k
            key += seqs[:, t]
        order = np.argsort(key, kind="stable").astype(np.int64)
        counts = np.bincount(key, minlength=k ** depth)
        ends = np.cumsum(counts)
        starts = ends - counts
        keep = counts > 0
        task_lo, task_hi = starts[keep].astype(np.int64), ends[keep].astype(np.int64)
    return order, task_lo, task_hi, np.arange(task_lo.size + 1, dtype=np.int64)


def _independent_tasks(s_count: int, n_threads: int):
    """Every sequence its own task, in ``8 * threads`` blocks (no prefix sharing)."""
    order = np.arange(s_count, dtype=np.int64)
    n_blocks = min(s_count, 8 * n_threads)
    return order, order.copy(), order + 1, np.linspace(0, s_count, n_blocks + 1).astype(np.int64)
