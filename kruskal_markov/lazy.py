"""Lazy public exports for the packages' ``__init__`` modules (PEP 562).

``import kruskal_markov`` (and the command line) stays fast: a public name is imported from its
module on first use.
"""
from __future__ import annotations

import importlib

__all__ = ["lazy_exports"]


def lazy_exports(package: str, exports: dict[str, str]):
    """Return ``(__getattr__, __dir__)`` for ``package`` whose public ``name`` lives in
    ``package.exports[name]``.

    >>> getattr_, dir_ = lazy_exports("kruskal_markov", {"TransitionModel": "model"})
    >>> getattr_("TransitionModel").__name__
    'TransitionModel'
    """
    def __getattr__(name):
        if name in exports:
            return getattr(importlib.import_module(f"{package}.{exports[name]}"), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__():
        return sorted(set(vars(importlib.import_module(package))) | set(exports))

    return __getattr__, __dir__
