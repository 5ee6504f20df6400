"""The errors of :mod:`sessionfiles` (standard library only).

``UserInputError`` means the user gave something wrong (a file, a field, an option): the command
line prints its message in one line and exits with status 2. ``SessionError`` is a session folder
that cannot be written, run or resumed as asked. :mod:`experiments.errors` re-exports both (the
same classes) at the root of its own hierarchy.
"""
from __future__ import annotations

__all__ = ["UserInputError", "SessionError"]


class UserInputError(ValueError):
    """Bad input from the user; the message names the file and the field."""


class SessionError(UserInputError):
    """A session directory that cannot be run or resumed as asked."""
