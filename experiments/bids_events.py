"""A session's BIDS ``events.tsv``: what happened in each trial attempt and when, from the log.

One concept: the events table of one run (a session is one run) and its sidecar. Every time is
taken from one clock, the host's UTC clock that stamps each event of ``events.jsonl`` (its
``time``, millisecond resolution): ``onset`` is an event's time minus the session's
``session_started`` time, in seconds; ``duration`` is the time from that event to the event that
ends it, on the same clock. The device's clock (``contact_onset_s``, traces) and the keyboard's
(``rt_s``) are other clocks: they stay in ``beh.tsv``, and no time of theirs is put on the log's
clock; the one thing taken from the device is a length, the contact's (below). A resumed
session stays one run: its onsets go on counting from the first start (the pause shows).

Rows (``trial_type``), one per event that was logged, sorted by onset:

``trial``
    ``trial_started`` to the attempt's ``trial_completed`` or ``trial_aborted``. An attempt cut
    by a killed process is marked aborted only when the session is resumed: that time is not
    the attempt's end, so its duration is ``n/a``.
``cue``
    the contact cue (a sound) was played (``cue`` with ``played`` true); duration ``n/a`` (its
    length is not logged).
``contact`` / ``playback``
    the finger touched the sample (real trial) or the display (simulated trial), until the
    display's recording ended. The end is the host's time the recording returned (the
    ``record`` / ``playback`` state event's ``ended_at_utc``, on the log's clock); the duration is
    the recording's own length from the contact (``contact_duration_s`` of the attempt's row,
    timed by the display to 1 ms; over a recording of at most minutes the two clocks' rates
    differ by well under 1 ms); the onset is the end minus that duration. (The host's time of
    reading the first frame in contact, ``contact_at_utc``, is not used there: frames may queue
    while the host shows a text, and it then reads the contact late.) A session on a *virtual*
    clock (``session_started`` ``clock = "virtual"``: the emulator as fast as possible) has no
    real-time length to place on the host's clock: its row runs from ``contact_at_utc`` to
    ``ended_at_utc``, the host's times as it ran (no frame queues in that emulator). Without
    these (an attempt interrupted before its row, a log written by an earlier version) there is
    no such row.
``question``
    the question's first frame on the participant's window (``text_on`` of the ``question``
    screen) until its ``text_off``; ``question_cue``: the question's sound in the spoken-answer
    mode (duration ``n/a``).
``response``
    the answer: a keyed answer when it was logged (``response``, right after the key), a spoken
    one when the experimenter keyed it (its ``answer_keyed`` event, before the confirmation);
    duration 0 (a key press). The precise response time is ``rt_s`` of ``beh.tsv`` (the
    keyboard's clock, from the question's first frame).
``feedback``
    the practice block's feedback was given; duration ``n/a``.

An event that did not happen has no row (an aborted attempt without contact has no ``contact``
row); a value that was not logged is ``n/a`` (an attempt whose end was never logged has a
``trial`` duration ``n/a``, an attempt without an answer a ``response`` of ``n/a``). No time is
ever made up.
"""
from __future__ import annotations

import datetime as _dt
import math
from typing import Any, Iterable, Mapping

from sessionfiles.logformat import event_time

__all__ = ["EVENT_COLUMNS", "EVENT_SIDECAR", "TRIAL_TYPES", "event_rows", "event_time"]

#: The events table's columns, in order.
EVENT_COLUMNS = ("onset", "duration", "trial_type", "trial_index", "attempt", "block", "mode",
                 "sample", "roughness_um", "response", "correct", "answer_mode", "status")

#: ``trial_type`` levels and what each row is.
TRIAL_TYPES = {
    "trial": "The trial attempt, from its start (trial_started) to its end (trial_completed or "
             "trial_aborted in the log)",
    "cue": "The sound cue telling the participant to touch was played",
    "contact": "Real trial: the finger on the sample, from the contact the display detected to "
               "the end of the recording",
    "playback": "Simulated trial: the finger on the display, from the contact to the end of "
                "the replayed temperature profile",
    "question": "The question on the participant's window, from its first frame to the frame "
                "that took it down",
    "question_cue": "Spoken-answer mode: the sound asking for the answer",
    "response": "The answer was given (keyed by the participant, or by the experimenter for a "
                "spoken answer)",
    "feedback": "Practice block: the participant was told whether the answer was right",
}

_CLOCK = ("host UTC clock of the session log (each event's time in events.jsonl, millisecond "
          "resolution)")

#: The ``events.json`` sidecar (column -> description, units, levels).
EVENT_SIDECAR = {
    "onset": {"Description": "Time of the event from the start of the session (its "
                             "session_started event), on the " + _CLOCK, "Units": "s"},
    "duration": {"Description": "Time from the event to the event that ended it, on the same "
                                "clock; 0 for an instant (a key press); n/a when the end was not "
                                "logged. contact and playback rows: the recording's length from "
                                "the contact as the display timed it (1 ms), ending when the "
                                "host had the recording back", "Units": "s"},
    "trial_type": {"Description": "What happened", "Levels": TRIAL_TYPES},
    "trial_index": {"Description": "Trial number in the session's schedule, from 1 (the "
                                   "trial_index of beh.tsv)"},
    "attempt": {"Description": "Attempt number of this trial (a faulted or aborted attempt is "
                               "run again)"},
    "block": {"Description": "Block name from the protocol"},
    "mode": {"Description": "How the sample was presented",
             "Levels": {"real": "a physical stainless-steel sample",
                        "simulated": "the Peltier display replaying the sample's temperature"}},
    "sample": {"Description": "The sample presented (its id in the protocol: 1..4 for 1#..4#)"},
    "roughness_um": {"Description": "Roughness Ra of the sample presented", "Units": "um"},
    "response": {"Description": "The sample named in the answer (its id); n/a where no answer "
                                "was given or asked"},
    "correct": {"Description": "Whether the answer named the sample presented; n/a without an "
                               "answer", "Levels": {"1": "correct", "0": "not correct"}},
    "answer_mode": {"Description": "Who keyed the answer",
                    "Levels": {"keyed": "the participant pressed the answer",
                               "spoken": "the participant said it and the experimenter keyed it"}},
    "status": {"Description": "How the attempt ended; n/a when its end was not logged",
               "Levels": {"ok": "completed", "fault": "display fault (run again)",
                          "aborted": "no contact or interrupted (run again)"}},
}

_CONTACT_STATES = {"record": "contact", "playback": "playback"}




def _int(v: Any) -> int | None:
    if isinstance(v, bool) or v is None:
        return None
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return int(f) if math.isfinite(f) and f == int(f) else None


class _Attempt:
    """What the log says about one trial attempt."""

    def __init__(self, spec: Mapping, t: _dt.datetime | None, run: int = 0):
        self.spec = spec
        self.run = run                # which start of the session (0, then each resume) ran it
        self.start = t
        self.end: _dt.datetime | None = None
        self.row: Mapping = {}
        self.status: str | None = None
        self.response: Mapping = {}
        self.marks: list[tuple[str, _dt.datetime, _dt.datetime | None, bool]] = []
        self.touch: tuple | None = None   # (trial_type, contact frame read, recording's end)
        self.open_question: _dt.datetime | None = None
        self.keyed: dict[str, _dt.datetime] = {}      # spoken answers: key -> when keyed

    def mark(self, kind, t, end=None, instant=False):
        self.marks.append((kind, t, end, instant))


def _attempts(events: Iterable[Mapping], virtual: bool = False) -> list[_Attempt]:
    attempts: list[_Attempt] = []
    by_key: dict[tuple[int, int], _Attempt] = {}
    current: _Attempt | None = None
    asked: _Attempt | None = None          # the attempt whose question is on screen
    run = -1
    for e in events:
        kind = e.get("event")
        t = event_time(e)
        key = (_int(e.get("trial_index")), _int(e.get("attempt")) or 1)
        if kind in ("session_started", "session_resumed"):
            run, current, asked = run + 1, None, None
            continue
        if kind == "trial_started":
            current = _Attempt(e, t, run)
            attempts.append(current)
            by_key[key] = current
            continue
        if kind == "text_off" and e.get("state") == "question" and asked is not None:
            when = event_time(e)             # the question may stay up past the trial's end
            if when is not None and asked.open_question is not None:
                asked.mark("question", asked.open_question, when)
                asked.open_question = None
            asked = None
            continue
        a = by_key.get(key) if key[0] is not None and "attempt" in e else current
        if a is None or (key[0] is not None and _int(a.spec.get("trial_index")) != key[0]):
            continue
        if t is None:
            continue
        if kind in ("trial_completed", "trial_aborted"):
            a.end = t if run == a.run else None      # logged by a later run: not its end
            row = e.get("row") if isinstance(e.get("row"), Mapping) else {}
            a.row = row
            a.status = "aborted" if kind == "trial_aborted" else (row.get("status") or None)
            current = None
        elif kind == "state" and e.get("to") in _CONTACT_STATES:
            ended = event_time({"time": e.get("ended_at_utc")})
            if ended is not None:
                a.touch = (_CONTACT_STATES[e["to"]], event_time({"time": e.get("contact_at_utc")}),
                           ended)
        elif kind == "cue" and e.get("played") is True:
            a.mark("cue", t)
        elif kind == "question_cue" and e.get("played") is True:
            a.mark("question_cue", t)
        elif kind == "text_on" and e.get("state") == "question":
            _close(a)
            a.open_question, asked = t, a
        elif kind == "answer_keyed":
            a.keyed[str(e.get("key"))] = t
        elif kind == "response":
            a.response = e
            keyed = a.keyed.get(str(e.get("response_id")))
            spoken = e.get("answer_mode") == "spoken" and keyed is not None
            a.mark("response", keyed if spoken else t, instant=True)
        elif kind == "feedback":
            a.mark("feedback", t)
    for a in attempts:
        _close(a)
        if a.touch is None:
            continue
        kind, read, ended = a.touch
        length = _seconds_value(a.row.get("contact_duration_s"))
        if virtual and read is not None and read <= ended:
            a.mark(kind, read, ended)
        elif not virtual and length is not None:
            a.mark(kind, ended - _dt.timedelta(seconds=length), ended)
    return attempts


def _seconds_value(v: Any) -> float | None:
    """A finite non-negative number of seconds, or None."""
    if isinstance(v, bool) or v is None or v == "":
        return None
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) and f >= 0 else None


def _close(a: _Attempt) -> None:
    """A question whose end was not logged: its row, duration ``n/a``."""
    if a.open_question is not None:
        a.mark("question", a.open_question, None)
        a.open_question = None


def _seconds(t: _dt.datetime, zero: _dt.datetime) -> float:
    return round((t - zero).total_seconds(), 3)


def event_rows(events: list[Mapping]) -> list[list] | None:
    """The events table of one session log (rows in :data:`EVENT_COLUMNS` order, ``None`` for
    ``n/a``), or None when the log has no ``session_started`` with a time (nothing to count
    onsets from).

    Parameters
    ----------
    events : list of dict
        ``events.jsonl`` as read (:attr:`sessionfiles.session_reader.SessionFolder.events`).

    Returns
    -------
    list of list or None
        Sorted by onset (then by the log's order).
    """
    started = next((e for e in events if e.get("event") == "session_started"), {})
    zero = event_time(started)
    if zero is None:
        return None
    rows = []
    for a in _attempts(events, virtual=started.get("clock") == "virtual"):
        spec, row, resp = a.spec, a.row, a.response
        response = _int(resp.get("response_id")) if resp else _int(row.get("response_id"))
        correct = _int(row.get("correct"))
        if correct is None and response is not None and _int(spec.get("roughness_id")) is not None:
            correct = int(response == _int(spec.get("roughness_id")))
        common = [_int(spec.get("trial_index")), _int(spec.get("attempt")) or 1, spec.get("block"),
                  spec.get("mode"), _int(spec.get("roughness_id")), spec.get("roughness_um"),
                  response, correct if response is not None else None,
                  (resp.get("answer_mode") if resp else row.get("answer_mode")) or None,
                  a.status]
        marks = ([("trial", a.start, a.end, False)] if a.start is not None else []) + a.marks
        for kind, t, end, instant in marks:
            duration = 0.0 if instant else (round((end - t).total_seconds(), 3)
                                            if end is not None else None)
            rows.append((t, len(rows), [_seconds(t, zero), duration, kind] + common))
    rows.sort(key=lambda r: (r[0], r[1]))
    return [r[2] for r in rows]
