"""The one exception class of :mod:`stimuli`."""
from __future__ import annotations

__all__ = ["ModelInputError"]


class ModelInputError(ValueError):
    """A physically meaningless or unsupported input to the thermal model.

    The message follows the project's convention
    ``"<where>: <field>: expected <what>, got <value!r>"``; the command line
    prints it in one line and exits with status 2.
    """
