"""The validated transition model: one row-stochastic sparse matrix per action.

A :class:`TransitionModel` is the abstract tray: ``n`` states (pose voxels, or automaton states),
one CSR matrix ``P_a`` per action ``a`` with ``P_a[i, j]`` = probability that action ``a`` moves
state ``i`` to state ``j``, an initial distribution, an optional partition of the states into
report cells (the paper's coarse entropy grid) and free-form JSON metadata.

Validation follows deeptime's ``transition_matrix_tolerance`` style: every error says which action,
which row and by how much (see :class:`ModelError`). A model is immutable once built: its arrays
are read-only so that derived data (packed kernel arrays, deterministic tables) stay valid.
"""
from __future__ import annotations

import io
import json
import os
import tempfile
import zipfile

import numpy as np
import scipy.sparse as sp

from kruskal_markov.errors import ModelError
from kruskal_markov.validation import action_position, beyond, check_number, distribution

__all__ = ["ModelError", "TransitionModel", "FORMAT_NAME", "FORMAT_VERSION", "atomic_savez", "atomic_write_text"]

#: Marker stored in every saved model; a ``.npz`` without it is rejected as foreign.
FORMAT_NAME = "kruskal.TransitionModel"
FORMAT_VERSION = 1
#: prefix of the ``.npz`` members that hold :attr:`TransitionModel.extras`.
_EXTRA_PREFIX = "x_"


def _atomic_write(path, write, suffix: str, prefix: str = ".tmp-", binary: bool = True) -> str:
    """Call ``write(fh)`` on a temporary file in ``path``'s directory, fsync, then ``os.replace`` it
    onto ``path``: a reader sees the old file or the new one, never a part."""
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    os.makedirs(directory, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=prefix, suffix=suffix, dir=directory)
    try:
        with (os.fdopen(fd, "wb") if binary else os.fdopen(fd, "w", encoding="utf-8")) as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)   # mkstemp's 0600 would make every result private
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path


def atomic_savez(path, arrays: dict, prefix: str = ".tmp-") -> str:
    """Write ``arrays`` to an uncompressed ``.npz`` at ``path`` atomically (temporary file in the same
    directory, fsync, ``os.replace``): a reader sees the old file or the new one, never a part.

    Parameters
    ----------
    path : str or path-like
        The file written.
    arrays : dict of str to array_like
        Name -> array.
    prefix : str, default ".tmp-"
        Prefix of the temporary file.

    Returns
    -------
    str
        ``path``.
    """
    return _atomic_write(path, lambda fh: np.savez(fh, **arrays), ".npz", prefix)


def atomic_write_text(path, text: str) -> str:
    """Write ``text`` (UTF-8) to ``path`` atomically, like :func:`atomic_savez`.

    Parameters
    ----------
    path : str or path-like
        The file written.
    text : str
        Its content.

    Returns
    -------
    str
        ``path``.
    """
    return _atomic_write(path, lambda fh: fh.write(text), os.path.splitext(os.fspath(path))[1], binary=False)


#: the largest row-sum tolerance a model file may ask for: the tolerance belongs to the reader, so a
#: file cannot switch its own validation off (a file's smaller tolerance is kept).
MAX_FILE_TOL = 1e-6


def _file_tolerance(header: dict) -> float:
    tol = header.get("tol", 1e-9)
    return min(check_number(tol, "header tolerance", lo=0, error=ModelError), MAX_FILE_TOL)


def _json_default(value):
    """Convert numpy scalars and arrays (and tuples/sets) for ``json.dumps``."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (set, frozenset)):
        return sorted(value)
    raise TypeError(f"object of type {type(value).__name__} is not JSON serialisable")


def _normalise_metadata(metadata) -> dict:
    if metadata is None:
        return {}
    if not isinstance(metadata, dict):
        raise ModelError(f"metadata must be a dict, got {type(metadata).__name__}")
    try:
        text = json.dumps(metadata, default=_json_default, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"metadata is not JSON-serialisable: {exc}") from None
    except RecursionError:
        raise ModelError("metadata is nested too deeply") from None
    return json.loads(text)


def _normalise_extras(extras) -> dict:
    if extras is None:
        return {}
    if not isinstance(extras, dict):
        raise ModelError(f"extras must be a dict of arrays, got {type(extras).__name__}")
    out = {}
    for key, value in extras.items():
        if not isinstance(key, str) or not key.isidentifier():
            raise ModelError(f"extras key {key!r} must be an identifier")
        arr = np.array(value)
        if arr.dtype.kind not in "biuf":
            raise ModelError(f"extras array {key!r} must be numeric, got dtype {arr.dtype}")
        arr.flags.writeable = False
        out[key] = arr
    return out


def _fmt_action(name: str) -> str:
    return f"action {name!r}"


def _as_csr(matrix, name: str) -> sp.csr_matrix:
    """Convert one action's matrix (sparse or dense) to canonical float64 CSR, checking shape and values."""
    try:
        if sp.issparse(matrix):
            m = sp.csr_matrix(matrix, dtype=np.float64, copy=True)
        else:
            arr = np.asarray(matrix)
            if arr.dtype == object or not (np.issubdtype(arr.dtype, np.number) or arr.dtype == bool):
                raise ModelError(f"{_fmt_action(name)}: matrix must be numeric, got dtype {arr.dtype}")
            if arr.ndim != 2:
                raise ModelError(f"{_fmt_action(name)}: matrix must be 2-dimensional, got shape {arr.shape}")
            m = sp.csr_matrix(arr.astype(np.float64))
    except ModelError:
        raise
    except (TypeError, ValueError) as exc:
        raise ModelError(f"{_fmt_action(name)}: cannot convert to a sparse matrix: {exc}") from None
    if m.shape[0] != m.shape[1]:
        raise ModelError(f"{_fmt_action(name)}: matrix is {m.shape[0]} x {m.shape[1]}, not square")
    m.sum_duplicates()
    if not np.all(np.isfinite(m.data)):
        bad = int(np.flatnonzero(~np.isfinite(m.data))[0])
        row = int(np.searchsorted(m.indptr, bad, side="right") - 1)
        raise ModelError(f"{_fmt_action(name)}: row {row} has a non-finite entry "
                         f"{float(m.data[bad])!r} at column {int(m.indices[bad])}")
    if np.any(m.data < 0):
        bad = int(np.argmin(m.data))
        row = int(np.searchsorted(m.indptr, bad, side="right") - 1)
        raise ModelError(f"{_fmt_action(name)}: row {row} has a negative entry {m.data[bad]:.6g} "
                         f"at column {int(m.indices[bad])}")
    m.eliminate_zeros()
    m.sort_indices()
    return m


def _checked_tol(tol) -> float:
    try:
        tol = float(tol)
    except (TypeError, ValueError):
        raise ModelError(f"tol must be a number, got {tol!r}") from None
    if not (np.isfinite(tol) and tol >= 0):
        raise ModelError(f"tol must be finite and >= 0, got {tol!r}")
    return tol


def _checked_action_names(actions) -> tuple[str, ...]:
    """Non-empty, comma-free names, distinct even ignoring case (command-line sequences are not
    case-sensitive)."""
    if isinstance(actions, str):
        raise ModelError("actions must be a sequence of names, not a single string")
    actions = tuple(actions)
    if not actions:
        raise ModelError("a model needs at least one action")
    for a in actions:
        if not isinstance(a, str) or not a.strip():
            raise ModelError(f"action names must be non-empty strings, got {a!r}")
        if "," in a:
            raise ModelError(f"action name {a!r} must not contain a comma")
    seen = set()
    for a in actions:
        if a in seen:
            raise ModelError(f"action name {a!r} is used twice")
        seen.add(a)
    lowered = [a.upper() for a in actions]
    if len(set(lowered)) != len(lowered):
        raise ModelError(f"action names must differ ignoring case (command-line sequences are "
                         f"case-insensitive): {list(actions)}")
    return actions


def _checked_matrices(actions, matrices, tol: float) -> tuple[sp.csr_matrix, ...]:
    """One read-only, row-stochastic (within ``tol``) CSR matrix per action, all of one size."""
    if sp.issparse(matrices) or (isinstance(matrices, np.ndarray) and matrices.ndim == 2):
        raise ModelError("matrices must be a sequence of one matrix per action")
    matrices = list(matrices)
    if len(matrices) != len(actions):
        raise ModelError(f"{len(actions)} actions but {len(matrices)} matrices")
    mats = []
    n = first = None
    for name, mat in zip(actions, matrices):
        m = _as_csr(mat, name)
        if n is None:
            n, first = m.shape[0], name
            if n == 0:
                raise ModelError(f"{_fmt_action(name)}: matrix has no states (0 x 0)")
        elif m.shape[0] != n:
            raise ModelError(f"{_fmt_action(name)}: matrix is {m.shape[0]} x {m.shape[1]} but "
                             f"{_fmt_action(first)} has {n} states")
        sums = np.asarray(m.sum(axis=1)).ravel()
        dev = np.abs(sums - 1.0)
        if dev.size and dev.max() > tol:
            row = int(np.argmax(dev))
            nbad = int(np.count_nonzero(dev > tol))
            more = f" ({nbad} rows out of tolerance)" if nbad > 1 else ""
            raise ModelError(f"{_fmt_action(name)}: row {row} sums to {float(sums[row])!r}, off by "
                             f"{beyond(float(sums[row]) - 1.0, tol)}, more than the tolerance {tol:g}{more}")
        for arr in (m.data, m.indices, m.indptr):
            arr.flags.writeable = False
        mats.append(m)
    return tuple(mats)


def _checked_partition(partition, n_cells, n: int) -> tuple[np.ndarray | None, int | None]:
    """The partition as a read-only int64 vector of cells in ``[0, n_cells)``, and ``n_cells``."""
    if partition is None:
        if n_cells is not None:
            raise ModelError("n_cells given without a partition")
        return None, None
    try:
        part = np.array(partition).ravel()
    except (TypeError, ValueError):
        raise ModelError("partition must be an integer vector") from None
    if part.shape != (n,):
        raise ModelError(f"partition has {part.size} entries, the model has {n} states")
    if part.dtype.kind == "f":
        if not np.all(np.isfinite(part)) or np.any(part != np.round(part)):
            raise ModelError("partition entries must be integers")
    elif part.dtype.kind not in "iu":
        raise ModelError(f"partition entries must be integers, got dtype {part.dtype}")
    part = part.astype(np.int64)
    if np.any(part < 0):
        i = int(np.argmin(part))
        raise ModelError(f"partition maps state {i} to cell {int(part[i])} < 0")
    if n_cells is None:
        n_cells = int(part.max()) + 1
    try:
        n_cells_int = int(n_cells)
    except (TypeError, ValueError):
        raise ModelError(f"n_cells must be an integer, got {n_cells!r}") from None
    if n_cells_int != n_cells or n_cells_int < 1:
        raise ModelError(f"n_cells must be a positive integer, got {n_cells!r}")
    if part.max() >= n_cells_int:
        i = int(np.argmax(part))
        raise ModelError(f"partition maps state {i} to cell {int(part[i])}, out of range "
                         f"[0, {n_cells_int})")
    part.flags.writeable = False
    return part, n_cells_int


def _check_file_dtypes(path, what, **arrays):
    """A model file's arrays must have the kinds the format says: probabilities real floating point,
    indices and the partition integers (a complex or fractional entry is refused, never cast)."""
    for name, arr in arrays.items():
        integral = name in ("indices", "indptr", "partition")
        ok = np.issubdtype(arr.dtype, np.integer) if integral else np.issubdtype(arr.dtype, np.floating)
        if not ok:
            kind = "integers" if integral else "real floating-point numbers"
            raise ModelError(f"{path}: {name} of {what} must be {kind}, found dtype {arr.dtype}")


class TransitionModel:
    """Per-action row-stochastic transition matrices over ``n`` states, validated.

    Parameters
    ----------
    actions : sequence of str
        Action names, unique and non-empty (tray models use ``N, NE, E, SE, S, SW, W, NW``).
    matrices : sequence of array_like or scipy.sparse matrices
        One ``n x n`` row-stochastic matrix per action, same order as ``actions``. Stored as
        float64 CSR with sorted indices, duplicates summed and explicit zeros removed.
    initial : array_like, optional
        Initial probability vector (default uniform over all states).
    partition : array_like of int, optional
        ``partition[i]`` = report cell of state ``i``, in ``[0, n_cells)``.
    n_cells : int, optional
        Number of report cells (default ``partition.max() + 1``); requires ``partition``.
    metadata : dict, optional
        JSON-serialisable free-form data (scene, grids, build statistics...). Numpy scalars
        and arrays are converted to plain JSON values.
    extras : dict of str to array_like, optional
        Named numeric arrays that travel with the model (a built model keeps its sample counts,
        fault counts and state poses here, see ``docs/builder.md``). Stored read-only and saved
        in the ``.npz`` beside the matrices; not used by the engine.
    tol : float
        Tolerance on row sums and on the total mass of ``initial`` (deeptime style), default 1e-9.

    Raises
    ------
    ModelError
        If anything is invalid; the message names the action, the row and the deviation.

    Examples
    --------
    >>> m = TransitionModel(["a", "b"], [[[0, 1], [0, 1]], [[0, 1], [1, 0]]])
    >>> m.n_states, m.n_actions, m.is_deterministic()
    (2, 2, True)
    >>> m.deterministic_table().tolist()
    [[1, 1], [1, 0]]
    """

    def __init__(self, actions, matrices, initial=None, partition=None, n_cells=None, metadata=None,
                 tol: float = 1e-9, extras=None):
        self.tol = tol = _checked_tol(tol)
        self.actions: tuple[str, ...] = _checked_action_names(actions)
        self.matrices: tuple[sp.csr_matrix, ...] = _checked_matrices(self.actions, matrices, tol)
        n = self.matrices[0].shape[0]
        init = np.full(n, 1.0 / n) if initial is None else distribution(initial, n, tol)
        init.flags.writeable = False
        self.initial: np.ndarray = init
        self.partition, self.n_cells = _checked_partition(partition, n_cells, n)
        self.metadata: dict = _normalise_metadata(metadata)
        self.extras: dict = _normalise_extras(extras)
        self._cache: dict = {}

    # ------------------------------------------------------------------ basic properties
    @property
    def n_states(self) -> int:
        """Number of states ``n``."""
        return self.matrices[0].shape[0]

    @property
    def n_actions(self) -> int:
        """Number of actions."""
        return len(self.actions)

    def __repr__(self) -> str:
        cells = f", n_cells={self.n_cells}" if self.partition is not None else ""
        nnz = sum(m.nnz for m in self.matrices)
        return (f"TransitionModel(n_states={self.n_states}, actions={list(self.actions)}, "
                f"nnz={nnz}{cells})")

    def action_index(self, name: str) -> int:
        """Index of action ``name`` (case-insensitive); :class:`ModelError` if unknown."""
        return action_position(self.actions, name)

    def memo(self, key, compute):
        """Data derived from this (immutable) model, computed once: the value kept under ``key``,
        or ``compute()`` kept and returned. Engines use it for packed and gathered layouts."""
        if key not in self._cache:
            self._cache[key] = compute()
        return self._cache[key]

    def is_deterministic(self) -> bool:
        """True if every row of every matrix is a single entry (equal to 1 within ``tol``)."""
        if "det" not in self._cache:
            self._cache["det"] = all(bool(np.all(np.diff(m.indptr) == 1)) for m in self.matrices)
        return self._cache["det"]

    def deterministic_table(self) -> np.ndarray:
        """The next-state table ``T[a, i]`` (int32, shape ``(n_actions, n_states)``).

        Raises :class:`ModelError` if some row is not a point mass.
        """
        if not self.is_deterministic():
            for name, m in zip(self.actions, self.matrices):
                counts = np.diff(m.indptr)
                if np.any(counts != 1):
                    row = int(np.flatnonzero(counts != 1)[0])
                    raise ModelError(f"model is not deterministic: {_fmt_action(name)} row {row} has "
                                     f"{int(counts[row])} non-zero entries")
        if "table" not in self._cache:
            table = np.stack([m.indices for m in self.matrices]).astype(np.int32)
            table.flags.writeable = False
            self._cache["table"] = table
        return self._cache["table"]

    def packed(self):
        """All matrices as three flat arrays for the Numba kernels.

        Returns ``(indptr, indices, data)`` with ``indptr`` int64 of shape ``(n_actions, n + 1)``
        holding offsets into the concatenated ``indices`` (int32) and ``data`` (float64).
        """
        if "packed" not in self._cache:
            n, k = self.n_states, self.n_actions
            indptr = np.empty((k, n + 1), dtype=np.int64)
            offset = 0
            for a, m in enumerate(self.matrices):
                indptr[a] = m.indptr.astype(np.int64) + offset
                offset += m.nnz
            indices = np.concatenate([m.indices for m in self.matrices]).astype(np.int32)
            data = np.concatenate([m.data for m in self.matrices]).astype(np.float64)
            for arr in (indptr, indices, data):
                arr.flags.writeable = False
            self._cache["packed"] = (indptr, indices, data)
        return self._cache["packed"]

    def to_networkx(self, actions=None):
        """The model's support graph as a :class:`networkx.MultiDiGraph`, to draw and explore.

        Parameters
        ----------
        actions : sequence of str, optional
            Only these actions' edges (default every action).

        Returns
        -------
        networkx.MultiDiGraph
            Nodes ``0..n-1`` (with ``cell``, the report cell, when the model has a partition); one
            edge ``i -> j`` per action ``a`` with ``P_a[i, j] > 0``, keyed by the action name and
            carrying ``action`` and ``probability``.

        Examples
        --------
        >>> m = TransitionModel(["a", "b"], [[[0, 1], [0, 1]], [[1, 0], [0.5, 0.5]]])
        >>> g = m.to_networkx()
        >>> sorted(g.edges(keys=True))
        [(0, 0, 'b'), (0, 1, 'a'), (1, 0, 'b'), (1, 1, 'a'), (1, 1, 'b')]
        >>> g.edges[1, 0, "b"]["probability"]
        0.5
        """
        import networkx as nx

        names = list(self.actions) if actions is None else [self.actions[self.action_index(a)] for a in actions]
        g = nx.MultiDiGraph()
        for i in range(self.n_states):
            g.add_node(i, **({} if self.partition is None else {"cell": int(self.partition[i])}))
        for name in names:
            P = self.matrices[self.action_index(name)].tocoo()
            for i, j, p in zip(P.row.tolist(), P.col.tolist(), P.data.tolist()):
                if p > 0:
                    g.add_edge(i, j, key=name, action=name, probability=p)
        return g

    def same_arrays(self, other: "TransitionModel") -> bool:
        """True when ``other`` holds exactly the same model, array for array: actions, initial
        distribution, partition, every matrix entry and every extra array (NaN equal to NaN).
        Metadata (timings, settings) is not compared. For checking that a build is reproducible."""
        def equal(x, y) -> bool:
            if x is None or y is None:
                return x is None and y is None
            x, y = np.asarray(x), np.asarray(y)
            return x.shape == y.shape and np.array_equal(x, y, equal_nan=x.dtype.kind == "f" and y.dtype.kind == "f")

        return (self.actions == other.actions and self.n_states == other.n_states
                and equal(self.initial, other.initial) and equal(self.partition, other.partition)
                and all((x != y).nnz == 0 for x, y in zip(self.matrices, other.matrices))
                and self.extras.keys() == other.extras.keys()
                and all(equal(self.extras[k], other.extras[k]) for k in self.extras))

    def with_initial(self, initial) -> "TransitionModel":
        """A copy of this model with another initial distribution."""
        return TransitionModel(self.actions, self.matrices, initial=initial, partition=self.partition,
                               n_cells=self.n_cells, metadata=self.metadata, tol=self.tol, extras=self.extras)

    # ------------------------------------------------------------------ files
    def save(self, path) -> str:
        """Write the model to one ``.npz`` file, atomically (temporary file + ``os.replace``).

        Arrays are stored uncompressed; the header (format marker, action names, metadata, tol) is
        a JSON string inside the archive. Returns the path written.
        """
        path = os.fspath(path)
        header = {
            "format": FORMAT_NAME, "version": FORMAT_VERSION, "actions": list(self.actions),
            "n_states": self.n_states, "n_cells": self.n_cells, "tol": self.tol,
            "metadata": self.metadata,
        }
        arrays = {"header": np.frombuffer(json.dumps(header).encode("utf-8"), dtype=np.uint8),
                  "initial": np.asarray(self.initial)}
        for a, m in enumerate(self.matrices):
            arrays[f"indptr_{a}"] = np.asarray(m.indptr)
            arrays[f"indices_{a}"] = np.asarray(m.indices)
            arrays[f"data_{a}"] = np.asarray(m.data)
        if self.partition is not None:
            arrays["partition"] = np.asarray(self.partition)
        for key, value in self.extras.items():
            arrays[_EXTRA_PREFIX + key] = np.asarray(value)
        return atomic_savez(path, arrays)

    @classmethod
    def load(cls, path, tol: float | None = None) -> "TransitionModel":
        """Read a model written by :meth:`save`; validated again on load.

        Raises :class:`ModelError` for a missing, corrupt or foreign file.
        """
        path = os.fspath(path)
        if not os.path.exists(path):
            raise ModelError(f"model file not found: {path}")
        if os.path.isdir(path):
            raise ModelError(f"model path is a directory, not a .npz file: {path}")
        try:
            loaded = np.load(path, allow_pickle=False)
            if not hasattr(loaded, "files"):
                raise ModelError(f"{path} is not a kruskal model (a .npy array, not a .npz archive)")
            with loaded as npz:
                if "header" not in npz.files:
                    raise ModelError(f"{path} is not a kruskal model (no header in the .npz archive)")
                try:
                    header = json.loads(npz["header"].tobytes().decode("utf-8"))
                except (UnicodeDecodeError, json.JSONDecodeError):
                    raise ModelError(f"{path} is not a kruskal model (unreadable header)") from None
                if not isinstance(header, dict) or header.get("format") != FORMAT_NAME:
                    raise ModelError(f"{path} is not a kruskal model (foreign .npz file)")
                if header.get("version") != FORMAT_VERSION:
                    raise ModelError(f"{path}: unsupported model format version {header.get('version')!r} "
                                     f"(this program reads version {FORMAT_VERSION})")
                actions = header["actions"]
                n = int(header["n_states"])
                mats = []
                for a in range(len(actions)):
                    data = npz[f"data_{a}"]
                    indices = npz[f"indices_{a}"]
                    indptr = npz[f"indptr_{a}"]
                    _check_file_dtypes(path, f"action {actions[a]!r}", data=data, indices=indices, indptr=indptr)
                    if indptr.shape != (n + 1,) or indptr[0] != 0 or indptr[-1] != data.size \
                            or indices.size != data.size or np.any(np.diff(indptr) < 0) \
                            or (indices.size and (indices.min() < 0 or indices.max() >= n)):
                        raise ModelError(f"{path}: corrupt sparse arrays for action {actions[a]!r}")
                    mats.append(sp.csr_matrix((data, indices, indptr), shape=(n, n)))
                initial = npz["initial"]
                partition = npz["partition"] if "partition" in npz.files else None
                _check_file_dtypes(path, "the model", initial=initial,
                                   **({} if partition is None else {"partition": partition}))
                extras = {f[len(_EXTRA_PREFIX):]: npz[f] for f in npz.files if f.startswith(_EXTRA_PREFIX)}
                return cls(actions, mats, initial=initial, partition=partition,
                           n_cells=header.get("n_cells") if partition is not None else None,
                           metadata=header.get("metadata") or {}, extras=extras,
                           tol=_file_tolerance(header) if tol is None else tol)
        except ModelError as exc:
            if str(exc).startswith(path):
                raise
            raise ModelError(f"{path}: invalid model: {exc}") from None
        except RecursionError:
            raise ModelError(f"{path}: invalid model: its header is nested too deeply") from None
        except (zipfile.BadZipFile, EOFError, KeyError, ValueError, TypeError, OSError, AttributeError,
                io.UnsupportedOperation) as exc:
            raise ModelError(f"{path} is not a readable kruskal model ({type(exc).__name__}: "
                             f"{str(exc).splitlines()[0] if str(exc) else 'corrupt file'})") from None

