"""The error raised for a bad participant record."""
from __future__ import annotations

__all__ = ["ParticipantError"]


class ParticipantError(ValueError):
    """A participant record that does not validate.

    The message is one line, ``"<file>: <field>: expected <what>, got <value!r>"``;
    the command line prints it and exits with status 2.

    Attributes
    ----------
    source : str
        The file (or other source) the record came from.
    field : str
        Dotted path of the first offending field (``""`` for the whole record).
    errors : tuple of str
        Every problem found, each in the one-line form; the message is the first.
    """

    def __init__(self, message: str, *, source: str = "", field: str = "",
                 errors: tuple[str, ...] | None = None):
        super().__init__(message)
        self.source = source
        self.field = field
        self.errors = tuple(errors) if errors else (message,)
