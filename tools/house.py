"""The house in numbers (docs/log/house.md): modules and lines by package, the largest modules, the
sync family's public size, worst complexity, modules importing each other, what the tests reach into
(private modules and names, attribute replacements, the benchmarks) and the documents' lengths.

Run from the repository's root: ``python tools/house.py`` (this checkout), ``python tools/house.py
DIR`` (another tree, e.g. ``git archive 67ac0f3 | tar -x -C DIR``), ``python tools/house.py BEFORE
AFTER`` (a Markdown table of both). Reads files only (``ast``, line counts) and runs ``ruff`` for
the complexity; ``duplicates`` pairs are counted when that command is on the ``PATH``.
"""
from __future__ import annotations

import ast
import pathlib
import re
import shutil
import subprocess
import sys

PACKAGES = ("kruskal_markov", "transition_builder", "analysis")
#: the subpackages counted on their own rows (each is also inside its package's row)
SUBPACKAGES = ("kruskal_markov/sync", "transition_builder/builder", "analysis/experiments", "analysis/commands",
               "analysis/fit")
GUIDE_LINES = 400


def _lines(p: pathlib.Path) -> int:
    return len(p.read_text(errors="replace").splitlines())


def _modules(root: pathlib.Path) -> dict:
    out = {}
    for pkg in PACKAGES:
        for p in sorted((root / pkg).rglob("*.py")):
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


def by_package(root: pathlib.Path) -> dict:
    """``package -> (modules, lines)`` for each package and the counted subpackages."""
    out = {}
    for d in PACKAGES + SUBPACKAGES:
        files = sorted((root / d).rglob("*.py"))
        out[d.replace("/", ".")] = (len(files), sum(_lines(p) for p in files))
    return out


def _dunder_all(path: pathlib.Path) -> list:
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "__all__" for t in node.targets):
            try:
                return list(ast.literal_eval(node.value))
            except ValueError:
                return []
    return []


def sync_family(root: pathlib.Path) -> dict:
    """The sync subpackage: public and private modules with their lines, and its exported names."""
    d = root / "kruskal_markov" / "sync"
    files = [p for p in sorted(d.rglob("*.py")) if p.name != "__init__.py"]
    private = [p for p in files if any(part.startswith("_") for part in p.relative_to(d).parts)]
    public = [p for p in files if p not in private]
    return {"public": (len(public), sum(map(_lines, public))), "private": (len(private), sum(map(_lines, private))),
            "exported": len(_dunder_all(d / "__init__.py"))}


def _is_private(module: str) -> bool:
    return any(part.startswith("_") for part in module.split("."))


def tests_reach(root: pathlib.Path) -> dict:
    """What the tests reach into: private modules and names, attribute replacements, the benchmarks."""
    private_modules, private_names = set(), set()
    setattr_calls = monkeypatch_calls = bench = files = 0
    for t in sorted((root / "tests").rglob("*.py")):
        files += 1
        tree = ast.parse(t.read_text())
        imports_bench = False
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and not node.level:
                top = node.module.split(".")[0]
                imports_bench |= top == "benchmarks"
                if top in PACKAGES:
                    if _is_private(node.module):
                        private_modules.add(node.module)
                    private_names |= {f"{node.module}.{a.name}" for a in node.names if a.name.startswith("_")}
                    private_modules |= {f"{node.module}.{a.name}" for a in node.names
                                        if a.name.startswith("_") and (root / node.module.replace(".", "/")
                                                                       / f"{a.name}.py").exists()}
            elif isinstance(node, ast.Import):
                for a in node.names:
                    imports_bench |= a.name.split(".")[0] == "benchmarks"
                    if a.name.split(".")[0] in PACKAGES and _is_private(a.name):
                        private_modules.add(a.name)
        bench += imports_bench
        calls = [node.func.attr for node in ast.walk(tree) if isinstance(node, ast.Call)
                 and isinstance(node.func, ast.Attribute) and getattr(node.func.value, "id", "") == "monkeypatch"]
        setattr_calls += calls.count("setattr")
        monkeypatch_calls += len(calls)
    return {"files": files, "private_modules": len(private_modules), "private_names": len(private_names),
            "setattr": setattr_calls, "monkeypatch": monkeypatch_calls, "import_benchmarks": bench}


def complexity(root: pathlib.Path) -> list:
    """(complexity, function) over 10, the Numba kernels aside, worst first."""
    out = subprocess.run([sys.executable, "-m", "ruff", "check", ".", "--select", "C901", "--isolated",
                          "--config", "lint.mccabe.max-complexity=10", "--output-format", "concise",
                          "--exclude", "**/_*kernels*.py,mutants"], capture_output=True, text=True, cwd=root).stdout
    return sorted(((int(m.group(2)), m.group(1)) for m in re.finditer(r"`(\S+)` is too complex \((\d+)", out)),
                  reverse=True)


def duplicates(root: pathlib.Path) -> str:
    """``duplicates``' first line (pairs and files read) over the packages, or a dash without the tool."""
    if shutil.which("duplicates") is None:
        return "-"
    out = subprocess.run(["duplicates", "--repo", str(root), "--most", "1", "--seconds", "120"],
                         capture_output=True, text=True).stdout
    return out.splitlines()[0] if out else "-"


def long_docs(root: pathlib.Path) -> list:
    """(lines, page) of the documents in ``docs/`` (logs aside) over :data:`GUIDE_LINES`."""
    pages = [p for p in sorted((root / "docs").glob("*.md"))]
    return sorted(((_lines(p), p.name) for p in pages if _lines(p) > GUIDE_LINES), reverse=True)


def measure(root=".") -> dict:
    """Every figure, as the text of one table cell each."""
    root = pathlib.Path(root)
    mods = _modules(root)
    rows = {}
    for name, (n, lines) in by_package(root).items():
        rows[f"`{name}`: modules / lines"] = f"{n} / {lines:,}"
    sizes = sorted(((_lines(p), str(p.relative_to(root))) for p in mods.values()), reverse=True)[:8]
    rows["largest modules (lines)"] = ", ".join(f"`{p}` {n}" for n, p in sizes)
    kernels = [(n, p) for n, p in sizes if not pathlib.Path(p).name.startswith("_")]
    rows["largest module outside the kernels"] = f"`{kernels[0][1]}` {kernels[0][0]}" if kernels else "-"
    s = sync_family(root)
    rows["sync family: public modules / lines"] = f"{s['public'][0]} / {s['public'][1]:,}"
    rows["sync family: private modules / lines"] = f"{s['private'][0]} / {s['private'][1]:,}"
    rows["sync family: names in `__all__`"] = str(s["exported"])
    cx = complexity(root)
    rows["complexity over 15 (kernels aside)"] = str(sum(1 for c, _ in cx if c > 15))
    rows["worst complexity (kernels aside)"] = ", ".join(f"{c} `{f}`" for c, f in cx[:3])
    rows["modules importing each other"] = str(len(mutual_imports(mods)))
    t = tests_reach(root)
    rows["test files"] = str(t["files"])
    rows["private modules imported by tests"] = str(t["private_modules"])
    rows["private names imported by tests"] = str(t["private_names"])
    rows["`monkeypatch.setattr` in tests"] = str(t["setattr"])
    rows["`monkeypatch` calls of any kind"] = str(t["monkeypatch"])
    rows["test files importing `benchmarks`"] = str(t["import_benchmarks"])
    docs = long_docs(root)
    rows[f"docs pages over {GUIDE_LINES} lines"] = (", ".join(f"`{p}` {n}" for n, p in docs) or "none")
    rows["`duplicates`"] = duplicates(root)
    return rows


def main(argv: list[str]) -> None:
    roots = argv or ["."]
    tables = [measure(r) for r in roots]
    print("| | " + " | ".join(roots) + " |")
    print("|---|" + "---|" * len(roots))
    for key in tables[0]:
        print(f"| {key} | " + " | ".join(t.get(key, "-") for t in tables) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
