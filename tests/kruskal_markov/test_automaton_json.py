"""Tests of kruskal_markov.automaton_json: the docs/commands.md automaton JSON format."""
from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.sparse as sp

from kruskal_markov.automaton_json import automaton_from_model, model_from_automaton
from kruskal_markov.model import ModelError, TransitionModel


def test_deterministic_from_dict_and_file(tmp_path):
    doc = {"states": 3, "actions": {"a": [1, 2, 0], "b": [0, 0, 2]}}
    path = tmp_path / "aut.json"
    path.write_text(json.dumps(doc))
    for source in (doc, path, str(path), json.dumps(doc)):
        m = model_from_automaton(source)
        assert m.actions == ("a", "b")
        assert m.is_deterministic()
        np.testing.assert_array_equal(m.deterministic_table(), [[1, 2, 0], [0, 0, 2]])
        np.testing.assert_array_equal(m.initial, np.full(3, 1 / 3))


def test_stochastic_sums_duplicates_and_reads_initial():
    doc = {"states": 2, "actions": {
        "a": {"rows": [0, 0, 0, 1], "cols": [0, 1, 1, 1], "probs": [0.5, 0.25, 0.25, 1.0]},
        "b": [1, 0]}, "initial": [0.25, 0.75]}
    m = model_from_automaton(doc)
    np.testing.assert_array_equal(m.matrices[0].toarray(), [[0.5, 0.5], [0, 1]])
    np.testing.assert_array_equal(m.matrices[1].toarray(), [[0, 1], [1, 0]])
    np.testing.assert_array_equal(m.initial, [0.25, 0.75])
    assert not m.is_deterministic()


@pytest.mark.parametrize("seed", range(5))
def test_round_trip_stochastic(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 8))
    mats = []
    for _ in range(int(rng.integers(1, 4))):
        a = rng.random((n, n)) * (rng.random((n, n)) < 0.4)
        a[np.arange(n), rng.integers(0, n, n)] += 0.3
        mats.append(sp.csr_matrix(a / a.sum(axis=1, keepdims=True)))
    init = rng.random(n)
    init /= init.sum()
    part = rng.integers(0, 3, n)
    m = TransitionModel([f"x{i}" for i in range(len(mats))], mats, initial=init, partition=part,
                        n_cells=3, metadata={"k": 1})
    doc = json.loads(json.dumps(automaton_from_model(m)))
    back = model_from_automaton(doc)
    assert back.actions == m.actions
    for a, b in zip(back.matrices, m.matrices):
        np.testing.assert_array_equal(a.toarray(), b.toarray())
    np.testing.assert_array_equal(back.initial, m.initial)
    np.testing.assert_array_equal(back.partition, m.partition)
    assert back.n_cells == 3 and back.metadata == {"k": 1}


def test_round_trip_deterministic_uses_lists():
    m = TransitionModel(["a", "b"], [np.eye(4)[[1, 2, 3, 0]], np.eye(4)[[0, 0, 2, 3]]])
    doc = automaton_from_model(m)
    assert doc == {"states": 4, "actions": {"a": [1, 2, 3, 0], "b": [0, 0, 2, 3]}}
    back = model_from_automaton(doc)
    np.testing.assert_array_equal(back.deterministic_table(), m.deterministic_table())


@pytest.mark.parametrize("doc, pattern", [
    ({"actions": {"a": [0]}}, "'states' must be a positive integer"),
    ({"states": 0, "actions": {"a": []}}, "'states' must be a positive integer"),
    ({"states": True, "actions": {"a": [0]}}, "'states' must be a positive integer"),
    ({"states": 2}, "'actions' must be a non-empty object"),
    ({"states": 2, "actions": {}}, "'actions' must be a non-empty object"),
    ({"states": 2, "actions": {"a": [0]}}, "action 'a': next-state list has 1 entries, expected 2"),
    ({"states": 2, "actions": {"a": [0, 2]}}, "action 'a': state 1 goes to 2, out of range"),
    ({"states": 2, "actions": {"a": [0, -1]}}, "state 1 goes to -1"),
    ({"states": 2, "actions": {"a": [0, 0.5]}}, "integers only"),
    ({"states": 2, "actions": {"a": [0, "1"]}}, "integers only"),
    ({"states": 2, "actions": {"a": 3}}, "expected a next-state list"),
    ({"states": 2, "actions": {"a": {"rows": [0], "cols": [0]}}}, "missing \\['probs'\\]"),
    ({"states": 2, "actions": {"a": {"rows": [0, 1], "cols": [0], "probs": [1, 1]}}}, "different lengths"),
    ({"states": 2, "actions": {"a": {"rows": [0, 5], "cols": [0, 1], "probs": [1, 1]}}}, "row index 5 out of range"),
    ({"states": 2, "actions": {"a": {"rows": [0, 1], "cols": [0, 7], "probs": [1, 1]}}}, "column index 7"),
    ({"states": 2, "actions": {"a": {"rows": [0, 1], "cols": [0, 1], "probs": [1, 0.5]}}},
     r"action 'a': row 1 sums to 0\.5"),
    ({"states": 2, "actions": {"a": {"rows": [0, 1], "cols": [0, 1], "probs": [1, "x"]}}}, "list of numbers"),
    ({"states": 2, "actions": {"a": {"rows": [0, 1, 1], "cols": [0, 0, 1], "probs": [1, 1.5, -0.5]}}},
     "negative entry"),
    ({"states": 2, "actions": {"a": [0, 1]}, "initial": [0.5, 0.4]}, "initial distribution sums to 0.9"),
    ({"states": 2, "actions": {"a": [0, 1]}, "initial": "uniform"}, "'initial' must be a list"),
    ({"states": 2, "actions": {"a": [0, 1]}, "bogus": 1}, "unknown key"),
])
def test_rejects_bad_automata(doc, pattern):
    with pytest.raises(ModelError, match=pattern):
        model_from_automaton(doc)


def test_bad_files(tmp_path):
    with pytest.raises(ModelError, match="not found"):
        model_from_automaton(tmp_path / "nope.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ModelError, match="bad.json: not valid JSON"):
        model_from_automaton(bad)
    arr = tmp_path / "arr.json"
    arr.write_text("[1, 2]")
    with pytest.raises(ModelError, match="expected a JSON object"):
        model_from_automaton(arr)
    with pytest.raises(ModelError, match="must be a path"):
        model_from_automaton(42)


def test_tolerance_is_1e9():
    ok = {"states": 1, "actions": {"a": {"rows": [0], "cols": [0], "probs": [1 + 5e-10]}}}
    model_from_automaton(ok)
    bad = {"states": 1, "actions": {"a": {"rows": [0], "cols": [0], "probs": [1 + 5e-9]}}}
    with pytest.raises(ModelError, match="sums to"):
        model_from_automaton(bad)


@pytest.mark.parametrize("doc, message", [
    ({"states": 2, "actions": {"a": {"rows": [0, "x"], "cols": [0, 1], "probs": [1, 1]}}},
     "automaton: action 'a': 'rows' must contain integers only, found 'x' at position 1"),
    ({"states": 2, "actions": {"a": [0, 1]}, "partition": [0, "q"]},
     "automaton: 'partition' must contain integers only, found 'q' at position 1"),
    ({"states": 2, "actions": {"a": [0, 1]}, "initial": [True, 0]}, "automaton: 'initial' must be a list of 2 numbers"),
    ({"states": 2, "actions": {"a": [0, 2 ** 63]}},
     "automaton: action 'a': next-state list has an entry 9223372036854775808 beyond any state index"),
    ({"states": 2, "actions": {"a": [0, -2 ** 63]}},
     "automaton: action 'a': state 1 goes to -9223372036854775808, out of range [0, 2)"),
    ({"states": 2, "actions": {"a": [0, "z"]}},
     "automaton: action 'a': next-state list must contain integers only, found 'z' at position 1"),
])
def test_bad_automata_are_named_exactly(doc, message):
    """Each message names the document, the action, the field and the entry (the whole line)."""
    import re

    from kruskal_markov.model import ModelError
    with pytest.raises(ModelError, match="^" + re.escape(message) + "$"):
        model_from_automaton(doc)


def test_memory_is_checked_before_building(monkeypatch):
    """8 bytes x (3 per action + 4) per state: 2 states, 1 action = 112 bytes, refused one byte short."""
    import kruskal_markov.limits as limits
    from kruskal_markov.model import ModelError

    doc = {"states": 2, "actions": {"a": [0, 1]}}
    monkeypatch.setattr(limits, "available_memory_bytes", lambda: 112 / limits.MEMORY_SHARE)
    model_from_automaton(doc)
    monkeypatch.setattr(limits, "available_memory_bytes", lambda: 111 / limits.MEMORY_SHARE)
    with pytest.raises(ModelError, match="^automaton: an automaton of 2 states needs "):
        model_from_automaton(doc)


# ----------------------------------------------------------------------------- whole messages and boundaries
def _error(source, **kw):
    with pytest.raises(ModelError) as info:
        model_from_automaton(source, **kw)
    return str(info.value)


def test_json_text_is_recognised_after_leading_whitespace_and_labelled_automaton():
    doc = {"states": 2, "actions": {"a": [1, 1]}}
    m = model_from_automaton("  \n\t" + json.dumps(doc))
    np.testing.assert_array_equal(m.deterministic_table(), [[1, 1]])
    assert _error('{"states": 0, "actions": {"a": []}}') == \
        "automaton: 'states' must be a positive integer, got 0"


def test_file_errors_are_named_exactly(tmp_path):
    latin = tmp_path / "latin.json"
    latin.write_bytes(b'{"states": 1, "actions": {"\xe9": [0]}}')          # not UTF-8
    assert _error(latin).startswith(f"cannot read automaton file {latin}: 'utf-8' codec can't decode byte 0xe9")
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 200_000 + "]" * 200_000)
    assert _error(deep) == f"automaton {deep}: JSON nested too deeply"
    assert _error(42) == "automaton must be a path, a JSON string or a dict, got int"
    assert _error(b"{}") == "automaton must be a path, a JSON string or a dict, got bytes"


def test_utf8_action_names_read_from_a_file(tmp_path):
    path = tmp_path / "names.json"
    path.write_bytes(json.dumps({"states": 1, "actions": {"Ω": [0]}}, ensure_ascii=False).encode("utf-8"))
    assert model_from_automaton(path).actions == ("Ω",)


@pytest.mark.parametrize("doc, message", [
    ({"states": 2, "actions": {"a": {"rows": 5, "cols": [0], "probs": [1]}}},
     "automaton: action 'a': 'rows' must be a list of integers"),
    ({"states": 2, "actions": {"a": [0, 1]}, "partition": [0, float("nan")]},
     "automaton: 'partition' has a non-finite entry nan at position 1"),
    ({"states": 2, "actions": {"a": {"rows": [0, 1], "cols": [0, "x"], "probs": [1, 1]}}},
     "automaton: action 'a': 'cols' must contain integers only, found 'x' at position 1"),
    ({"states": 2, "actions": {"a": {"rows": [0, 2], "cols": [0, 1], "probs": [1, 1]}}},
     "automaton: action 'a': row index 2 out of range [0, 2)"),
    ({"states": 2, "actions": {"a": {"rows": [0, 1], "cols": [0, 2], "probs": [1, 1]}}},
     "automaton: action 'a': column index 2 out of range [0, 2)"),
    ({"states": 1, "actions": {"a": {"rows": [], "cols": [], "probs": []}}},
     "automaton: action 'a': row 0 sums to 0.0, off by -1, more than the tolerance 1e-09"),
    ({"states": 2, "actions": {"a": [-200, 2 ** 63]}},
     "automaton: action 'a': next-state list has an entry 9223372036854775808 beyond any state index"),
    ({"states": 2, "actions": {"a": [200, 2 ** 63]}},
     "automaton: action 'a': next-state list has an entry 9223372036854775808 beyond any state index"),
    ({"states": 2, "actions": {"a": [-2 ** 63, 2 ** 63]}},
     "automaton: action 'a': next-state list has an entry 9223372036854775808 beyond any state index"),
    ({"states": 2, "actions": {"a": [0, -2 ** 63 - 1]}},
     "automaton: action 'a': next-state list has an entry -9223372036854775809 beyond any state index"),
])
def test_more_bad_automata_are_named_exactly(doc, message):
    assert _error(doc) == message


def test_integral_floats_are_integers_and_unused_last_states_keep_the_shape():
    """1.0 is an integer in JSON's sense; a last state no transition enters still has its row and column."""
    m = model_from_automaton({"states": 3, "actions": {"a": [0, 1.0, 0],
                                                       "b": {"rows": [0, 1, 2], "cols": [0, 0, 1], "probs": [1, 1, 1]}}})
    assert m.n_states == 3 and all(x.shape == (3, 3) for x in m.matrices)
    np.testing.assert_array_equal(m.deterministic_table(), [[0, 1, 0], [0, 0, 1]])


def test_tolerance_is_passed_through():
    doc = {"states": 1, "actions": {"a": {"rows": [0], "cols": [0], "probs": [1.0005]}}}
    assert model_from_automaton(doc, tol=1e-3).n_states == 1
    assert _error(doc) == "automaton: action 'a': row 0 sums to 1.0005, off by +0.0005, more than the tolerance 1e-09"
    tight = {"states": 1, "actions": {"a": {"rows": [0], "cols": [0], "probs": [1 + 5e-10]}}}
    assert _error(tight, tol=1e-12).startswith("automaton: action 'a': row 0 sums to 1")


def test_memory_refusal_names_the_option(monkeypatch):
    import kruskal_markov.limits as limits

    monkeypatch.setattr(limits, "available_memory_bytes", lambda: 100)
    assert _error({"states": 2, "actions": {"a": [0, 1]}}) == (
        "automaton: an automaton of 2 states needs 112 B of memory, more than this machine has available "
        "(100 B); is 'states' right?")


def test_written_json_uses_integers_for_indices():
    m = TransitionModel(["a", "b"], [np.array([[0.5, 0.5], [0.0, 1.0]]), np.eye(2)], partition=[1, 0], n_cells=2)
    doc = automaton_from_model(m)
    for key in ("rows", "cols"):
        assert all(type(v) is int for v in doc["actions"]["a"][key])
    assert all(type(v) is int for v in doc["partition"]) and doc["cells"] == 2
    assert json.dumps(doc["actions"]["a"]) == '{"rows": [0, 0, 1], "cols": [0, 1, 1], "probs": [0.5, 0.5, 1.0]}'


def test_files_are_read_as_utf8_whatever_the_locale(tmp_path, monkeypatch):
    """The file is decoded as UTF-8 even where the locale's default encoding is not (Windows' cp1252):
    ``open`` is replaced by one whose default is Latin-1, as on such a machine."""
    import builtins

    import kruskal_markov.automaton_json as automaton

    def latin_default_open(file, mode="r", buffering=-1, encoding=None, **kw):
        if "b" not in mode and encoding is None:
            encoding = "latin-1"
        return builtins.open(file, mode, buffering, encoding, **kw)

    monkeypatch.setattr(automaton, "open", latin_default_open, raising=False)
    path = tmp_path / "names.json"
    path.write_bytes(json.dumps({"states": 1, "actions": {"Ωé": [0]}}, ensure_ascii=False).encode("utf-8"))
    assert model_from_automaton(path).actions == ("Ωé",)


def test_probabilities_beyond_int64_are_a_row_sum_error():
    """2**70 as a JSON integer is read as the float 2**70 (not an object array scipy refuses)."""
    doc = {"states": 1, "actions": {"a": {"rows": [0], "cols": [0], "probs": [2 ** 70]}}}
    assert _error(doc).startswith(f"automaton: action 'a': row 0 sums to {float(2 ** 70)}, off by +")


def test_an_empty_integer_list_is_an_empty_int64_array():
    from kruskal_markov.automaton_json import _int_list

    for values in ([], [3]):
        out = _int_list(values, "'rows'", "automaton")
        assert out.dtype == np.int64 and out.tolist() == values
