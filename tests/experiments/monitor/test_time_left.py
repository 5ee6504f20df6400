"""The time left: measured trial durations, the rewarm included, one estimate for the terminal
and the monitor (experiments.monitor.time_left)."""
from __future__ import annotations

import datetime as dt
import logging
import re

import pytest

from _session_helpers import P01, ScriptedDisplay, ScriptedResponder, read_json_lines, write_protocol
from experiments.monitor.time_left import TimeLeft, event_seconds
from experiments.session import create_session

T0 = dt.datetime(2026, 11, 28, 9, 0, tzinfo=dt.timezone.utc)


def ev(kind, at_s, **fields):
    stamp = (T0 + dt.timedelta(seconds=at_s)).isoformat(timespec="milliseconds")
    return {"event": kind, "time": stamp.replace("+00:00", "Z"), **fields}


def started(ti, at_s, attempt=1):
    return ev("trial_started", at_s, trial_index=ti, attempt=attempt)


def completed(ti, at_s, status="ok", attempt=1):
    return ev("trial_completed", at_s, trial_index=ti, attempt=attempt, row={"status": status})


#: A known schedule: three real trials (20 s touch + 30 s rewarm: 50 s from start to start),
#: then three simulated ones (10 s + 30 s: 40 s).
MODES = {1: "real", 2: "real", 3: "real", 4: "simulated", 5: "simulated", 6: "simulated"}


def known_log(until_trial):
    events = [ev("session_started", -1.0)]
    at = 0.0
    for ti in range(1, until_trial + 1):
        events.append(started(ti, at))
        if ti < until_trial:
            touch = 20.0 if MODES[ti] == "real" else 10.0
            events.append(completed(ti, at + touch))
            at += touch + 30.0
    return events, at


def test_the_time_left_of_a_known_schedule_counts_every_rewarm_but_the_last():
    events, at = known_log(5)                  # trial 5 has just started, at 190 s
    t = TimeLeft(MODES, rewarm_s=30.0).feed_all(events)
    assert t.durations == {1: 50.0, 2: 50.0, 3: 50.0, 4: 40.0}
    assert at == 190.0
    # trials 5 and 6 (simulated, 40 s each), no rewarm after the last
    assert t.seconds_left(event_seconds(events[-1])) == pytest.approx(40 + 40 - 30)
    # 15 s into trial 5: 15 s less
    assert t.seconds_left(event_seconds(events[-1]) + 15) == pytest.approx(80 - 15 - 30)
    # at trial 3 (two real trials measured): the simulated trials are guessed at the real mean
    events, _ = known_log(3)
    t = TimeLeft(MODES, rewarm_s=30.0).feed_all(events)
    assert t.seconds_left(event_seconds(events[-1])) == pytest.approx(4 * 50 - 30)


def test_nothing_is_said_before_a_duration_is_measured_and_nothing_is_left_at_the_end():
    events, _ = known_log(1)
    t = TimeLeft(MODES, rewarm_s=30.0).feed_all(events)
    assert t.seconds_left(event_seconds(events[-1])) is None
    t.feed(ev("session_finished", 500.0))
    assert t.seconds_left(event_seconds(events[-1])) == 0.0


def test_repeated_attempts_count_in_their_trial_and_an_interruption_is_not_a_duration():
    events = [ev("session_started", 0.0), started(1, 0.0), completed(1, 20.0, "fault"),
              started(1, 50.0, attempt=2), completed(1, 70.0),
              started(2, 100.0), ev("session_interrupted", 110.0),
              ev("session_resumed", 1000.0), started(2, 1005.0, attempt=2), completed(2, 1025.0),
              started(3, 1055.0)]
    t = TimeLeft({1: "real", 2: "real", 3: "real"}, rewarm_s=30.0).feed_all(events)
    # trial 1: both attempts and their rewarms (100 s); trial 2 from its attempt after the resume
    assert t.durations == {1: 100.0, 2: 50.0}
    assert t.seconds_left(event_seconds(events[-1])) == pytest.approx(75.0 - 30.0)


def test_the_terminals_time_left_is_the_measured_estimate_with_the_rewarm(tmp_path, caplog):
    # three instant trials and a 2 s rewarm after each but the last, on the real clock: the old
    # estimate (the mean of the trials without their rewarm, times the trials left) said
    # "about 0:00 left" at trial 2 when 2 s of rewarm and a trial were still to come
    proto = write_protocol(tmp_path, real_samples=(1, 2, 3), sim_samples=(), rewarm_s=2.0)
    s = create_session(proto, P01, tmp_path / "data", "scripted://", seed=7,
                       responder_name="scripted-test", clock="real")
    caplog.set_level(logging.INFO, logger="thermocue.session")
    assert s.run(ScriptedResponder(), display=ScriptedDisplay()) == 0
    lines = [r.getMessage() for r in caplog.records if r.getMessage().startswith("trial 2 of 3")]
    said = re.search(r"about (\d+):(\d\d) left", lines[0])
    assert said, lines
    said_s = int(said[1]) * 60 + int(said[2])
    events = read_json_lines(s.directory / "events.jsonl")
    upto = next(i for i, e in enumerate(events) if e["event"] == "trial_started"
                and e["trial_index"] == 2)
    modes = {sp.trial_index: sp.mode for sp in s.schedule}
    want = TimeLeft(modes, rewarm_s=2.0).feed_all(events[:upto + 1]).seconds_left(
        event_seconds(events[upto]))
    assert want >= 2 * 2.0 - 2.0                     # two trials of at least one rewarm each, less one
    # the line's M:SS (seconds cut off) of the same estimate, made a moment after the event
    assert want - 2.0 < said_s <= want
    assert said_s >= 2
