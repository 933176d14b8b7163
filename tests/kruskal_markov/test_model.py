"""Tests of kruskal_markov.model: validation, save/load, deterministic tables."""
from __future__ import annotations

import json
import os
import zipfile

import numpy as np
import pytest
import scipy.sparse as sp

from kruskal_markov.generators import random_stochastic_matrix
from kruskal_markov.model import ModelError, TransitionModel


def random_stochastic(rng, n, density=0.3, dense=False):
    """A random row-stochastic matrix with at least one non-zero per row (the shared generator)."""
    return random_stochastic_matrix(n, density, rng, dense)


@pytest.fixture
def small_model():
    rng = np.random.default_rng(1)
    mats = [random_stochastic(rng, 6) for _ in range(3)]
    init = rng.random(6)
    init /= init.sum()
    return TransitionModel(["a", "b", "c"], mats, initial=init, partition=[0, 0, 1, 1, 2, 2],
                           metadata={"scene": {"shape": "x"}, "counts": np.arange(3)})


@pytest.mark.parametrize("dense", [False, True])
def test_constructs_canonical_csr(dense):
    rng = np.random.default_rng(0)
    mats = [random_stochastic(rng, 5, dense=dense) for _ in range(2)]
    m = TransitionModel(["x", "y"], mats)
    assert m.n_states == 5 and m.n_actions == 2
    for given, stored in zip(mats, m.matrices):
        assert sp.isspmatrix_csr(stored) and stored.dtype == np.float64
        assert stored.has_sorted_indices
        assert np.all(stored.data != 0)
        np.testing.assert_array_equal(stored.toarray(), given.toarray() if sp.issparse(given) else given)
    np.testing.assert_allclose(m.initial, np.full(5, 0.2), rtol=0, atol=0)
    assert m.partition is None and m.n_cells is None


def test_explicit_zeros_and_duplicates_are_canonicalised():
    data = np.array([0.5, 0.0, 0.25, 0.25, 1.0])
    rows = np.array([0, 0, 0, 0, 1])
    cols = np.array([1, 0, 1, 0, 1])
    m = TransitionModel(["a"], [sp.coo_matrix((data, (rows, cols)), shape=(2, 2))])
    P = m.matrices[0]
    assert P.nnz == 3
    np.testing.assert_array_equal(P.toarray(), [[0.25, 0.75], [0, 1]])


def test_deterministic_table():
    m = TransitionModel(["a", "b"], [np.eye(3)[[1, 2, 0]], np.eye(3)[[0, 0, 2]]])
    assert m.is_deterministic()
    t = m.deterministic_table()
    assert t.dtype == np.int32 and t.shape == (2, 3)
    np.testing.assert_array_equal(t, [[1, 2, 0], [0, 0, 2]])


def test_not_deterministic_table_raises(small_model):
    assert not small_model.is_deterministic()
    with pytest.raises(ModelError, match="not deterministic.*row"):
        small_model.deterministic_table()


def test_partition_and_metadata(small_model):
    assert small_model.n_cells == 3
    assert small_model.partition.dtype == np.int64
    assert small_model.metadata["counts"] == [0, 1, 2]
    json.dumps(small_model.metadata)


def test_arrays_are_read_only(small_model):
    with pytest.raises(ValueError):
        small_model.initial[0] = 1.0
    with pytest.raises(ValueError):
        small_model.matrices[0].data[0] = 1.0


def test_packed_matches_matrices(small_model):
    indptr, indices, data = small_model.packed()
    for a, m in enumerate(small_model.matrices):
        for i in range(small_model.n_states):
            lo, hi = indptr[a, i], indptr[a, i + 1]
            np.testing.assert_array_equal(indices[lo:hi], m.indices[m.indptr[i]:m.indptr[i + 1]])
            np.testing.assert_array_equal(data[lo:hi], m.data[m.indptr[i]:m.indptr[i + 1]])


# ---------------------------------------------------------------------------- validation
def _p(n=3):
    return np.eye(n)


@pytest.mark.parametrize("kwargs, pattern", [
    (dict(actions=[], matrices=[]), "at least one action"),
    (dict(actions="ab", matrices=[_p(), _p()]), "not a single string"),
    (dict(actions=["a", "a"], matrices=[_p(), _p()]), "'a' is used twice"),
    (dict(actions=["a", "A"], matrices=[_p(), _p()]), "ignoring case"),
    (dict(actions=["", "b"], matrices=[_p(), _p()]), "non-empty strings"),
    (dict(actions=["a,b"], matrices=[_p()]), "comma"),
    (dict(actions=["a", "b"], matrices=[_p()]), "2 actions but 1 matrices"),
    (dict(actions=["a"], matrices=[np.ones((2, 3)) / 3]), "action 'a'.*2 x 3, not square"),
    (dict(actions=["a", "b"], matrices=[_p(3), _p(4)]), "action 'b'.*4 x 4.*action 'a' has 3 states"),
    (dict(actions=["a"], matrices=[np.array([[1.5, -0.5], [0, 1]])]), "action 'a'.*row 0.*negative entry -0.5"),
    (dict(actions=["a"], matrices=[np.array([[np.nan, 1], [0, 1]])]), "action 'a'.*row 0.*non-finite"),
    (dict(actions=["a"], matrices=[np.array([[np.inf, 0], [0, 1]])]), "non-finite"),
    (dict(actions=["a", "b"], matrices=[_p(2), np.array([[1, 0], [0.5, 0.4]])]),
     r"action 'b': row 1 sums to 0\.9, off by -0\.1"),
    (dict(actions=["a"], matrices=[np.array([[1, 0], [0, 1 + 1e-6]])]), r"row 1 sums to 1\.000001.*\+1e-06"),
    (dict(actions=["a"], matrices=[np.zeros((0, 0))]), "no states"),
    (dict(actions=["a"], matrices=[np.ones((2, 2, 2))]), "2-dimensional"),
    (dict(actions=["a"], matrices=[np.array([["x", "y"], ["x", "y"]])]), "numeric"),
    (dict(actions=["a"], matrices=[_p(2)], initial=[0.5, 0.6]), r"initial distribution sums to 1\.1"),
    (dict(actions=["a"], matrices=[_p(2)], initial=[1.5, -0.5]), "initial.*negative entry -0.5 at state 1"),
    (dict(actions=["a"], matrices=[_p(2)], initial=[1.0]), "initial distribution has 1 entries.*2 states"),
    (dict(actions=["a"], matrices=[_p(2)], initial=[np.nan, 1]), "initial.*non-finite"),
    (dict(actions=["a"], matrices=[_p(2)], partition=[0, 2], n_cells=2), "state 1 to cell 2, out of range"),
    (dict(actions=["a"], matrices=[_p(2)], partition=[0, -1]), "cell -1"),
    (dict(actions=["a"], matrices=[_p(2)], partition=[0]), "partition has 1 entries"),
    (dict(actions=["a"], matrices=[_p(2)], partition=[0, 0.5]), "integers"),
    (dict(actions=["a"], matrices=[_p(2)], n_cells=2), "n_cells given without a partition"),
    (dict(actions=["a"], matrices=[_p(2)], partition=[0, 1], n_cells=0), "positive integer"),
    (dict(actions=["a"], matrices=[_p(2)], metadata={"x": object()}), "not JSON-serialisable"),
    (dict(actions=["a"], matrices=[_p(2)], metadata=[1]), "metadata must be a dict"),
    (dict(actions=["a"], matrices=[_p(2)], tol=-1), "tol must be"),
])
def test_rejects_bad_models(kwargs, pattern):
    with pytest.raises(ModelError, match=pattern):
        TransitionModel(**kwargs)


def test_tolerance_parameter_is_used():
    off = np.array([[1, 0], [0, 1 + 1e-7]])
    with pytest.raises(ModelError):
        TransitionModel(["a"], [off])
    m = TransitionModel(["a"], [off], tol=1e-6)
    assert m.tol == 1e-6


def test_model_error_is_value_error():
    assert issubclass(ModelError, ValueError)


def test_action_index():
    m = TransitionModel(["N", "NE"], [_p(2), _p(2)])
    assert m.action_index("NE") == 1 and m.action_index("ne") == 1
    with pytest.raises(ModelError, match="unknown action 'X'.*N,NE"):
        m.action_index("X")


# ---------------------------------------------------------------------------- save / load
def test_save_load_round_trip(tmp_path, small_model):
    path = tmp_path / "m.npz"
    small_model.save(path)
    back = TransitionModel.load(path)
    assert back.actions == small_model.actions
    for a, b in zip(back.matrices, small_model.matrices):
        assert (a != b).nnz == 0
        np.testing.assert_array_equal(a.indices, b.indices)
        np.testing.assert_array_equal(a.data, b.data)
    np.testing.assert_array_equal(back.initial, small_model.initial)
    np.testing.assert_array_equal(back.partition, small_model.partition)
    assert back.n_cells == small_model.n_cells and back.metadata == small_model.metadata
    assert back.tol == small_model.tol
    assert [p for p in os.listdir(tmp_path) if p.startswith(".tmp")] == []


def test_save_overwrites_atomically(tmp_path, small_model):
    path = tmp_path / "m.npz"
    path.write_bytes(b"old")
    small_model.save(path)
    assert TransitionModel.load(path).n_states == 6


def test_save_without_partition(tmp_path):
    m = TransitionModel(["a"], [_p(3)])
    m.save(tmp_path / "x.npz")
    back = TransitionModel.load(tmp_path / "x.npz")
    assert back.partition is None and back.n_cells is None


def test_load_rejects_missing_corrupt_and_foreign(tmp_path, small_model):
    with pytest.raises(ModelError, match="not found"):
        TransitionModel.load(tmp_path / "none.npz")
    with pytest.raises(ModelError, match="directory"):
        TransitionModel.load(tmp_path)
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"this is not a zip file at all")
    with pytest.raises(ModelError, match="junk.npz"):
        TransitionModel.load(junk)
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, a=np.arange(3))
    with pytest.raises(ModelError, match="not a kruskal model"):
        TransitionModel.load(foreign)
    npy = tmp_path / "arr.npy"
    np.save(npy, np.arange(3))
    with pytest.raises(ModelError, match="not a kruskal model"):
        TransitionModel.load(npy)
    good = tmp_path / "good.npz"
    small_model.save(good)
    truncated = tmp_path / "trunc.npz"
    truncated.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    with pytest.raises(ModelError, match="trunc.npz"):
        TransitionModel.load(truncated)


def _saved_arrays(model, tmp_path):
    """The arrays of ``model`` as saved (to tamper with), and the path :func:`_refused` writes to."""
    good = tmp_path / "good.npz"
    model.save(good)
    with np.load(good) as z:
        return {k: z[k] for k in z.files}, tmp_path / "bad.npz"


def _refused(bad, arrays, match):
    """``arrays`` written to ``bad`` do not load: a ModelError matching ``match``."""
    np.savez(bad, **arrays)
    with pytest.raises(ModelError, match=match):
        TransitionModel.load(bad)


def test_load_rejects_tampered_arrays(tmp_path, small_model):
    arrays, bad = _saved_arrays(small_model, tmp_path)
    arrays["data_1"] = arrays["data_1"] * 2
    _refused(bad, arrays, r"bad.npz: invalid model: action 'b': row \d+ sums to 2")
    arrays["data_1"] = arrays["data_1"] / 2
    arrays["indices_0"] = arrays["indices_0"] + 100
    _refused(bad, arrays, "corrupt sparse arrays for action 'a'")
    arrays["indices_0"] = arrays["indices_0"] - 100
    arrays["header"] = np.frombuffer(b"\xff\xfe", dtype=np.uint8)
    _refused(bad, arrays, "unreadable header")


def test_a_file_cannot_switch_off_its_own_validation(tmp_path, small_model):
    """A header asking for tolerance 10 does not make rows summing to 5 acceptable."""
    arrays, bad = _saved_arrays(small_model, tmp_path)
    header = json.loads(arrays["header"].tobytes().decode())
    header["tol"] = 10
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    arrays["data_0"] = arrays["data_0"] * 5
    _refused(bad, arrays, r"row \d+ sums to 5.*the tolerance 1e-06")
    header["tol"] = "lots"
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    _refused(bad, arrays, "header tolerance")


def test_saved_file_is_a_plain_npz_without_pickles(tmp_path, small_model):
    path = tmp_path / "m.npz"
    small_model.save(path)
    with zipfile.ZipFile(path) as z:
        names = set(z.namelist())
    assert "header.npy" in names and "data_0.npy" in names
    with np.load(path, allow_pickle=False) as z:
        header = json.loads(z["header"].tobytes())
    assert header["format"] == "kruskal.TransitionModel" and header["actions"] == ["a", "b", "c"]


def test_with_initial(small_model):
    p = np.zeros(6)
    p[2] = 1
    m2 = small_model.with_initial(p)
    np.testing.assert_array_equal(m2.initial, p)
    assert m2.matrices[0] is small_model.matrices[0] or (m2.matrices[0] != small_model.matrices[0]).nnz == 0


def test_same_arrays_compares_every_array_and_treats_nan_as_equal(tmp_path, small_model):
    """``same_arrays`` (the builder's reproducibility check): a saved and loaded copy is the same,
    NaN poses included; one changed matrix entry, initial distribution, partition or extra is not."""
    poses = np.full((6, 3), np.nan)
    poses[3:] = 1.5
    model = TransitionModel(small_model.actions, small_model.matrices, initial=small_model.initial,
                            partition=small_model.partition, extras={"state_poses": poses})
    model.save(tmp_path / "m.npz")
    assert model.same_arrays(TransitionModel.load(tmp_path / "m.npz"))
    other_matrix = [m.copy() for m in model.matrices]
    other_matrix[1] = sp.csr_matrix(random_stochastic(np.random.default_rng(9), 6, dense=True))
    other_poses = poses.copy()
    other_poses[4, 2] = 1.25
    other_init = np.roll(model.initial, 1)
    changed = [TransitionModel(model.actions, other_matrix, initial=model.initial, partition=model.partition,
                               extras=model.extras),
               model.with_initial(other_init),
               TransitionModel(model.actions, model.matrices, initial=model.initial, partition=[0, 1, 1, 1, 2, 2],
                               extras=model.extras),
               TransitionModel(model.actions, model.matrices, initial=model.initial, partition=model.partition,
                               extras={"state_poses": other_poses}),
               TransitionModel(model.actions, model.matrices, initial=model.initial, partition=model.partition)]
    assert not any(model.same_arrays(c) for c in changed)


# ----------------------------------------------------------------------------- messages and small functions, whole
def test_atomic_write_text_writes_utf8_and_leaves_no_temporary_file(tmp_path):
    from kruskal_markov.model import atomic_write_text

    path = tmp_path / "sub" / "note.txt"
    text = "caf\u00e9 \u2713\nline two\n"
    assert atomic_write_text(path, text) == os.fspath(path)
    assert path.read_bytes() == text.encode("utf-8")
    assert atomic_write_text(os.fspath(path), "again") == os.fspath(path) and path.read_text("utf-8") == "again"
    assert sorted(os.listdir(tmp_path / "sub")) == ["note.txt"]


def test_construction_messages_whole():
    ok = [[0.0, 1.0], [1.0, 0.0]]
    with pytest.raises(ModelError) as info:
        TransitionModel(["a"], sp.csr_matrix(ok))
    assert str(info.value) == "matrices must be a sequence of one matrix per action"
    with pytest.raises(ModelError) as info:
        TransitionModel(["a"], [[[0.5, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.5]]])
    assert str(info.value) == "action 'a': row 0 sums to 0.5, off by -0.5, more than the tolerance 1e-09 " \
                              "(2 rows out of tolerance)"
    with pytest.raises(ModelError) as info:
        TransitionModel(["a"], [ok], metadata={"x": object()})
    assert str(info.value) == "metadata is not JSON-serialisable: object of type object is not JSON serialisable"
    with pytest.raises(ModelError) as info:
        TransitionModel(["a"], [ok], extras={"s": np.array(["x", "y"])})
    assert str(info.value) == "extras array 's' must be numeric, got dtype <U1"


def test_integer_matrices_explicit_zeros_and_integral_float_partitions_are_accepted():
    """Dense integer (0/1) matrices are numeric; an explicitly stored zero is not negative (it is
    dropped); a float partition with integral entries is a partition."""
    m = TransitionModel(["a"], [np.array([[0, 1], [1, 0]], dtype=np.int64)], partition=np.array([0.0, 1.0]))
    np.testing.assert_array_equal(m.matrices[0].toarray(), [[0.0, 1.0], [1.0, 0.0]])
    assert m.partition.tolist() == [0, 1] and m.partition.dtype == np.int64 and m.n_cells == 2
    stored_zero = sp.csr_matrix((np.array([0.0, 1.0, 1.0]), np.array([0, 1, 0]), np.array([0, 2, 3])), shape=(2, 2))
    assert stored_zero.nnz == 3
    z = TransitionModel(["a"], [stored_zero])
    assert z.matrices[0].nnz == 2 and z.matrices[0].toarray().tolist() == [[0.0, 1.0], [1.0, 0.0]]


def test_repr_whole():
    m = TransitionModel(["a", "b"], [[[0, 1], [0, 1]], [[1, 0], [0.5, 0.5]]])
    assert repr(m) == "TransitionModel(n_states=2, actions=['a', 'b'], nnz=5)"
    p = TransitionModel(["a"], [[[0, 1], [1, 0]]], partition=[0, 0], n_cells=3)
    assert repr(p) == "TransitionModel(n_states=2, actions=['a'], nnz=2, n_cells=3)"


def test_to_networkx_edges_nodes_and_action_filter():
    pytest.importorskip("networkx")
    m = TransitionModel(["a", "b"], [[[0, 1], [0, 1]], [[1, 0], [0.5, 0.5]]], partition=[1, 0])
    g = m.to_networkx()
    assert sorted(g.nodes(data=True)) == [(0, {"cell": 1}), (1, {"cell": 0})]
    assert sorted(g.edges(keys=True, data=True)) == [
        (0, 0, "b", {"action": "b", "probability": 1.0}), (0, 1, "a", {"action": "a", "probability": 1.0}),
        (1, 0, "b", {"action": "b", "probability": 0.5}), (1, 1, "a", {"action": "a", "probability": 1.0}),
        (1, 1, "b", {"action": "b", "probability": 0.5})]
    only_b = m.to_networkx(actions=["B"])
    assert sorted(only_b.edges(keys=True)) == [(0, 0, "b"), (1, 0, "b"), (1, 1, "b")]
    plain = TransitionModel(["a"], [[[0, 1], [1, 0]]]).to_networkx()
    assert sorted(plain.nodes(data=True)) == [(0, {}), (1, {})]


def _header(arrays):
    return json.loads(arrays["header"].tobytes().decode("utf-8"))


def _refused_whole(bad, arrays, message):
    np.savez(bad, **arrays)
    with pytest.raises(ModelError) as info:
        TransitionModel.load(bad)
    assert str(info.value) == message.format(path=os.fspath(bad))


def test_load_messages_whole(tmp_path, small_model):
    """Tampered files: each refusal's whole message (version, array kinds, sparse structure, a
    file numpy cannot read)."""
    from kruskal_markov.model import FORMAT_VERSION

    arrays, bad = _saved_arrays(small_model, tmp_path)
    header = _header(arrays)
    header["version"] = 99
    tampered = dict(arrays, header=np.frombuffer(json.dumps(header).encode("utf-8"), dtype=np.uint8))
    _refused_whole(bad, tampered, "{path}: unsupported model format version 99 (this program reads version "
                                  f"{FORMAT_VERSION})")
    _refused_whole(bad, dict(arrays, indices_0=arrays["indices_0"].astype(np.float64)),
                   "{path}: indices of action 'a' must be integers, found dtype float64")
    _refused_whole(bad, dict(arrays, indptr_1=arrays["indptr_1"].astype(np.float64)),
                   "{path}: indptr of action 'b' must be integers, found dtype float64")
    _refused_whole(bad, dict(arrays, data_2=np.ones(arrays["data_2"].size, dtype=np.int64)),
                   "{path}: data of action 'c' must be real floating-point numbers, found dtype int64")
    _refused_whole(bad, dict(arrays, partition=arrays["partition"].astype(np.float64)),
                   "{path}: partition of the model must be integers, found dtype float64")
    n = small_model.n_states
    at_n = arrays["indices_0"].copy()
    at_n[0] = n                                          # one column index past the last state
    _refused_whole(bad, dict(arrays, indices_0=at_n), "{path}: corrupt sparse arrays for action 'a'")
    ptr = arrays["indptr_0"].copy()
    nnz = int(ptr[-1])
    down = np.array([0, nnz] + [1] * (n - 2) + [nnz], dtype=ptr.dtype)    # first, last and size right
    assert down.shape == ptr.shape and np.any(np.diff(down) < 0)
    _refused_whole(bad, dict(arrays, indptr_0=down), "{path}: corrupt sparse arrays for action 'a'")
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"this is not a zip file at all")
    try:
        np.load(junk, allow_pickle=False)
    except ValueError as exc:
        first = str(exc).splitlines()[0]
    assert first
    with pytest.raises(ModelError) as info:
        TransitionModel.load(junk)
    assert str(info.value) == f"{junk} is not a readable kruskal model (ValueError: {first})"
