"""``ThermalDisplay.poll``: a trial driven from the caller's own loop (PsychoPy's frame loop).

The in-process emulator on its real clock, so the trial takes its real 1.5 s while the test's
loop does something else between polls, as a window's frame loop would.
"""
from __future__ import annotations

import time

import numpy as np
import pytest

from experiments.display import open_display

T = np.arange(0, 1.5, 0.01)
PROFILE = 32.0 - 3.5 * np.sqrt(T / 1.5)     # 32 -> 28.5 °C (9 °C/s over its first 0.1 s)


@pytest.fixture
def real_clock_display():
    d = open_display("emulator://?seed=7")
    yield d
    d.close()


def test_poll_runs_a_trial_without_blocking(real_clock_display):
    d = real_clock_display
    d.upload_profile(T, PROFILE)
    d.arm("playback", force_threshold_N=2.0, max_duration_s=10.0)
    d.sim_finger(press_after_s=0.1, force_N=2.5, hold_s=5.0)
    frames, events, polls, took = [], [], 0, []
    deadline = time.monotonic() + 15.0
    ended = False
    while not ended and time.monotonic() < deadline:
        t0 = time.monotonic()
        ended = d.poll(on_telemetry=frames.append, on_event=events.append)
        took.append(time.monotonic() - t0)
        polls += 1
        time.sleep(1 / 60)                       # a frame of the caller's loop
    assert ended
    rec = d.run_trial(timeout_s=5.0)             # collects the recording at once
    assert rec.status == "ok" and rec.end_reason == "complete"
    assert [e.kind for e in events][:2] == ["READY", "CONTACT"]
    assert rec.contact_time_s == events[1].device_time_s
    assert rec.frames == len(frames) and rec.frames_lost == 0
    assert rec.tracking_rms_C < 0.05
    # polling never waits for bytes: a waiting read would take its 10 ms timeout on every call;
    # the median call takes far less (the median, so that a call pre-empted by another process
    # on a loaded machine does not decide)
    assert polls > 10 and float(np.median(took)) < 0.005     # (about 95 calls on a quiet machine)
    assert d.status().state == "IDLE"


def test_poll_without_a_trial_keeps_the_link_alive(real_clock_display):
    d = real_clock_display
    assert d.poll() is False
    assert d.is_awake()


def test_abort_during_polling_ends_the_trial_as_aborted(real_clock_display):
    d = real_clock_display
    d.upload_profile(T, PROFILE)
    d.arm("playback", force_threshold_N=2.0, max_duration_s=10.0)
    d.sim_finger(press_after_s=0.1, force_N=2.5, hold_s=5.0)
    deadline = time.monotonic() + 10.0
    while d.status().state != "PLAYING" and time.monotonic() < deadline:
        d.poll()
        time.sleep(0.01)
    t_play = time.monotonic()
    while time.monotonic() - t_play < 0.5:       # half a second into the profile
        d.poll()
        time.sleep(0.01)
    assert d.status().setpoint_C < 31.0
    d.abort()
    assert d.poll() is True
    rec = d.run_trial(timeout_s=2.0)
    assert rec.status == "aborted" and rec.contact_time_s is not None
    deadline = time.monotonic() + 1.0            # the firmware slews back at <= 1 °C a tick
    while d.status().setpoint_C != 32.0 and time.monotonic() < deadline:
        time.sleep(0.01)
    st = d.status()
    assert st.state == "IDLE" and st.setpoint_C == 32.0


def test_events_before_the_callback_is_attached_are_replayed_in_order(real_clock_display):
    """READY (and even CONTACT) may arrive while the caller is still drawing its cue, before it
    attaches ``on_event``: they reach the callback first, not lost."""
    d = real_clock_display
    d.upload_profile(T, PROFILE)
    d.arm("playback", force_threshold_N=2.0, max_duration_s=10.0)
    d.sim_finger(press_after_s=0.2, force_N=2.5, hold_s=5.0)
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline and d.link.trial.contact_s is None:
        d.poll()                                  # routes frames and events; no callbacks yet
        time.sleep(0.01)
    assert d.link.trial.contact_s is not None, "no contact within 10 s"
    events = []
    rec = d.run_trial(timeout_s=10.0, on_event=events.append)
    assert rec.status == "ok"
    kinds = [e.kind for e in events]
    assert kinds[:2] == ["READY", "CONTACT"] and kinds[-1] == "END"
    assert events[1].device_time_s == rec.contact_time_s
