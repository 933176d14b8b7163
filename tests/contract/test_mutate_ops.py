"""tools/mutate_ops.py: the mutation operators of our own, by the mutants they make."""
import ast
import importlib.util

import tests

_spec = importlib.util.spec_from_file_location("mutate_ops", str(tests.ROOT / "tools" / "mutate_ops.py"))
mutate_ops = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(mutate_ops)

_SOURCE = '''
import numpy as np


def figures(tilts, m):
    """Docstring: tilts["x"] is never mutated."""
    a = tilts["mean"] + tilts["lower"]
    b = m.width * m.height + m.total()
    return a, b, np.pi


def alone(r):
    return r["only"]
'''


def _mutants():
    return [(i, kind, desc, ast.unparse(ast.parse(src))) for i, kind, _, desc, src in mutate_ops.mutants(_SOURCE)]


def test_a_field_read_becomes_the_next_field_the_same_function_reads_from_the_same_name():
    got = [(i, desc) for i, kind, desc, _ in _mutants() if kind == "field"]
    assert got == [(0, "tilts['mean'] -> tilts['lower']"), (1, "tilts['lower'] -> tilts['mean']"),
                   (2, "m.width -> m.height"), (3, "m.height -> m.width")]
    src = {i: s for i, kind, _, s in _mutants()}
    assert "a = tilts['lower'] + tilts['lower']" in src[0]
    assert "b = m.width * m.width + m.total()" in src[3]
    # each mutant changes exactly one site: the rest of the module is the original
    original = ast.unparse(ast.parse(_SOURCE))
    assert src[2].replace("m.height * m.height", "m.width * m.height") == original


def test_methods_imported_names_docstrings_and_lone_fields_are_left_alone():
    descs = " ".join(d for _, kind, d, _ in _mutants() if kind == "field")
    assert "total" not in descs and "np." not in descs and "only" not in descs and "'x'" not in descs


def test_field_sites_come_after_the_other_operators_so_their_numbering_stays():
    source = _SOURCE.replace("np.pi", "np.max(a) + 2.5")
    kinds = [kind for _, kind, _, _, _ in mutate_ops.mutants(source)]
    assert kinds == ["agg", "const", "field", "field", "field", "field"]
    without = ast.parse(source)
    old = [(k, d) for _, k, d in mutate_ops._sites(without) if k != "field"]
    assert old == [("agg", "np.max -> np.min"), ("const", "2.5 -> 2.75")]
