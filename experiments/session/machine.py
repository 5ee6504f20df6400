"""The session's state machine, its interruption signal and its clocks.

:data:`TRANSITIONS` is the table of legal state changes of one trial (see
:mod:`experiments.session`); :class:`StateMachine` enforces it and reports every change (the
session logs each as a ``state`` event), in the manner of PsychoPy's ``ExperimentHandler.status``.
"""
from __future__ import annotations

import time

from experiments.display.url import url_options
from experiments.errors import UserInputError

__all__ = ["TRANSITIONS", "TransitionError", "SessionInterrupted", "StateMachine", "RealClock",
           "VirtualClock", "clock_for_url"]

#: Legal state changes of the engine (state -> states it may go to).
TRANSITIONS: dict[str, frozenset[str]] = {
    "idle": frozenset({"prompt", "finished", "stopped", "interrupted"}),
    "prompt": frozenset({"prepare", "interrupted"}),
    "prepare": frozenset({"cue", "fault", "interrupted"}),
    "cue": frozenset({"wait_contact", "interrupted"}),
    "wait_contact": frozenset({"playback", "record", "no_contact", "fault", "interrupted"}),
    "playback": frozenset({"respond", "fault", "interrupted"}),
    "record": frozenset({"respond", "fault", "interrupted"}),
    "respond": frozenset({"write", "interrupted"}),
    "fault": frozenset({"write", "interrupted"}),
    "no_contact": frozenset({"rewarm", "idle", "interrupted"}),
    "write": frozenset({"rewarm", "idle", "interrupted"}),
    "rewarm": frozenset({"idle", "interrupted"}),
    "finished": frozenset(),
    "stopped": frozenset(),
    "interrupted": frozenset(),
}

class TransitionError(RuntimeError):
    """An illegal state change (a bug in the engine, never a user error)."""


class SessionInterrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived; ``reason`` is the signal's name."""

    def __init__(self, reason: str):
        super().__init__(reason)
        self.reason = reason


class StateMachine:
    """A finite-state machine over a transition table that reports every change.

    Parameters
    ----------
    table : dict of str to set of str
    initial : str
    on_change : callable(old, new, **context)
        Called after every change (the session logs a ``state`` event).
    """

    def __init__(self, table=TRANSITIONS, initial: str = "idle", on_change=None):
        if initial not in table:
            raise ValueError(f"state machine: initial: expected one of {sorted(table)}, got {initial!r}")
        self.table = table
        self.state = initial
        self.on_change = on_change

    def can(self, new: str) -> bool:
        return new in self.table.get(self.state, ())

    def go(self, new: str, **context) -> None:
        """Change to ``new``; raises :class:`TransitionError` naming both states if illegal."""
        if not self.can(new):
            raise TransitionError(f"illegal session transition: {self.state!r} -> {new!r}")
        old, self.state = self.state, new
        if self.on_change is not None:
            self.on_change(old, new, **context)


class RealClock:
    """Wall-clock waits (a lab session)."""

    virtual = False

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            time.sleep(seconds)


class VirtualClock:
    """Waits that return at once and only advance :attr:`now` (simulated sessions)."""

    virtual = True

    def __init__(self):
        self.now = 0.0

    def sleep(self, seconds: float) -> None:
        self.now += max(0.0, float(seconds))


def clock_for_url(url: str, clock: str = "auto"):
    """The session clock: ``"real"``, ``"virtual"`` or ``"auto"`` (virtual iff the display URL
    says ``clock=virtual``, the emulator's own virtual clock)."""
    if clock == "virtual":
        return VirtualClock()
    if clock == "real":
        return RealClock()
    if clock != "auto":
        raise UserInputError(f"--clock: expected 'auto', 'real' or 'virtual', got {clock!r}")
    return VirtualClock() if url_options(url).get("clock") == "virtual" else RealClock()
