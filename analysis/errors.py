"""Errors and warnings of :mod:`analysis` (one small hierarchy, one module)."""
from __future__ import annotations

__all__ = ["LogError", "LogWarning", "ModelWarning"]


class LogError(ValueError):
    """A trial log that cannot be analysed; the message names the file and the column.

    Messages follow ``"<file>: <column>: expected <what>, got <value!r>"``.
    """


class LogWarning(UserWarning):
    """A trial log that was read only in part (truncated, stale, duplicated rows)."""


class ModelWarning(UserWarning):
    """A model that was simplified or could not be fitted (separation, non-convergence)."""
