"""The house in numbers (docs/house.md): largest modules, worst complexity, import cycles between
modules, private names imported by tests, monkeypatches. Run from the repository's root:
``python tools/house.py``."""
from __future__ import annotations

import ast
import pathlib
import re
import subprocess
import sys

PACKAGES = ("kruskal_markov", "transition_builder", "analysis")


def _modules(root: pathlib.Path) -> dict:
    out = {}
    for pkg in PACKAGES:
        for p in (root / pkg).rglob("*.py"):
            name = ".".join(p.relative_to(root).with_suffix("").parts)
            out[name.removesuffix(".__init__")] = p
    return out


def _imports(path: pathlib.Path, known) -> set:
    """Modules of ``known`` that ``path`` imports, at the top or inside functions."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        names = []
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        found |= {n for n in names if n in known}
    return found


def mutual_imports(mods: dict) -> list:
    """Pairs of modules (packages aside: their ``__init__`` re-exports) that import each other."""
    plain = {m for m, p in mods.items() if p.name != "__init__.py"}
    graph = {m: _imports(mods[m], plain) - {m} for m in plain}
    return sorted({tuple(sorted((a, b))) for a in graph for b in graph[a] if a in graph.get(b, ())})


def main(root=".") -> None:
    root = pathlib.Path(root)
    mods = _modules(root)
    sizes = sorted(((sum(1 for _ in open(p)), str(p.relative_to(root))) for p in mods.values()), reverse=True)[:6]
    print("largest modules:", ", ".join(f"{p} {n}" for n, p in sizes))
    out = subprocess.run([sys.executable, "-m", "ruff", "check", str(root), "--select", "C901", "--isolated",
                          "--config", "lint.mccabe.max-complexity=10", "--output-format", "concise",
                          "--exclude", "**/_*kernels*.py,mutants"], capture_output=True, text=True).stdout
    cx = sorted(((int(m.group(2)), m.group(1)) for m in re.finditer(r"`(\S+)` is too complex \((\d+)", out)),
                reverse=True)
    print("worst complexity (Numba kernels aside):", cx[:5], "; over 15:", sum(1 for c, _ in cx if c > 15))
    print("modules importing each other:", mutual_imports(mods))
    private, patches, clocks, files = set(), 0, 0, 0
    for t in (root / "tests").rglob("*.py"):
        files += 1
        src = t.read_text()
        for node in ast.walk(ast.parse(src)):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] in PACKAGES:
                private |= {f"{node.module}.{a.name}" for a in node.names if a.name.startswith("_")}
        patches += len(re.findall(r"monkeypatch\.(?:setattr|setitem|delattr|setenv|delenv)", src))
        clocks += len(re.findall(r'monkeypatch\.setattr\([^)]*"time"', src))
    print(f"test files: {files}; private names imported by tests: {len(private)}; monkeypatch calls: {patches}; "
          f"module time replaced: {clocks}")


if __name__ == "__main__":
    main(*sys.argv[1:])
