"""Mutation operators mutmut does not have, and a small runner for them (``tools/mutate.py --ops``).

mutmut 3 swaps operators, names and literals one token at a time; the errors a reviewer plants in
reported figures are often of another kind (docs/testing.md). The operators here:

``agg``
    aggregation swaps: ``mean`` <-> ``median`` (``np.`` functions), ``.mean()`` -> ``.max()``,
    ``.sum()`` -> ``.mean()``, ``max`` <-> ``min`` (builtins, ``np.`` functions and methods),
    ``argmax`` <-> ``argmin``, ``any`` <-> ``all``, ``.std()`` -> ``.var()``;
``const``
    constant perturbations: a float literal other than 0 and 1 times 1.1, an integer literal other
    than 0 and 1 plus 1;
``threshold``
    threshold perturbations: the right side ``b`` of a comparison ``a < b`` (``<=``, ``>``, ``>=``)
    that is not a literal becomes ``b * 1.25``;
``field``
    a figure read from the wrong field of the same record: a read ``x.a`` (not a call) or ``x["a"]`` of a
    name ``x`` is replaced by the next (in sorted order) of the other fields the same function reads from
    ``x`` the same way (``tilts["mean"]`` -> ``tilts["lower"]``, ``m.mean_entropy_50`` ->
    ``m.mean_entropy_10``); names bound by imports are left alone. Its sites come after the other
    operators' so that their numbering does not move.

Docstrings, ``__all__``, keyword defaults of ``print``-like formatting and functions decorated
with ``njit`` / ``jit`` are left alone. Each mutant is the module with exactly one site changed; it
runs against the module's tests in a scratch copy of the project (``-x``, so the first failing test
kills it; a timeout counts as killed, as in mutmut).
"""
from __future__ import annotations

import ast
import copy
import os
import pathlib
import shutil
import subprocess
import sys

_NP_SWAP = {"mean": "median", "median": "mean", "max": "min", "min": "max", "nanmax": "nanmin", "nanmin": "nanmax",
            "argmax": "argmin", "argmin": "argmax", "any": "all", "all": "any", "sum": "mean", "amax": "amin",
            "amin": "amax", "maximum": "minimum", "minimum": "maximum", "std": "var"}
_METHOD_SWAP = {"mean": "max", "sum": "mean", "max": "min", "min": "max", "argmax": "argmin", "argmin": "argmax",
                "any": "all", "all": "any", "std": "var"}
_BUILTIN_SWAP = {"max": "min", "min": "max", "any": "all", "all": "any"}
_CMP = (ast.Lt, ast.LtE, ast.Gt, ast.GtE)


def _jitted(fn) -> bool:
    for d in fn.decorator_list:
        target = d.func if isinstance(d, ast.Call) else d
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
        if name in ("njit", "jit", "vectorize", "guvectorize"):
            return True
    return False


def _skipped_nodes(tree) -> set[int]:
    """ids of nodes never mutated: docstrings, ``__all__`` and jitted functions' bodies."""
    skip = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr) \
                and isinstance(getattr(body[0], "value", None), ast.Constant) and isinstance(body[0].value.value, str):
            skip.update(id(n) for n in ast.walk(body[0]))
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and _jitted(node):
            skip.update(id(n) for n in ast.walk(node))
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
            skip.update(id(n) for n in ast.walk(node))
    return skip


def _sites(tree):
    """(node, kind, description) of every mutable site, in a fixed order."""
    skip = _skipped_nodes(tree)
    out = []
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Call):
            f = node.func
            if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and f.value.id in ("np", "numpy") \
                    and f.attr in _NP_SWAP:
                out.append((node, "agg", f"np.{f.attr} -> np.{_NP_SWAP[f.attr]}"))
            elif isinstance(f, ast.Attribute) and f.attr in _METHOD_SWAP and not (
                    isinstance(f.value, ast.Name) and f.value.id in ("np", "numpy", "math")):
                out.append((node, "agg", f".{f.attr}() -> .{_METHOD_SWAP[f.attr]}()"))
            elif isinstance(f, ast.Name) and f.id in _BUILTIN_SWAP:
                out.append((node, "agg", f"{f.id}() -> {_BUILTIN_SWAP[f.id]}()"))
        elif isinstance(node, ast.Constant) and type(node.value) in (int, float) and node.value not in (0, 1):
            out.append((node, "const", f"{node.value!r} -> {_perturbed(node.value)!r}"))
        elif isinstance(node, ast.Compare) and len(node.ops) == 1 and isinstance(node.ops[0], _CMP) \
                and not isinstance(node.comparators[0], ast.Constant):
            out.append((node, "threshold", f"{ast.unparse(node)} -> right side x 1.25"))
    return out + _field_sites(tree, skip)


class _FieldReads(ast.NodeVisitor):
    """Every field read ``(scope, base, how, field, node)`` of a module, ``scope`` the innermost function."""

    def __init__(self, skip: set[int], imported: set[str]):
        self.skip, self.imported, self.scope, self.reads = skip, imported, [None], []

    def visit_FunctionDef(self, node):
        self.scope.append(id(node))
        self.generic_visit(node)
        self.scope.pop()

    visit_AsyncFunctionDef = visit_FunctionDef

    def visit_Call(self, node):
        self.visit(node.func.value if isinstance(node.func, ast.Attribute) else node.func)   # a method is no field
        for a in [*node.args, *node.keywords]:
            self.visit(a)

    def _read(self, node, how, field):
        if id(node) not in self.skip and isinstance(node.ctx, ast.Load) and isinstance(node.value, ast.Name) \
                and node.value.id not in self.imported:
            self.reads.append((self.scope[-1], node.value.id, how, field, node))

    def visit_Attribute(self, node):
        self._read(node, "attr", node.attr)
        self.generic_visit(node)

    def visit_Subscript(self, node):
        if isinstance(node.slice, ast.Constant) and isinstance(node.slice.value, str):
            self._read(node, "key", node.slice.value)
        self.generic_visit(node)


def _field_sites(tree, skip: set[int]):
    """The ``field`` operator's sites, in the order of the reads; each node gets ``_field_to``."""
    imported = {(a.asname or a.name).split(".")[0] for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom))
                for a in n.names}
    v = _FieldReads(skip, imported)
    v.visit(tree)
    fields: dict = {}
    for scope, base, how, field, _ in v.reads:
        fields.setdefault((scope, base, how), set()).add(field)
    out = []
    for scope, base, how, field, node in v.reads:
        others = sorted(fields[(scope, base, how)])
        if len(others) < 2:
            continue
        node._field_to = others[(others.index(field) + 1) % len(others)]
        old, new = (f".{field}", f".{node._field_to}") if how == "attr" else (f"[{field!r}]", f"[{node._field_to!r}]")
        out.append((node, "field", f"{base}{old} -> {base}{new}"))
    return out


def _perturbed(v):
    return v + 1 if isinstance(v, int) else v * 1.1


def _apply(node, kind):
    if kind == "agg":
        f = node.func
        if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and f.value.id in ("np", "numpy"):
            f.attr = _NP_SWAP[f.attr]
        elif isinstance(f, ast.Attribute):
            f.attr = _METHOD_SWAP[f.attr]
        else:
            f.id = _BUILTIN_SWAP[f.id]
    elif kind == "const":
        node.value = _perturbed(node.value)
    elif kind == "field":
        if isinstance(node, ast.Attribute):
            node.attr = node._field_to
        else:
            node.slice = ast.Constant(node._field_to)
    else:
        node.comparators[0] = ast.BinOp(node.comparators[0], ast.Mult(), ast.Constant(1.25))


def mutants(source: str):
    """Yield ``(index, kind, line, description, mutated source)`` for every site of ``source``."""
    tree = ast.parse(source)
    n = len(_sites(tree))
    for i in range(n):
        t = copy.deepcopy(tree)
        node, kind, desc = _sites(t)[i]
        line = getattr(node, "lineno", 0)
        _apply(node, kind)
        ast.fix_missing_locations(t)
        yield i, kind, line, desc, ast.unparse(t)


def run_ops(root: pathlib.Path, work: pathlib.Path, name: str, file: str, tests: list[str], sample: int = 1,
            timeout: float = 300.0, only: range | None = None) -> dict:
    """Run every ``sample``-th custom mutant of ``file`` against ``tests`` (with ``only``: of those, the ones whose
    index is in it, so that a long run splits into lock jobs); survivors to ``ops-survivors.txt``."""
    ws = work / (f"ops-{name}" if only is None else f"ops-{name}-{only.start}-{min(only.stop, 99999)}")
    if ws.exists():
        shutil.rmtree(ws)
    ws.mkdir(parents=True)
    for d in ("kruskal_markov", "transition_builder", "analysis", "tests"):
        shutil.copytree(root / d, ws / d, ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    for f in ("pyproject.toml", "conftest.py"):
        if (root / f).exists():
            shutil.copy(root / f, ws / f)
    original = (root / file).read_text()
    env = dict(os.environ, PYTHONPATH=str(ws), NUMBA_CACHE_DIR=str(ws / ".numba-cache"))
    counts = {"killed": 0, "timeout": 0, "survived": 0}
    survivors = []
    for i, kind, line, desc, src in mutants(original):
        if i % sample or (only is not None and i not in only):
            continue
        (ws / file).write_text(src)
        try:
            rc = subprocess.run([sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *tests],
                                cwd=ws, env=env, capture_output=True, timeout=timeout).returncode
            verdict = "killed" if rc != 0 else "survived"
        except subprocess.TimeoutExpired:
            verdict = "timeout"
        counts[verdict] += 1
        with open(ws / "ops-log.txt", "a") as fh:          # partial results survive an interrupted run
            fh.write(f"{i} {kind} line {line}: {desc}: {verdict}\n")
        if verdict == "survived":
            survivors.append(f"=== ops {i} ({kind}) line {line}: {desc}")
    (ws / file).write_text(original)
    (ws / "ops-survivors.txt").write_text("\n".join(survivors) + "\n")
    total = sum(counts.values())
    return {"module": name, "file": file, "counts": counts, "mutants": total,
            "score": (counts["killed"] + counts["timeout"]) / total if total else float("nan")}
