"""SIGINT and SIGTERM during a session: raised between writes, never inside one.

:class:`SignalGuard` installs handlers that raise
:class:`~experiments.session.machine.SessionInterrupted`; inside :meth:`SignalGuard.critical`
(a log append, a file rewrite) a signal is held and raised right after, and inside
:meth:`SignalGuard.shielded` (the clean-up after an interruption or an error) it is dropped.
"""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

from experiments.responders.base import ResponderClosed
from experiments.session.machine import SessionInterrupted

__all__ = ["SignalGuard", "STOPS", "stop_reason"]

#: What stops a session cleanly (resumable): a signal, Ctrl-C, the participant's window closed.
STOPS = (SessionInterrupted, KeyboardInterrupt, ResponderClosed)


def stop_reason(exc) -> str:
    """The reason logged for one of :data:`STOPS` (the signal's name, or the message)."""
    return getattr(exc, "reason", None) or str(exc) or type(exc).__name__


class SignalGuard:
    """SIGINT/SIGTERM handlers that hold a signal while the session writes.

    Attributes
    ----------
    depth : int
        How many :meth:`critical` or :meth:`shielded` blocks are open.
    pending : str or None
        The name of a signal held until the outermost critical block ends.
    """

    def __init__(self):
        self.depth = 0
        self.pending: str | None = None

    @contextmanager
    def critical(self):
        """No signal interrupts the block; one that arrived is raised right after."""
        self.depth += 1
        try:
            yield
        finally:
            self.depth -= 1
            if self.depth == 0 and self.pending is not None:
                reason, self.pending = self.pending, None
                raise SessionInterrupted(reason)

    @contextmanager
    def shielded(self):
        """No signal interrupts the block (a clean-up); one that arrived is dropped."""
        self.depth += 1
        try:
            yield
        finally:
            self.depth -= 1
            self.pending = None

    def install(self):
        """Install the handlers (main thread only); returns what :meth:`restore` needs."""
        if threading.current_thread() is not threading.main_thread():
            return None

        def handler(signum, frame):
            name = signal.Signals(signum).name
            if self.depth:
                self.pending = name
                return
            raise SessionInterrupted(name)

        old = {}
        for sig in (signal.SIGINT, signal.SIGTERM):
            old[sig] = signal.signal(sig, handler)
        return old

    @staticmethod
    def restore(old) -> None:
        """Put back the handlers :meth:`install` replaced."""
        if old:
            for sig, h in old.items():
                signal.signal(sig, h)
