"""The public API is a numpydoc contract: every callable a package exports (its ``__all__``) says what
it takes and what it gives back — functions a ``Parameters`` section (when they take any) and a
``Returns`` (or ``Yields``) section, classes ``Parameters`` or ``Attributes``."""
from __future__ import annotations

import importlib
import inspect
import re

import pytest

PACKAGES = ("kruskal_markov", "transition_builder", "analysis", "kruskal_markov.sync", "transition_builder.builder")


def _exports():
    seen = set()
    for name in PACKAGES:
        package = importlib.import_module(name)
        for attr in package.__all__:
            obj = getattr(package, attr)
            if callable(obj) and id(obj) not in seen:
                seen.add(id(obj))
                yield f"{name}.{attr}", obj


def _sections(obj) -> set[str]:
    """The numpydoc section headers of ``obj``'s docstring (a line underlined with dashes)."""
    lines = (inspect.getdoc(obj) or "").splitlines()
    return {a.strip() for a, b in zip(lines, lines[1:]) if re.fullmatch(r"-{3,}", b.strip()) and a.strip()}


def missing_sections(obj) -> list[str]:
    """What ``obj``'s docstring lacks of the contract (empty: nothing)."""
    found = _sections(obj)
    if inspect.isclass(obj):
        return [] if found & {"Parameters", "Attributes"} else ["Parameters or Attributes"]
    missing = [] if found & {"Returns", "Yields"} else ["Returns"]
    try:
        takes = [p for p in inspect.signature(obj).parameters.values() if p.name not in ("self", "cls")]
    except (TypeError, ValueError):      # no signature to read (a compiled kernel): ask for both
        takes = [None]
    if takes and "Parameters" not in found:
        missing.insert(0, "Parameters")
    return missing


EXPORTS = dict(_exports())


@pytest.mark.parametrize("name", sorted(EXPORTS))
def test_export_is_documented(name):
    missing = missing_sections(EXPORTS[name])
    assert not missing, f"{name}: docstring has no {' / '.join(missing)} section"


def test_the_walk_finds_the_api():
    assert len(EXPORTS) >= 60
    assert "kruskal_markov.TransitionModel" in EXPORTS and "transition_builder.build_model" in EXPORTS
