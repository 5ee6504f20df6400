"""The exception hierarchy of :mod:`experiments` (one module, kept small).

``UserInputError`` and its subclasses mean the user gave something wrong (a
file, a field, an option): the command line prints their message in one line
and exits with status 2. ``DisplayError`` and its subclasses are device faults:
the session engine puts the display in a safe state, marks the trial and goes on
or stops cleanly.
"""
from __future__ import annotations

__all__ = [
    "UserInputError",
    "ProtocolError",
    "SessionError",
    "DisplayError",
    "DisplayTimeout",
    "DisplayRefused",
    "DisplayRestarted",
    "SafetyLimitError",
]


# the session folder's errors live on the floor below (sessionfiles); the same classes
from sessionfiles.errors import SessionError, UserInputError


class ProtocolError(UserInputError):
    """A malformed experiment protocol file."""


class DisplayError(IOError):
    """The thermal display failed (I/O, refusal, fault reported by the device)."""


class DisplayTimeout(DisplayError):
    """The display did not answer in time."""


class DisplayLinkLost(DisplayError):
    """The port itself failed (the display unplugged, its pty closed): nothing more can be sent.

    ``code`` is ``"LINK_LOST"``, the fault code a trial cut off by it carries."""

    code = "LINK_LOST"


class DisplayBadReply(DisplayError):
    """The display answered a command with a reply the protocol does not have (a wrong size, an
    unknown state or code): nothing of it is used. ``code`` is ``"BAD_REPLY"``, the fault code a
    trial that met it carries; the message names the command."""

    code = "BAD_REPLY"


class DisplayRefused(DisplayError):
    """The display answered a command with an error code: ``code`` as the device sent it,
    ``code_name`` its name (``"BAD_STATE"``), which callers log."""

    def __init__(self, message: str, code: int | None = None, code_name: str | None = None):
        super().__init__(message)
        self.code = code
        self.code_name = code_name


class DisplayFaultLatched(DisplayError):
    """The display is latched in FAULT (over-temperature or a sensor fault) from before this
    connection: the pad's relay is open and it refuses to be armed until an operator has checked
    the pad and reset it (``thermocue clear-fault URL``). ``code`` is the fault's name."""

    def __init__(self, message: str, code: str | None = None):
        super().__init__(message)
        self.code = code


class DisplayRestarted(DisplayError):
    """The display restarted since the handshake (boot id changed, time went back, NO_HELLO):
    it no longer holds the session's limits, neutral or profile; the session stops."""


class SafetyLimitError(DisplayError, UserInputError):
    """A setpoint or profile outside the protocol's safe range or rate limit.

    Raised by the host *before* anything is sent.

    Attributes
    ----------
    reason : str or None
        What is wrong without the message's own ``display: limits:`` prefix, when the raiser
        gives it (a caller that names its own field words its line with it).
    """

    def __init__(self, *args, reason: str | None = None):
        super().__init__(*args)
        self.reason = reason
