"""Delivery needs evidence: a trial is ``ok`` only with telemetry covering the contact.

Attacks with a device that plays every trial to its end, answers STATUS truthfully, and never
streams a telemetry frame (or streams nothing but idle frames): before, 4 trials of 4 were ``ok``
with 0 frames and no tracking value. The rule is one function (trial_recording.evidence_fault)
applied by the thermocue driver, the TCS II backend and the session.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from _device_proxy import FrameProxy, start_emulator, stop
from experiments.display import open_display
from experiments.display.thermocue import messages as m
from experiments.display.trial_recording import TrialRecording, evidence_fault

T = np.arange(0, 0.5001, 0.01)


def _drop_telemetry(fr):
    # TELEMETRY shares its type with ARM's reply: a reply is the 4-byte one
    if fr.type == m.Msg.TELEMETRY and len(fr.payload) != m.COUNTER.size:
        return []
    return [(fr.seq, fr.type, fr.payload)]


def _idle_telemetry_only(fr):
    if fr.type == m.Msg.TELEMETRY and len(fr.payload) == m.TELEMETRY.size:
        vals = list(m.TELEMETRY.unpack(fr.payload))
        if vals[10] in (m.State.PLAYING, m.State.RECORDING):
            return []
    return [(fr.seq, fr.type, fr.payload)]


@pytest.mark.slow
@pytest.mark.parametrize("rewrite, mode", [(_drop_telemetry, "playback"),
                                           (_drop_telemetry, "record"),
                                           (_idle_telemetry_only, "playback")])
def test_a_device_that_plays_but_never_streams_gives_no_ok_trial(tmp_path, rewrite, mode):
    proc, path = start_emulator(tmp_path)
    try:
        with FrameProxy(path, rewrite) as dev, open_display(dev.path) as d:
            d.sim_sample()
            d.upload_profile(T, np.full(T.size, 31.0))
            played = []
            for _ in range(6):               # (a loaded machine may trip the device's watchdog:
                d.arm(mode, max_duration_s=0.5)  # only trials the device played are judged)
                d.sim_finger(press_after_s=0.05, hold_s=5.0)
                rec = d.run_trial(timeout_s=10.0)
                assert rec.status != "ok", rec
                if rec.end_reason in ("complete", "max_duration", "released"):
                    played.append(rec)
                if len(played) == 2:
                    break
                d.wait(0.05)
            st = d.status()
        assert played, "the device played no trial to its end"
        for rec in played:
            assert rec.status == "fault" and rec.fault_code == "NO_TELEMETRY", rec
            assert "no telemetry covering the contact" in rec.fault_message
        assert st.state == "IDLE"
    finally:
        stop(proc)


def test_the_rule_names_each_missing_evidence():
    ok = TrialRecording("ok", None, None, 1.0, 100, 0, 0.05, 0.1, "playback", "complete", 1.0, 0, 90)
    assert evidence_fault(ok) is None
    no_frames = TrialRecording("ok", None, None, 1.0, 0, 0, math.nan, math.nan)
    assert evidence_fault(no_frames)[0] == "NO_TELEMETRY"
    idle_only = TrialRecording("ok", None, None, 1.0, 80, 0, math.nan, math.nan, contact_frames=0)
    assert evidence_fault(idle_only)[0] == "NO_TELEMETRY"
    no_track = TrialRecording("ok", None, None, 1.0, 80, 0, math.nan, math.nan, contact_frames=50)
    assert evidence_fault(no_track)[0] == "NO_TRACKING"
    record = TrialRecording("ok", None, None, 1.0, 80, 0, math.nan, math.nan, "record",
                            contact_frames=50)
    assert evidence_fault(record) is None          # record mode has no target to track
    lossy = TrialRecording("ok", None, None, 1.0, 95, 5, 0.05, 0.1, contact_frames=90)
    assert evidence_fault(lossy)[0] == "TELEMETRY_LOSS"
