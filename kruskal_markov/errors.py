"""The engine's error type (its own module so that the validation helpers and the model share it
without importing each other)."""
from __future__ import annotations

__all__ = ["ModelError"]


class ModelError(ValueError):
    """An invalid transition model, automaton or model file; the message says what and where.

    Parameters
    ----------
    message : str
        One line: what is wrong and where (which action, which row, by how much).
    """
