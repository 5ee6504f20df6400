"""Every temperature a TCS II reports is a safety input.

Attacks on the TCS II emulator (a zone's driver stuck at full heating towards 55 °C during a
trial; a stimulation that goes on at 50 °C for 14 s after a completed trial): before, the first
was stopped only at the profile's end and the second noticed only when the next arm timed out.
Now each is stopped at once (``A``, verified) and the trial (or the next one) faults with a code.
"""
from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from experiments.display import open_display
from experiments.display.safety import SafetyLimits
from experiments.display.tcs2.watch import OVER_MARGIN_C, RETURN_S
from experiments.emulators.pty_server import serve_tcs2
from experiments.errors import DisplayError

LIMITS = SafetyLimits(min_C=15.0, max_C=42.0, max_rate_C_per_s=10.0, neutral_C=32.0)
T = np.arange(0, 5.0001, 0.01)                 # a 5 s profile
Y = np.full(T.size, 32.0)


@pytest.mark.slow
def test_55_C_during_a_trial_is_stopped_at_once_on_a_real_pty(tmp_path):
    link = tmp_path / "tcs2"
    ready, stopping = threading.Event(), threading.Event()
    th = threading.Thread(target=serve_tcs2, kwargs=dict(
        link=str(link), faults="overheat@1:0.5:2", announce=lambda p: ready.set(),
        stop=stopping.is_set), daemon=True)
    th.start()
    assert ready.wait(10)
    try:
        with open_display(f"tcs2://{link}", LIMITS) as d:
            d.upload_profile(T, Y)
            d.arm(max_duration_s=10.0)
            frames = []
            rec = d.run_trial(timeout_s=20.0, on_telemetry=frames.append)
            assert rec.status == "fault" and rec.fault_code == "OVER_TEMPERATURE", rec
            assert "zone 2" in rec.fault_message and "verified" in rec.fault_message
            assert "NOT verified" not in rec.fault_message
            # stopped within the lines of the first reading above the maximum, not at 5 s
            assert len(frames) * 0.01 < 2.0, len(frames)
            assert max(f.contact_C for f in frames) <= 42.0 + OVER_MARGIN_C + 3.0
            d.link.drain(0.05)
            (line,) = d.link.ask("Oe")
            temps = [int(v) / 100 for v in line.split("+")]
            assert max(temps[1:]) <= 42.0, temps           # back down after A
    finally:
        stopping.set()
        th.join(5)


@pytest.mark.slow
def test_a_stimulation_going_on_after_the_trial_is_stopped_by_the_idle_watch():
    with open_display("tcs2://emulator?clock=real&faults=runon@1:0", LIMITS) as d:
        dev = d.port.device
        t = np.arange(0, 0.5001, 0.01)
        d.upload_profile(t, np.full(t.size, 32.0))
        d.arm(max_duration_s=5.0)
        rec = d.run_trial(timeout_s=10.0)
        assert rec.status == "ok", rec                     # the trial itself was delivered
        ended = time.monotonic()
        hottest = 0.0
        while time.monotonic() - ended < 7.0:              # the device heats towards 50 °C ...
            hottest = max(hottest, max(dev.temps))
            if d.idle_fault is not None:
                break
            time.sleep(0.02)
        stopped_after_s = time.monotonic() - ended
        # ... and is stopped once the watch reads it, not after its 14 s run-on (the watch
        # asks every 0.25 s; 7 s leaves a loaded machine room and is half the run-on)
        assert hottest > 42.0                              # the attack happened
        assert d.idle_fault is not None and d.idle_fault[0] == "OVER_TEMPERATURE", d.idle_fault
        assert "verified" in d.idle_fault[1] and "NOT verified" not in d.idle_fault[1]
        assert dev.state == "idle" and stopped_after_s < 7.0
        with pytest.raises(DisplayError) as exc:           # the next trial faults with the code
            d.arm(max_duration_s=5.0)
        assert getattr(exc.value, "code", None) == "OVER_TEMPERATURE"
        d.arm(max_duration_s=5.0)                          # once said, the display goes on
        assert d.run_trial(timeout_s=10.0).status == "ok"


def test_a_zone_held_off_neutral_while_idle_is_a_stimulation_still_running():
    with open_display("tcs2://emulator?clock=virtual", LIMITS) as d:
        dev = d.port.device
        dev.state, dev.setpoints = "runon", [38.0] * 5     # 38 °C: under the maximum, not neutral
        dev._runon_until = 1e9
        d.link.line(0.2)                                   # (virtual time passes as the host reads)
        d.check_idle()
        assert d.idle_fault is None                        # a return to neutral takes a moment
        d.link.line(RETURN_S + 0.2)
        d.check_idle()
        assert d.idle_fault is not None and d.idle_fault[0] == "STIMULATION_RUNNING", d.idle_fault
        assert dev.state == "idle"
