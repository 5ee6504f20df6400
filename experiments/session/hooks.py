"""Named points of a trial where a test may stop the engine (kill tests, crash tests).

The engine calls ``hooks.at(point, spec, attempt)`` at each of :data:`PAUSE_POINTS`; the
default :class:`SessionHooks` does nothing there. A test either passes its own subclass to
:class:`~experiments.session.Session` (``hooks=``) or, for a ``thermocue run`` subprocess, sets
:data:`PAUSE_ENV`: :func:`hooks_from_env` then returns a :class:`PauseAt` that prints
``THERMOCUE_PAUSED <point> <trial_index> <attempt>`` on stderr and waits for ever (the test
SIGKILLs the process there).
"""
from __future__ import annotations

import os
import sys
import time

from experiments.errors import UserInputError

__all__ = ["PAUSE_ENV", "PAUSE_POINTS", "SessionHooks", "PauseAt", "hooks_from_env"]

#: Environment variable naming test pause points, e.g. ``"playback:5"`` or
#: ``"upload:9,after_response:3"``.
PAUSE_ENV = "THERMOCUE_TEST_PAUSE_AT"
#: The points, in the order a trial reaches them: the trial logged as started, just before
#: the profile upload, armed, the first frame in contact, the answer taken, the row written.
PAUSE_POINTS = ("trial_started", "upload", "armed", "playback", "after_response", "after_write")


class SessionHooks:
    """Called by the engine at each pause point; this base class does nothing.

    Subclass and override :meth:`at` to stop, kill or inspect a session mid-trial.
    """

    def at(self, point: str, spec, attempt: int) -> None:
        """The engine reached ``point`` (one of :data:`PAUSE_POINTS`) in ``spec``'s ``attempt``."""


class PauseAt(SessionHooks):
    """Print ``THERMOCUE_PAUSED point trial attempt`` and wait for ever at chosen points.

    Parameters
    ----------
    points : set of (str, int)
        ``(point, trial_index)`` pairs.
    """

    def __init__(self, points):
        self.points = set(points)

    def at(self, point: str, spec, attempt: int) -> None:
        if (point, spec.trial_index) in self.points:
            print(f"THERMOCUE_PAUSED {point} {spec.trial_index} {attempt}", file=sys.stderr, flush=True)
            while True:  # the test kills us here
                time.sleep(3600)


def hooks_from_env(environ=None) -> SessionHooks:
    """The hooks :data:`PAUSE_ENV` asks for (none: the do-nothing :class:`SessionHooks`).

    Raises
    ------
    UserInputError
        An item that is not ``point:trial_index`` with a known point.
    """
    text = (os.environ if environ is None else environ).get(PAUSE_ENV, "")
    points = set()
    for item in filter(None, (p.strip() for p in text.split(","))):
        point, _, index = item.partition(":")
        if point not in PAUSE_POINTS or not index.isdigit():
            raise UserInputError(f"{PAUSE_ENV}: expected point:trial_index with point one of "
                                 f"{PAUSE_POINTS}, got {item!r}")
        points.add((point, int(index)))
    return PauseAt(points) if points else SessionHooks()
