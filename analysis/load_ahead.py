"""The sessions read in a forked process while the caller imports the rest of the analysis.

``thermocue analyze`` spends its first ~1.5 s of CPU importing SciPy, statsmodels and the
analysis modules, and then ~1 s reading the session folders (:func:`analysis.load.load_trials`),
one after the other on one core. :func:`start` forks a child that reads them (it needs only
pandas and the log reader, ~0.4 s to import, :mod:`analysis` importing its names on demand)
while the caller imports the rest; :meth:`PendingLoad.result` then hands over the child's
:class:`~analysis.load.TrialLog`, pickled through a pipe, the same tables and messages as reading
them here. Warnings the child issued are issued again in the caller, in order, under the
caller's filters; a :class:`~analysis.errors.LogError` (or any other error of the read) is raised
there too.

Where a fork is not available or not safe (:func:`analysis.worker.can_fork`: another thread
runs, a daemonic process), or the child dies without an answer (killed, out of memory), the
sessions are read in the caller at :meth:`PendingLoad.result`: the same result, later.
"""
from __future__ import annotations

import multiprocessing
import os
import warnings

__all__ = ["start", "PendingLoad"]


def _read(data_dir, sessions: str, condition):
    """``(TrialLog, warnings issued)``, as read by :func:`analysis.load.load_trials`."""
    from analysis.load import load_trials
    with warnings.catch_warnings(record=True) as issued:
        warnings.simplefilter("always")
        log = load_trials(data_dir, sessions=sessions, condition=condition)
    return log, [(w.message, w.category) for w in issued]


def _child(conn, data_dir, sessions, condition) -> None:
    """In the forked child: the read's outcome sent through ``conn`` (``("ok", result)`` or
    ``("error", exception)``)."""
    try:
        try:
            outcome = ("ok", _read(data_dir, sessions, condition))
        except Exception as exc:          # noqa: BLE001  handed to the caller, raised there
            outcome = ("error", exc)
        conn.send(outcome)
    finally:
        conn.close()


class PendingLoad:
    """The sessions being read (:func:`start`); :meth:`result` waits for them."""

    def __init__(self, data_dir, sessions: str = "first", condition=None):
        self.data_dir, self.sessions, self.condition = data_dir, sessions, condition
        self._process = self._conn = None
        from analysis.worker import can_fork
        if not can_fork():
            return
        ctx = multiprocessing.get_context("fork")
        receive, send = ctx.Pipe(duplex=False)
        try:
            process = ctx.Process(target=_child, args=(send, data_dir, sessions, condition),
                                  name="thermocue-load-ahead", daemon=True)
            process.start()
        except OSError:                   # no process to spare: read in the caller
            receive.close()
            return
        finally:
            send.close()                  # the child's end: EOF here once the child is gone
        self._process, self._conn = process, receive

    @property
    def forked(self) -> bool:
        """Whether a child is reading the sessions (else :meth:`result` reads them here)."""
        return self._process is not None

    def result(self):
        """The :class:`~analysis.load.TrialLog` (once; the child's warnings issued here)."""
        outcome = None
        if self._process is not None:
            try:
                outcome = self._conn.recv()
            except (EOFError, OSError):   # the child died without an answer
                outcome = None
            finally:
                self._conn.close()
                self._process.join()
                self._process = self._conn = None
        if outcome is None:
            outcome = ("ok", _read(self.data_dir, self.sessions, self.condition))
        kind, value = outcome
        if kind == "error":
            raise value
        log, issued = value
        for message, category in issued:
            warnings.warn(message, category, stacklevel=2)
        return log


def start(data_dir, sessions: str = "first", condition=None) -> PendingLoad:
    """Start reading ``data_dir``'s sessions (:func:`analysis.load.load_trials`'s arguments)
    in a forked child; :meth:`PendingLoad.result` returns them."""
    return PendingLoad(os.fspath(data_dir), sessions, condition)
