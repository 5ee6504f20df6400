"""Errors of :mod:`experiments.calibration` (both are user errors: the CLI exits 2)."""
from __future__ import annotations

from experiments.errors import UserInputError

__all__ = ["CalibrationError", "CalibrationRefused"]


class CalibrationError(UserInputError):
    """Unusable calibration input: a missing file or column, a flat, truncated or
    non-physical trace.  The message names the file and the field."""


class CalibrationRefused(CalibrationError):
    """The fit ran but is not reported: it did not converge or is not identifiable.

    Attributes
    ----------
    reasons : tuple of str
        Every check that failed, in words.
    diagnostics : dict
        What the checks measured (JSON-ready), for ``refusal.json``.
    """

    def __init__(self, message: str, reasons=(), diagnostics=None):
        super().__init__(message)
        self.reasons = tuple(reasons)
        self.diagnostics = dict(diagnostics or {})
