"""The time a session has left, from the trial durations measured in its own event log.

One estimate for the terminal's progress line and for ``thermocue monitor``: both feed the
same events (``events.jsonl``'s) to :class:`TimeLeft`. A trial's measured duration runs from the
start of its first attempt to the start of the next trial: the prompt, the touch, the answer,
any repeated attempts and the rewarm after it (``[contact] rewarm_s``, 30 s in
``roughness_recognition``; measured, not assumed). The time left is, for every trial not yet
done, the mean measured duration of the trials of its block's mode (``real`` trials wait for the
experimenter to place a sample, ``simulated`` ones do not; the mean of all trials while a mode
has none measured), less the time the running trial has already taken, less the one rewarm that
does not follow the last trial. A duration interrupted by the end of a run (an interruption, a
stop, a crash followed by ``resume``) is not a trial's duration and is not counted.

Standard library only: the monitor reads the folder and imports nothing that runs a session.
"""
from __future__ import annotations

from typing import Iterable, Mapping

from sessionfiles.logformat import event_time

__all__ = ["TimeLeft", "event_seconds"]

#: Events after which the open trial's duration is not measured (the run ended or began).
_RUN_BOUNDARIES = {"session_started", "session_resumed", "session_interrupted",
                   "session_stopped", "session_error"}


def event_seconds(event: Mapping) -> float | None:
    """An event's ``time`` (UTC, ISO 8601) as POSIX seconds, or None."""
    t = event_time(event)
    return None if t is None else t.timestamp()


class TimeLeft:
    """Measured trial durations and the time left they give.

    Parameters
    ----------
    modes : mapping of int to str
        The schedule: trial_index -> mode (``real``/``simulated``) of every trial.
    rewarm_s : float
        The protocol's rewarm, s (0 on a virtual clock): the last trial has none after it.
    """

    def __init__(self, modes: Mapping[int, str], rewarm_s: float = 0.0):
        self.modes = {int(k): str(v) for k, v in modes.items()}
        self.rewarm_s = float(rewarm_s)
        self.durations: dict[int, float] = {}     # trial_index -> measured seconds
        self.done: set[int] = set()               # trials with an ok attempt
        self._open: tuple[int, float] | None = None   # (trial_index, start s) of the running trial
        self.finished = False

    def feed(self, event: Mapping) -> None:
        """Take one event of the log (in order)."""
        kind = event.get("event")
        if kind == "trial_started":
            t, ti = event_seconds(event), event.get("trial_index")
            if t is None or not isinstance(ti, int):
                return
            if self._open is not None and self._open[0] != ti:
                self.durations[self._open[0]] = max(0.0, t - self._open[1])
            if self._open is None or self._open[0] != ti:
                self._open = (ti, t)
        elif kind == "trial_completed":
            row = event.get("row") or {}
            if row.get("status") == "ok" and isinstance(event.get("trial_index"), int):
                self.done.add(event["trial_index"])
        elif kind in _RUN_BOUNDARIES:
            self._open = None
        elif kind == "session_finished":
            self.finished = True
            self._open = None

    def feed_all(self, events: Iterable[Mapping]) -> "TimeLeft":
        for e in events:
            self.feed(e)
        return self

    def mean_s(self, mode: str | None = None) -> float | None:
        """Mean measured duration of the trials of ``mode`` (all trials if None or none)."""
        values = [d for ti, d in self.durations.items() if mode is None or self.modes.get(ti) == mode]
        if not values and mode is not None:
            return self.mean_s(None)
        return sum(values) / len(values) if values else None

    def seconds_left(self, now_s: float) -> float | None:
        """Seconds left at ``now_s`` (POSIX seconds), or None before any duration is measured."""
        if self.finished:
            return 0.0
        todo = [ti for ti in self.modes if ti not in self.done]
        if not todo:
            return 0.0
        if self.mean_s() is None:
            return None
        total = sum(self.mean_s(self.modes[ti]) for ti in todo)
        if self._open is not None and self._open[0] in todo:
            total -= min(max(0.0, now_s - self._open[1]), self.mean_s(self.modes[self._open[0]]))
        return max(0.0, total - self.rewarm_s)
