"""Every example in a docstring and in the README's "Use it from Python" section runs and holds."""
from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import tests

ROOT = tests.ROOT
PACKAGES = ("kruskal_markov", "transition_builder", "analysis")


def _modules():
    for pkg in PACKAGES:
        yield pkg
        for info in pkgutil.walk_packages([str(ROOT / pkg)], prefix=f"{pkg}."):
            if not info.name.endswith("__main__"):
                yield info.name


@pytest.mark.parametrize("name", list(_modules()))
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0


def test_readme_python_example():
    result = doctest.testfile(str(ROOT / "README.md"), module_relative=False,
                              optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted >= 5 and result.failed == 0
