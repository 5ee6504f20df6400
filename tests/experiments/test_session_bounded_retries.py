"""Bounded retries: a trial is attempted at most ``[contact] max_attempts`` times (default 3) in
one run, and a session stops after ``max_consecutive_faults`` faulted attempts in a row, on every
path (a reconnection's too); both are logged, and the session is resumable.

The attack: the in-process emulator with a disconnect on its clock. Each reconnection opens a new
emulator whose fault schedule replays, so every attempt of the trial is cut off the same way;
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


@pytest.mark.parametrize("max_faults, reason, n", [(2, "2 consecutive faults", 2),
                                                   (10, "failed attempts ([contact] max_attempts)", 3)])
def test_a_fault_that_replays_on_every_reconnection_stops_the_session(tmp_path, max_faults, reason, n):
    s, out = _session(tmp_path, "emulator://?clock=virtual&faults=disconnect@1.5", max_faults)
    code = s.run(ScriptedResponder())
    events = read_json_lines(s.directory / "events.jsonl")
    assert code == 1 and s.hooks.n <= 12, (s.hooks.n, out.getvalue())
    stop = next(e for e in events if e["event"] == "session_stopped")
    assert reason in stop["reason"], stop
    last = [e for e in events if e["event"] == "trial_started"][-1]["trial_index"]
    tries = [e for e in events if e["event"] == "display_fault" and e["trial_index"] == last]
    assert len(tries) == n and all(e["fault_code"] == "LINK_LOST" for e in tries), tries
    said = [ln for ln in out.getvalue().splitlines() if "stopped after" in ln]
    assert len(said) == 1 and "thermocue resume" in said[0], out.getvalue()
