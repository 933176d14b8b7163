"""Sphinx configuration of the API reference (``make docs``): built from the numpydoc docstrings.

The pages of the three packages are generated here, one section per public module (every module
whose dotted name has no part starting with ``_``), so a new module is documented without an
edit; packages show their docstring only (their members are documented where they are defined).
"""
import importlib
import os
import pkgutil
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, ROOT)

project = "kruskal"
author = "the kruskal project"
extensions = ["sphinx.ext.autodoc", "numpydoc"]
autodoc_default_options = {"members": True, "undoc-members": False}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_xref_param_type = False
html_theme = "alabaster"
exclude_patterns = ["_build"]

PACKAGES = {"kruskal_markov": "kruskal_markov: the Markov mathematics",
            "transition_builder": "transition_builder: physics to transition models",
            "analysis": "analysis: the command line, the experiments and the report"}
#: names a module imports that autodoc would document as its own
EXCLUDE = {"transition_builder.builder.representatives": "cKDTree"}


def public_modules(package: str) -> list[str]:
    """``package`` and its public modules, in walk order."""
    names = [package]
    for info in pkgutil.walk_packages([os.path.join(ROOT, package)], prefix=f"{package}."):
        if not any(part.startswith("_") for part in info.name.split(".")):
            names.append(info.name)
    return names


def _write_pages():
    for package, title in PACKAGES.items():
        lines = [title, "=" * len(title), ""]
        for name in public_modules(package):
            lines += [name, "-" * len(name), "", f".. automodule:: {name}"]
            if hasattr(importlib.import_module(name), "__path__"):
                lines.append("   :no-members:")
            if name in EXCLUDE:
                lines.append(f"   :exclude-members: {EXCLUDE[name]}")
            lines.append("")
        path = os.path.join(HERE, f"{package}.rst")
        text = "\n".join(lines)
        if not os.path.exists(path) or open(path).read() != text:
            with open(path, "w") as f:
                f.write(text)


_write_pages()
