"""The tcs2:// backend against the TCS II emulator: handshake, upload, trials, every fault path."""
from __future__ import annotations

import os

import numpy as np
import pytest

from experiments.errors import DisplayError, SafetyLimitError, UserInputError
from experiments.display import open_display
from experiments.display.registry import backend_for
from experiments.display.safety import SafetyLimits
from experiments.display.tcs2.backend import Tcs2Display

LIMITS = SafetyLimits(min_C=15.0, max_C=42.0, max_rate_C_per_s=10.0, neutral_C=35.5)
T = np.arange(501) * 0.01
Y = np.interp(T, [0, 1, 2, 5], [35.5, 30.0, 30.0, 33.0])


def _open(query="", limits=LIMITS):
    sep = "&" if query else ""
    return open_display(f"tcs2://emulator?clock=virtual{sep}{query}", limits)


def _temps_sent(commands):
    """Every temperature the host sent (N, C, Om, Uw ends), °C."""
    out = []
    for c in commands:
        if c[0] == "N" and c[1:].isdigit():
            out.append(int(c[1:]) / 10)
        elif c[0] == "C" and c[1:].isdigit():
            out.append(int(c[2:]) / 10)
        elif c.startswith("Uw"):
            body = c[10:]
            out += [int(body[i + 3:i + 6]) / 10 for i in range(0, len(body), 6)]
    return out


def test_registered_with_its_capabilities():
    assert backend_for("tcs2:///dev/ttyACM0") is Tcs2Display
    caps = Tcs2Display.declared_capabilities()
    assert caps.modes == ("playback",) and caps.contact_detection == "stimulus_start"
    assert not caps.force_sensing


def test_handshake_sets_the_maximum_first_and_reads_everything_back():
    d = _open()
    try:
        cmds = d.port.device.commands
        first_setting = next(i for i, c in enumerate(cmds) if c[0] in "NCSU" or c.startswith("Om"))
        assert cmds[first_setting] == "Om420"
        assert cmds.index("?") < first_setting and cmds.index("H") < first_setting
        assert d.info.device_id and d.info.firmware and d.max_C == 42.0 and d.neutral_C == 35.5
        dev = d.port.device
        assert (dev.max_dC, dev.neutral_dC, dev.zones) == (420, 355, (1, 1, 1, 1, 1))
    finally:
        d.close()


def test_a_device_holding_another_maximum_is_refused():
    with pytest.raises(DisplayError) as exc:
        _open("faults=om_cap%3D40")
    msg = str(exc.value)
    assert "\n" not in msg and "maximum" in msg and "40" in msg and "tcs2://emulator" in msg


def test_a_device_that_is_not_a_tcs_is_refused():
    # loop:// echoes: '?' comes back as '?', not 'TCS'
    with pytest.raises(DisplayError) as exc:
        open_display("tcs2://loop://", LIMITS)
    assert "'?' reply" in str(exc.value) and "not using this device" in str(exc.value)


def test_a_silent_device_on_a_real_pty_is_refused_in_time():
    master, slave = os.openpty()
    try:
        with pytest.raises(DisplayError) as exc:
            open_display(f"tcs2://{os.ttyname(slave)}", LIMITS)
        assert "no reply to '?'" in str(exc.value)
    finally:
        os.close(master)
        os.close(slave)


@pytest.mark.parametrize("url", ["tcs2://", "tcs2://emulator?colour=red", "tcs2:///dev/x?clock=virtual",
                                 "tcs2://emulator?zones=7", "tcs2://emulator?tolerance_C=-1"])
def test_malformed_urls_are_user_errors(url):
    with pytest.raises(UserInputError):
        Tcs2Display.check_url(url)


def test_upload_is_read_back_and_reports_its_error():
    d = _open()
    try:
        r = d.upload_profile(T, Y)
        assert r.segments == 3 and r.max_deviation_C <= 0.1 + 1e-9 and r.points == 501
        assert d.port.device.profile[1] == tuple((s.steps, s.end_dC) for s in d.compiled.segments)
    finally:
        d.close()


def test_a_profile_held_otherwise_is_refused():
    d = _open()
    try:
        dev = d.port.device
        real = dev._upload
        dev._upload = lambda c: real(c[:-3] + "300")      # the last end held as 30.0 °C
        with pytest.raises(DisplayError) as exc:
            d.upload_profile(T, Y)
        assert "Ur" in str(exc.value)
        assert dev.profile_zones == (0, 0, 0, 0, 0) and dev.commands[-1] == "A"
        with pytest.raises(UserInputError):        # nothing to arm with
            d.arm()
    finally:
        d.close()


def test_nothing_above_the_maximum_is_ever_sent():
    d = _open()
    try:
        before = list(d.port.device.commands)
        with pytest.raises(SafetyLimitError):
            d.upload_profile(T, np.where(T > 1, 42.5, 35.5))
        with pytest.raises(SafetyLimitError):
            d.set_neutral(43.0)
        assert d.port.device.commands == before
        d.upload_profile(T, Y)
        d.arm()
        d.run_trial()
        assert max(_temps_sent(d.port.device.commands)) <= 42.0
    finally:
        d.close()


def test_a_trial_streams_100_Hz_and_is_ok():
    d = _open()
    try:
        d.upload_profile(T, Y)
        d.arm()
        frames, events = [], []
        rec = d.run_trial(on_telemetry=frames.append, on_event=events.append)
        assert rec.status == "ok" and rec.end_reason == "complete"
        assert rec.frames == len(frames) == 500 and rec.frames_lost == 0
        assert rec.contact_time_s == frames[0].device_time_s
        assert np.allclose(np.diff([f.device_time_s for f in frames]), 0.01)
        assert rec.tracking_max_C < 0.5
        assert [e.kind for e in events] == ["CONTACT", "END"]
        assert "Q" in d.port.device.commands[d.port.device.commands.index("L"):]
    finally:
        d.close()


@pytest.mark.parametrize("fault, code", [
    ("zone@1:2.0", "ZONE_ERROR"), ("garbage@1:1.0", "BAD_REPLY"), ("unknown@1:1.0", "BAD_REPLY"),
    ("halfline@1:1.0", "HALF_LINE"), ("silent@1:1.0", "LINK_TIMEOUT"),
    ("disconnect@1:1.0", "LINK_LOST"), ("drop=0.05", "TELEMETRY_LOSS")])
def test_every_fault_aborts_to_neutral_and_flags_the_trial(fault, code):
    d = _open("faults=" + fault.replace("@", "%40").replace(":", "%3A").replace("=", "%3D"))
    try:
        d.upload_profile(T, Y)
        d.arm()
        rec = d.run_trial()
        assert rec.status == "fault" and rec.fault_code == code
        assert rec.fault_message and "\n" not in rec.fault_message
        dev = d.port.device
        if code not in ("LINK_LOST", "TELEMETRY_LOSS", "LINK_TIMEOUT"):
            after = dev.commands[dev.commands.index("L"):]
            assert "A" in after and dev.state == "idle"
    finally:
        d.close()


def test_the_emulated_participant_stops_early_and_the_trial_counts():
    d = _open()
    try:
        d.upload_profile(T, Y)
        d.arm()
        d.sim_finger(press_after_s=0.5, hold_s=2.0)
        rec = d.run_trial()
        assert rec.status == "ok" and rec.end_reason == "released"
        assert 1.9 <= rec.duration_s <= 2.2
    finally:
        d.close()


def test_start_on_the_trigger_input():
    d = _open("start=trigger")
    try:
        d.upload_profile(T, Y)
        d.arm()
        d.sim_finger(press_after_s=0.2, hold_s=20.0)
        rec = d.run_trial()
        assert rec.status == "ok" and "#T" in d.port.device.commands
        assert "L" not in d.port.device.commands
        d.arm()                           # nobody pulses the trigger: no contact, aborted
        rec = d.run_trial(timeout_s=1.0)
        assert rec.status == "aborted" and rec.contact_time_s is None
    finally:
        d.close()


def test_poll_then_run_trial_as_the_psychopy_device_does():
    d = _open()
    try:
        d.upload_profile(T, Y)
        d.arm()
        events = []
        for _ in range(100000):
            if d.poll(on_event=events.append):
                break
        rec = d.run_trial(timeout_s=1.0)
        assert rec.status == "ok" and events[0].kind == "CONTACT" and d.is_awake()
    finally:
        d.close()


def test_record_mode_is_refused():
    d = _open()
    try:
        with pytest.raises(UserInputError):
            d.arm(mode="record")
        with pytest.raises(DisplayError):
            d.sim_sample()
    finally:
        d.close()


def test_the_maximum_duration_stops_a_longer_profile():
    d = _open()
    try:
        d.upload_profile(T, Y)
        d.arm(max_duration_s=2.0)
        rec = d.run_trial()
        assert rec.status == "ok" and rec.end_reason == "max_duration" and rec.frames == 200
        dev = d.port.device
        assert dev.commands[-1] == "A" and dev.state == "idle"
    finally:
        d.close()


def test_a_zone_still_in_error_faults_the_next_trial_before_it_starts():
    d = _open("faults=zone%401%3A1.0")
    try:
        d.upload_profile(T, Y)
        d.arm()
        assert d.run_trial().fault_code == "ZONE_ERROR"
        n = len(d.port.device.commands)
        d.arm()
        rec = d.run_trial()
        assert rec.fault_code == "ZONE_ERROR" and rec.contact_time_s is None
        assert "L" not in d.port.device.commands[n:]
    finally:
        d.close()


def test_a_device_error_reply_to_the_upload_refuses_it():
    d = _open()
    try:
        d.port.device._upload = lambda c: ["ERR Uw malformed: " + c[:20]]
        with pytest.raises(DisplayError) as exc:
            d.upload_profile(T, Y)
        assert "ERR Uw" in str(exc.value) and "\n" not in str(exc.value)
        assert d.compiled is None and d.port.device.commands[-1] == "A"
    finally:
        d.close()


def test_a_reply_to_Q_still_on_its_way_at_the_end_is_not_taken_for_the_next_reply():
    # the participant stops the stimulation just after a Q was sent: its reply comes late
    d = _open()
    try:
        d.upload_profile(T, Y)
        for hold in (0.505, 1.005, 1.51):
            d.arm()
            d.sim_finger(press_after_s=0.0, hold_s=hold)
            assert d.run_trial().status == "ok"
            d.port.device._out += b"000000\r\n"       # a late reply, as a slow link delivers it
            r = d.upload_profile(T, Y)                  # Ur must still read its own lines
            assert r.segments == 3
    finally:
        d.close()
