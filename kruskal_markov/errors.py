"""The engine's error and warning types (their own module so that the validation helpers and the model
share them without importing each other)."""
from __future__ import annotations

__all__ = ["ModelError", "KruskalDeprecationWarning"]


class ModelError(ValueError):
    """An invalid transition model, automaton or model file; the message says what and where.

    Parameters
    ----------
    message : str
        One line: what is wrong and where (which action, which row, by how much).
    """


class KruskalDeprecationWarning(DeprecationWarning):
    """A deprecated name of this project's packages was used; the message names its replacement.

    Its own class so that the test suite turns exactly these into errors (``filterwarnings`` in
    pyproject.toml): no test calls a deprecated alias except the one test of that alias.

    Parameters
    ----------
    message : str
        ``"<old> is deprecated; use <new>"``.
    """
