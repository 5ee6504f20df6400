"""A lost link (the display unplugged): the attempt ends at once, one reconnect is tried, and
the session stops (or goes on) without a rewarm or another request to place the sample.

The display is ``thermocue emulator`` on a real pty in its own process; "unplugging" it is
ending that process while the runner's trial plays (a test hook at the first frame in contact).
"""
from __future__ import annotations

import io
import subprocess
import sys
import time

import pytest

from _session_helpers import P01, ScriptedResponder, read_json_lines, write_protocol
from experiments.session import create_session
from experiments.session.hooks import SessionHooks

pytestmark = pytest.mark.slow

THERMOCUE = [sys.executable, "-m", "experiments"]


def _emulator(link):
    proc = subprocess.Popen(THERMOCUE + ["emulator", "--link", str(link), "--clock", "virtual"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 30
    while not link.exists():
        assert proc.poll() is None and time.monotonic() < deadline, "emulator did not start"
        time.sleep(0.05)
    return proc


def _stop(proc) -> None:
    if proc.poll() is None:
        proc.terminate()
        proc.wait(timeout=10)


class Unplug(SessionHooks):
    """At the first frame in contact of ``trial_index``'s first attempt: end the emulator
    (optionally start another on the same link: the display plugged in again)."""

    def __init__(self, state, trial_index, replug=False):
        self.state, self.trial_index, self.replug = state, trial_index, replug

    def at(self, point, spec, attempt):
        if point == "playback" and spec.trial_index == self.trial_index and attempt == 1:
            _stop(self.state["emulator"])
            deadline = time.monotonic() + 10
            while self.state["link"].exists() and time.monotonic() < deadline:
                time.sleep(0.02)
            if self.replug:
                self.state["emulator"] = _emulator(self.state["link"])


def _run(tmp_path, replug):
    proto = write_protocol(tmp_path, contact_s=0.5, rewarm_s=0.0, real_samples=(1, 2),
                           sim_samples=(3, 4))
    link = tmp_path / "pty"
    state = {"link": link, "emulator": _emulator(link)}
    out = io.StringIO()
    try:
        s = create_session(proto, P01, tmp_path / "data", str(link), seed=4, clock="virtual",
                           out=out)
        s.hooks = Unplug(state, trial_index=2, replug=replug)
        code = s.run(ScriptedResponder())
    finally:
        _stop(state["emulator"])
    return s, code, out.getvalue(), read_json_lines(s.directory / "events.jsonl")


def test_a_lost_link_that_stays_lost_stops_the_session_at_once(tmp_path):
    s, code, out, events = _run(tmp_path, replug=False)
    assert code == 1
    fault = next(e for e in events if e["event"] == "display_fault")
    later = [e for e in events if e["seq"] > fault["seq"]]
    after = [e["event"] for e in later]
    assert fault["trial_index"] == 2 and fault["fault_code"] == "LINK_LOST"
    # one attempt only: no second trial_started, no placement, no rewarm after the fault
    assert [e for e in events if e["event"] == "trial_started" and e["trial_index"] == 2] \
        and len([e for e in events if e["event"] == "trial_started"]) == 2
    assert "sample_placed" not in after and "trial_started" not in after
    assert not any(e["event"] == "state" and e.get("to") == "rewarm" for e in later)
    assert sum(1 for e in later if e["event"] == "display_error" and e.get("step") == "reconnect") == 1
    stop = next(e for e in events if e["event"] == "session_stopped")
    assert stop["reason"] == "display link lost"
    # one clean message: the stop line, once, without a repeated "display:" prefix
    lines = [ln for ln in out.splitlines() if ln.strip()]
    lost = [ln for ln in lines if "link" in ln]
    assert len(lost) == 1 and lost[0].startswith("thermocue: stopped: the display's link was lost ("), out
    assert "display: display" not in out and lost[0].count("display:") == 0, out
    assert lost[0].count("link was lost") == 1 and "link lost" not in lost[0], out
    assert "thermocue resume" in lost[0]
    rows = {(r["trial_index"], r["attempt"]): r["status"] for r in
            (e["row"] | {"trial_index": e["trial_index"], "attempt": e["attempt"]}
             for e in events if e["event"] == "trial_completed")}
    assert rows == {(1, 1): "ok", (2, 1): "fault"}


def test_a_lost_link_that_comes_back_reruns_the_trial_without_a_rewarm(tmp_path):
    s, code, out, events = _run(tmp_path, replug=True)
    assert code == 0, out
    fault = next(e for e in events if e["event"] == "display_fault")
    assert fault["fault_code"] == "LINK_LOST"
    again = [e for e in events if e["event"] == "display_reconnected"]
    assert len(again) == 1 and again[0]["trial_index"] == 2
    rows = [(e["trial_index"], e["attempt"], e["row"]["status"]) for e in events
            if e["event"] == "trial_completed"]
    assert rows == [(1, 1, "ok"), (2, 1, "fault"), (2, 2, "ok"), (3, 1, "ok"), (4, 1, "ok")]
    lost = [ln for ln in out.splitlines() if "link" in ln]
    assert len(lost) == 1 and "connected again" in lost[0] and "display:" not in lost[0], out
