"""Bounded retries: a trial is attempted at most ``[contact] max_attempts`` times (default 3) in
one run, and a session stops after ``max_consecutive_faults`` faulted attempts in a row, on every
path (a reconnection's too); both are logged, and the session is resumable.

The attack: the in-process emulator with a disconnect on its clock, ``disconnect@1.5*`` (an
every-opening event: each reconnection opens a new emulator that has it again), so every attempt
of the trial is cut off the same way;
before, the reconnect path skipped both bounds and one session logged thousands of attempts.
"""
from __future__ import annotations

import io

import pytest

from _session_helpers import P01, ScriptedResponder, read_json_lines, write_protocol
from experiments.session import create_session
from experiments.session.hooks import SessionHooks

pytestmark = pytest.mark.slow


class Count(SessionHooks):
    """Counts attempts; ends a runaway loop (the defect) with an error instead of for ever."""

    def __init__(self):
        self.n = 0

    def at(self, point, spec, attempt):
        if point == "trial_started":
            self.n += 1
            if self.n > 25:
                raise RuntimeError("unbounded retries: more than 25 attempts")


def _session(tmp_path, url, max_faults):
    proto = write_protocol(tmp_path, contact_s=0.5, rewarm_s=0.0, real_samples=(1, 2),
                           sim_samples=(3, 4))
    out = io.StringIO()
    s = create_session(proto, P01, tmp_path / "data", url, seed=4, clock="virtual", out=out,
                       max_consecutive_faults=max_faults)
    s.hooks = Count()
    return s, out


def test_a_fault_that_replays_on_every_reconnection_stops_the_session_at_max_faults(tmp_path):
    s, out = _session(tmp_path, "emulator://?clock=virtual&faults=disconnect@1.5*", 2)
    code = s.run(ScriptedResponder())
    events = read_json_lines(s.directory / "events.jsonl")
    assert code == 1 and s.hooks.n <= 8, (s.hooks.n, out.getvalue())
    stop = next(e for e in events if e["event"] == "session_stopped")
    assert stop["reason"] == "2 consecutive faults", stop
    faults = [e for e in events if e["event"] == "display_fault"]
    assert len(faults) >= 2 and faults[-1]["trial_index"] == faults[-2]["trial_index"]
    assert all(e["fault_code"] == "LINK_LOST" for e in faults), faults
    assert not [e for e in events if e["event"] == "trial_given_up"]
    said = [ln for ln in out.getvalue().splitlines() if "stopped after" in ln]
    assert len(said) == 1 and "thermocue resume" in said[0], out.getvalue()


def test_a_trial_is_given_up_after_max_attempts_and_the_session_ends(tmp_path):
    # max_attempts 3 per trial (the default), 10 faults in a row allowed: every trial the
    # replayed disconnect cuts is given up after its 3rd attempt; the session goes on to its end
    # (or to the 10th fault in a row), never past 3 attempts of one trial
    s, out = _session(tmp_path, "emulator://?clock=virtual&faults=disconnect@1.5*", 10)
    code = s.run(ScriptedResponder())
    events = read_json_lines(s.directory / "events.jsonl")
    assert s.hooks.n <= 12, (s.hooks.n, out.getvalue())
    given = [(e["trial_index"], e["attempts"]) for e in events if e["event"] == "trial_given_up"]
    assert given and all(n == 3 for _, n in given), given
    for index, _ in given:
        tries = [e for e in events if e["event"] == "display_fault" and e["trial_index"] == index]
        assert len(tries) == 3 and all(e["fault_code"] == "LINK_LOST" for e in tries), tries
    assert out.getvalue().count("given up after 3 attempts") == len(given), out.getvalue()
    # the trial after a given-up one starts after a rewarm (a lost link's "at once, no rewarm"
    # is for the same trial again, never for the next one)
    for k, e in enumerate(events):
        if e["event"] == "trial_given_up":
            later = events[k + 1:]
            start = next((j for j, x in enumerate(later) if x["event"] == "trial_started"), None)
            if start is not None:
                assert any(x["event"] == "state" and x.get("to") == "rewarm"
                           for x in later[:start]), later[:start]
    end = events[-1]
    if code == 0:
        assert end["event"] == "session_finished" and end["n_given_up"] == len(given)
        assert end["n_completed"] == 4 - len(given)
    else:
        assert end["event"] == "session_stopped" and end["reason"] == "10 consecutive faults"
