"""The display protocol's conformance suite, written once, run on every backend.

Black-box: each test drives a device through the protocol only (the driver, or frames by hand)
and checks what ``docs/display-protocol.md`` promises -- the handshake's numbers, the upload's
receipts, a contact and its playback, 100 Hz telemetry, ABORT, the watchdog, latched faults,
restart detection, the NO_HELLO rule, retries answered from the reply store, the device's own
clamps and rate window. Expected values come from the spec and from the test's own inputs,
never from the backend under test. Backends: ``conftest.py``.
"""
from __future__ import annotations

import struct
import time
import zlib

import numpy as np
import pytest

from experiments.errors import DisplayFaultLatched, DisplayRefused, DisplayRestarted
from experiments.display.thermocue import messages as m

SPEC_MAX_TRACKING_C = 1.0      # [simulation] max_tracking_error_C's default (§4)


def wait_device_time(display, t_s, limit_s=20.0):
    """Keep the link alive until the device's clock reads ``t_s`` (s) or ``limit_s`` pass."""
    deadline = time.monotonic() + limit_s
    while display.status().device_time_s < t_s and time.monotonic() < deadline:
        display.wait(0.02)


def ramp_profile(duration_s=0.6, start_C=32.0, slope_C_per_s=5.0, step_s=0.001):
    t = np.arange(0.0, duration_s, step_s)
    return t, start_C + slope_C_per_s * t


# ---------------------------------------------------------------------------- handshake
def test_handshake_declares_the_protocols_numbers(display):
    info = display.hello                           # the HELLO reply as the protocol has it
    assert info.protocol == 2
    assert info.telemetry_hz == 100
    assert info.watchdog_ms == 90                  # §6: 90 ms + one 10 ms tick = 100 ms
    assert info.hard_min_C >= 10.0 and info.hard_max_C <= 44.5
    assert 0 < info.max_rate_C_per_s <= 100.0
    assert info.min_dt_s >= 0.001 and info.max_points * 0.001 >= 30.0   # ≥ 30 s at 1 ms
    assert info.boot_id != 0
    assert {"playback", "record", "sim"} <= set(info.capabilities)


def test_declared_capabilities_match_the_handshake(display, backend):
    """What ``thermocue displays`` says before opening equals what the device says."""
    declared = type(display).declared_capabilities()
    got = display.capabilities
    if backend == "emulator-c":
        # emulator:// declares its default core's numbers; core=c is the firmware's own core,
        # whose profile memory is the MCU's (config.h FW_MAX_POINTS): fewer points, never more
        assert got.max_profile_points == 32768 < declared.max_profile_points
    else:
        assert declared.max_profile_points == got.max_profile_points
    assert declared.safe_range_C == got.safe_range_C
    assert declared.max_rate_C_per_s == got.max_rate_C_per_s
    assert declared.telemetry_hz == got.telemetry_hz


# ---------------------------------------------------------------------------- upload
def test_upload_receipt_carries_the_profiles_crc32(display):
    t, y = ramp_profile(0.5, 32.0, 2.0)
    receipt = display.upload_profile(t, y)
    q = np.round(y * 100).astype("<i2")
    assert receipt.points == len(t)
    assert receipt.crc32 == zlib.crc32(q.tobytes())
    assert receipt.clamped == 0
    assert receipt.max_deviation_C <= 0.005 + 1e-9


# ---------------------------------------------------------------------------- a trial
@pytest.fixture(scope="module")
def played(shared_display):
    """One playback trial: a 0.6 s ramp 32 -> 35 °C, the finger pressing 0.2 s after READY."""
    d = shared_display
    if d.status().state == "FAULT":
        d.clear_fault()
    d.abort()
    d.set_neutral(32.0)
    t, y = ramp_profile(0.6, 32.0, 5.0)
    d.upload_profile(t, y)
    d.arm("playback", force_threshold_N=2.0, max_duration_s=5.0)
    d.sim_finger(press_after_s=0.2, force_N=2.0, hold_s=3.0)
    tel, events = [], []
    rec = d.run_trial(timeout_s=10.0, on_telemetry=tel.append, on_event=events.append)
    return dict(rec=rec, telemetry=tel, events=events, status=d.wire_status(), profile=(t, y))


def test_contact_starts_playback_and_the_trial_is_delivered(played):
    rec, st = played["rec"], played["status"]
    assert rec.status == "ok", (rec.fault_code, rec.fault_message)
    assert rec.end_reason == "complete"
    assert st.state == "IDLE" and st.end_reason == 0
    assert st.contact_time_s is not None and st.contact_time_s == pytest.approx(rec.contact_time_s)
    kinds = [e.kind for e in played["events"]]
    # (READY may come before run_trial attaches its callback: events are sent once)
    assert kinds.count("READY") <= 1 and kinds.count("CONTACT") == 1 and kinds[-1] == "END"
    # the contact frame: summed force at or above the 2 N threshold
    contact = next(e for e in played["events"] if e.kind == "CONTACT")
    at = [f for f in played["telemetry"] if abs(f.device_time_s - contact.device_time_s) < 1e-6]
    assert at and sum(at[0].forces_N) >= 2.0 - 0.01


def test_playback_tracks_the_profile(played):
    rec = played["rec"]
    assert rec.tracking_max_C < SPEC_MAX_TRACKING_C
    playing = [f for f in played["telemetry"] if f.state == "PLAYING"]
    t0 = played["rec"].contact_time_s
    t, y = played["profile"]
    # the setpoint follows the uploaded ramp (5 °C/s: within the 10 °C/s default limit)
    for f in playing[5:]:
        assert f.setpoint_C == pytest.approx(np.interp(f.device_time_s - t0, t, y), abs=0.06)


def test_telemetry_is_100_hz_without_loss(played):
    tel = played["telemetry"]
    counters = [f.counter for f in tel]
    assert counters == list(range(counters[0], counters[0] + len(counters)))
    times = np.array([f.device_time_s for f in tel])
    dt = np.diff(times)
    assert np.median(dt) == pytest.approx(0.010, abs=0.0005)
    rate = (len(tel) - 1) / (times[-1] - times[0])
    assert 95.0 <= rate <= 105.0


# ---------------------------------------------------------------------------- abort
def test_arm_resets_the_last_trials_account_and_abort_ends_it(played, display):
    """Requirement 7: STATUS's contact time and end reason describe the last armed trial."""
    assert played["status"].contact_time_s is not None       # the trial before had a contact
    t, y = ramp_profile(0.5, 32.0, 2.0)
    display.upload_profile(t, y)
    display.arm("playback", 2.0, 5.0)
    st = display.wire_status()
    assert st.state == "ARMED" and st.contact_time_s is None and st.end_reason == 0
    display.abort()
    st = display.wire_status()
    assert st.state == "IDLE" and st.end_reason == 3 and st.contact_time_s is None


def test_a_contact_needs_a_fresh_touch(display):
    """Requirement 6: a finger already pressing at ARM is no contact until it has let go."""
    display.sim_finger(press_after_s=0.0, force_N=2.0, hold_s=3.0)   # pressing before ARM
    t0 = display.status().device_time_s
    wait_device_time(display, t0 + 0.4)
    display.arm("record", force_threshold_N=2.0, max_duration_s=5.0)
    wait_device_time(display, t0 + 1.0)          # ready (record: 0.1 s), the finger still on
    st = display.status()
    assert st.state == "ARMED" and st.contact_time_s is None
    assert sum(st.forces_N) > 1.5                # pressing (≈ 2 N), not a fresh touch
    display.sim_finger(press_after_s=0.6, force_N=2.0, hold_s=0.5)   # lets go, presses again
    rec = display.run_trial(timeout_s=10.0)
    assert rec.status == "ok" and rec.end_reason == "released"
    assert display.status().contact_time_s > t0 + 1.0


# ---------------------------------------------------------------------------- host loss
# (the watchdog on host loss is thermocue check's check_watchdog: test_qualification.py)


# ---------------------------------------------------------------------------- faults
def test_over_temperature_is_latched_until_operator_reset(display):
    """The heater stuck at full current during an armed trial: the trip acts below 45 °C, the
    trial is not delivered, FAULT stays through ABORT until the operator's reset (§6)."""
    t = np.arange(0.0, 2.0, 0.01)
    display.upload_profile(t, np.full_like(t, 32.0))
    display.arm("playback", 2.0, 5.0)
    fault_ends_s = display.sim_fault("overtemp+2")["now_s"] + 2.0   # heater stuck at full, 2 s
    tel = []
    rec = display.run_trial(timeout_s=3.0, on_telemetry=tel.append)
    assert rec.status != "ok"
    st = display.wire_status()
    assert st.state == "FAULT" and st.last_fault == "OVER_TEMPERATURE" and st.end_reason == 4
    assert tel[-1].state == "FAULT" and tel[-1].fault == "OVER_TEMPERATURE"
    # the pad above the 45 °C hard maximum for at most one 10 ms tick (§6)
    assert sum(f.contact_C > 45.0 for f in tel) <= 1
    display.abort()                               # ABORT never clears it
    assert display.status().state == "FAULT"
    with pytest.raises(DisplayRefused) as exc:
        display.arm("record", 2.0, 5.0)
    assert "FAULT_LATCHED" in str(exc.value)
    wait_device_time(display, fault_ends_s + 0.1)  # the stuck heater is gone
    display.clear_fault()                         # the operator's reset
    assert display.status().state == "IDLE"


def test_stuck_contact_sensor_is_latched(display):
    fault_ends_s = display.sim_fault("stuck_sensor+0.5")["now_s"] + 0.5
    wait_device_time(display, fault_ends_s + 0.1)   # 20 identical readings take 0.1 s
    st = display.wire_status()
    assert st.state == "FAULT" and st.last_fault == "SENSOR_STUCK"
    display.abort()
    assert display.status().state == "FAULT"
    # a host connecting now is refused at the handshake, before any limits are sent
    with pytest.raises(DisplayFaultLatched) as exc:
        display.handshake()
    assert exc.value.code == "SENSOR_STUCK" and "clear-fault" in str(exc.value)
    display.clear_fault()
    assert display.status().state == "IDLE"
    display.handshake()                           # the shared display's limits and neutral again
    assert display.status().state == "IDLE"


def test_restart_is_detected_and_a_new_boot_id_drawn(fresh_display):
    """Requirement 5 and the host's side of a restart (§6): a power cycle is seen as one."""
    d = fresh_display
    boot = d.hello.boot_id
    wait_device_time(d, 1.0)
    before_s = d.status().device_time_s
    injected = time.monotonic()                  # before the command: the device's 0.1 s starts
    d.sim_fault("reboot@0.1")                     # when it handles it, after this
    with pytest.raises(DisplayRestarted):
        deadline = time.monotonic() + 10.0           # the device's 0.1 s, however slow it runs
        while time.monotonic() < deadline:
            d.status()
            time.sleep(0.05)
    d.handshake()                                 # a resume shakes hands again
    assert d.hello.boot_id != boot
    after_s = d.status().device_time_s
    # device time restarted from 0 (a device clock never runs faster than the wall clock)
    assert after_s <= time.monotonic() - injected + 0.05 and before_s >= 1.0


# ---------------------------------------------------------------------------- raw frames
def _hello(raw, seq):
    fr = raw.command(seq, m.Cmd.HELLO, m.HELLO_REQ.pack(2))
    assert fr is not None and fr.type == 0x81
    return fr


def test_no_hello_refuses_all_but_the_safe_commands(raw):
    """Requirement 2: before a HELLO only HELLO, HEARTBEAT, STATUS, ABORT, CLEAR_FAULT."""
    for seq, cmd, payload in ((10, m.Cmd.SET_LIMITS, m.LIMITS.pack(1500, 4200, 1000)),
                              (11, m.Cmd.SET_NEUTRAL, m.CENTI.pack(3000)),
                              (12, m.Cmd.UPLOAD_BEGIN, m.UPLOAD_BEGIN.pack(10, 10000)),
                              (13, m.Cmd.ARM, m.ARM.pack(1, 200, 5000))):
        fr = raw.command(seq, cmd, payload)
        assert fr is not None and fr.type == 0xFF
        assert m.NAK_HEAD.unpack_from(fr.payload) == (cmd, m.Err.NO_HELLO)
    for seq, cmd in ((20, m.Cmd.STATUS), (21, m.Cmd.HEARTBEAT), (22, m.Cmd.ABORT)):
        fr = raw.command(seq, cmd)
        assert fr is not None and fr.type == cmd | 0x80
    _hello(raw, 30)
    fr = raw.command(31, m.Cmd.SET_LIMITS, m.LIMITS.pack(1500, 4200, 1000))
    assert fr.type == 0x84 and m.LIMITS.unpack(fr.payload) == (1500, 4200, 1000)


def test_garbage_costs_only_the_frames_it_overlaps(raw):
    """§1: after random bytes (false markers and headers among them) the next frame is parsed."""
    from experiments.display.thermocue.framing import encode_frame
    rng = np.random.default_rng(4)
    _hello(raw, 1)
    for k in range(20):
        junk = rng.integers(0, 256, int(rng.integers(1, 40)), dtype=np.uint8).tobytes()
        if k % 3 == 0:
            junk += b"\xa5\x5a"                    # a marker whose header will not check
        if k % 5 == 0:
            junk += encode_frame(9, m.Cmd.STATUS)[:-1] + b"\x00"    # a bad CRC
        raw.port.write(junk)
        fr = raw.command(100 + k, m.Cmd.HEARTBEAT, timeout_s=2.0)
        assert fr is not None and fr.type == 0x82 and len(fr.payload) == 8


def test_retries_are_answered_from_the_store_and_hello_forgets_it(raw):
    _hello(raw, 1)
    fr = raw.command(7, m.Cmd.SET_NEUTRAL, m.CENTI.pack(3000))
    assert m.CENTI.unpack(fr.payload) == (3000,)
    fr = raw.command(7, m.Cmd.SET_NEUTRAL, m.CENTI.pack(3300))     # same seq: a retry
    assert fr.type == 0x83 and m.CENTI.unpack(fr.payload) == (3000,)
    st = m.Status.decode(raw.command(8, m.Cmd.STATUS).payload)
    assert st.neutral_C == 30.0                                     # not carried out twice
    # a silent heartbeat gets no reply
    raw.send(9, m.Cmd.HEARTBEAT, b"\x00")
    raw.others.clear()
    raw.pump(0.1, heartbeat=False)
    assert not [f for f in raw.others if f.seq == 9]
    _hello(raw, 2)                                                  # a new session
    fr = raw.command(7, m.Cmd.SET_NEUTRAL, m.CENTI.pack(3300))
    assert fr.type == 0x83 and m.CENTI.unpack(fr.payload) == (3300,)


def test_device_clamps_limits_neutral_and_samples(raw):
    _hello(raw, 1)
    fr = raw.command(2, m.Cmd.SET_LIMITS, m.LIMITS.pack(500, 5000, 20000))
    assert m.LIMITS.unpack(fr.payload) == (1000, 4450, 10000)       # its own 10-44.5, 100 °C/s
    fr = raw.command(3, m.Cmd.SET_NEUTRAL, m.CENTI.pack(5000))
    assert m.CENTI.unpack(fr.payload) == (4450,)
    fr = raw.command(4, m.Cmd.SET_LIMITS, m.LIMITS.pack(1500, 4200, 1000))
    assert m.LIMITS.unpack(fr.payload) == (1500, 4200, 1000)
    values = np.linspace(1200, 4500, 100).round().astype("<i2")
    expected = int(np.count_nonzero((values < 1500) | (values > 4200)))
    assert raw.command(5, m.Cmd.UPLOAD_BEGIN, m.UPLOAD_BEGIN.pack(100, 10000)).type == 0x90
    fr = raw.command(6, m.Cmd.UPLOAD_CHUNK, m.UPLOAD_CHUNK_HEAD.pack(0, 100) + values.tobytes())
    assert m.UPLOAD_CHUNK_ACK.unpack(fr.payload) == (0, 100, zlib.crc32(values.tobytes()))
    fr = raw.command(7, m.Cmd.UPLOAD_COMMIT, m.COMMIT.pack(zlib.crc32(values.tobytes())))
    assert fr.type == 0x92
    assert m.COMMIT_ACK.unpack(fr.payload) == (100, zlib.crc32(values.tobytes()), expected)


def test_device_holds_the_rate_limit_over_every_window(raw):
    """A profile that jumps 32 -> 40 °C (past a careless host) is slowed, never played faster:
    the setpoints of any 10 ticks span ≤ 10 °C/s × 0.1 s + 0.01 °C (§6).

    The windows are taken on the device's own clock (each frame's ``device_time_s``: frames
    less than 0.1 s apart are within 10 ticks), not as 10 frames in a row: on a loaded machine
    the host may miss frames (under QEMU 68 of about 150 arrived), and 10 frames in a row then
    span more than 10 ticks."""
    _hello(raw, 1)
    raw.command(2, m.Cmd.SET_LIMITS, m.LIMITS.pack(1500, 4200, 1000))
    raw.command(3, m.Cmd.SET_NEUTRAL, m.CENTI.pack(3200))
    values = np.array([3200] * 20 + [4000] * 130, dtype="<i2")       # 10 ms steps, 1.5 s
    raw.command(4, m.Cmd.UPLOAD_BEGIN, m.UPLOAD_BEGIN.pack(len(values), 10000))
    raw.command(5, m.Cmd.UPLOAD_CHUNK, m.UPLOAD_CHUNK_HEAD.pack(0, len(values)) + values.tobytes())
    assert raw.command(6, m.Cmd.UPLOAD_COMMIT, m.COMMIT.pack(zlib.crc32(values.tobytes()))).type == 0x92
    finger = m.encode_json(dict(press_after_s=0.1, force_N=2.0, hold_s=3.0,
                                skin_thickness_m=650e-6, skin_temperature_C=35.5))
    with raw.heartbeating():          # from ARM on the device is active: the watchdog runs
        assert raw.command(7, m.Cmd.ARM, m.ARM.pack(0, 200, 5000)).type == 0xA0
        assert raw.command(8, m.Cmd.SIM_FINGER, finger).type == 0xB1
        raw.pump(10.0, until=lambda f: f.type == 0xA1 and f.payload[0] == m.Event.END)
    tel = [m.Telemetry.decode(f.payload) for f in raw.others
           if f.type == 0xA0 and len(f.payload) == m.TELEMETRY.size]
    playing = [f for f in tel if f.state == "PLAYING"]
    sp = np.array([f.setpoint_C for f in playing])
    t = np.array([f.device_time_s for f in playing])
    events = [(m.Event(f.payload[0]).name, f.payload.hex()) for f in raw.others
              if f.type == 0xA1 and len(f.payload) >= 11 and f.payload[0] in iter(m.Event)]
    assert len(playing) >= 20 and t[-1] - t[0] >= 1.0, events     # the whole 0.8 s ramp watched
    moved = np.abs(sp[:, None] - sp[None, :])
    within_10_ticks = np.abs(t[:, None] - t[None, :]) < 0.1 - 0.005
    assert moved[within_10_ticks].max() <= 1.01 + 0.01   # + the 0.01 °C of telemetry's rounding
    assert sp.max() == pytest.approx(40.0, abs=0.005)  # slowed, then reached
