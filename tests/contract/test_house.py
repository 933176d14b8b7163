"""The suite tests behaviour: it never imports the benchmarks (studies, not product code; their own
machinery is tested in ``benchmarks/tests/``, ``make bench-test``), and it replaces attributes of the
code under test (``monkeypatch.setattr``) at most 12 times: a seam the code offers (an argument, an
injected clock or solver, the model cache) is used instead.
"""
from __future__ import annotations

import ast

import tests

TESTS = tests.ROOT / "tests"
MAX_SETATTR = 12


def _imports(tree) -> set[str]:
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names.add(node.module)
    return names


def _setattr_calls(tree) -> int:
    return sum(1 for node in ast.walk(tree) if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
               and node.func.attr == "setattr" and getattr(node.func.value, "id", "") == "monkeypatch")


def _trees():
    for path in sorted(TESTS.rglob("*.py")):
        yield path.relative_to(tests.ROOT).as_posix(), ast.parse(path.read_text())


def test_no_test_imports_the_benchmarks():
    found = [name for name, tree in _trees()
             if any(m == "benchmarks" or m.startswith("benchmarks.") for m in _imports(tree))]
    assert not found, found


def test_attributes_are_replaced_at_most_twelve_times():
    counts = {name: n for name, tree in _trees() if (n := _setattr_calls(tree))}
    assert sum(counts.values()) <= MAX_SETATTR, counts


def test_the_scans_find_what_they_look_for():
    tree = ast.parse("from benchmarks import bench_fit\nimport benchmarks.bench_coverage\n"
                     "def test_x(monkeypatch):\n    monkeypatch.setattr(m, 'f', g)\n    monkeypatch.setenv('A', '1')\n")
    assert {"benchmarks", "benchmarks.bench_coverage"} <= _imports(tree)
    assert _setattr_calls(tree) == 1
