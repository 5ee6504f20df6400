"""The exception and the warning classes of :mod:`stimuli`."""
from __future__ import annotations

__all__ = ["ModelInputError", "ModelRangeWarning"]


class ModelInputError(ValueError):
    """A physically meaningless or unsupported input to the thermal model.

    The message follows the project's convention
    ``"<where>: <field>: expected <what>, got <value!r>"``; the command line
    prints it in one line and exits with status 2.
    """


class ModelRangeWarning(UserWarning):
    """An input the model accepts but outside the range its physics was meant for (e.g. a skin
    temperature outside 20-42 °C, Eq. 5 at a pressure approaching the skin's hardness)."""
