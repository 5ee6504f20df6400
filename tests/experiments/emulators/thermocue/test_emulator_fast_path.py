"""The virtual clock's fast path (speed): decoded frames in place of bytes, exactly.

``Serial.read_frames`` hands the driver the frames ``read()`` would have returned, without
encoding and parsing them, when nothing on the line can damage them (virtual clock, no fault
spec); the device takes a silent heartbeat without parsing it. Both must change nothing: the
same frames at the same device times, the same trial, the same logs.
"""
from __future__ import annotations

import hashlib
import sys
from pathlib import Path

import numpy as np
import pytest
import serial

from experiments.display.thermocue import messages as m
from experiments.emulators.thermocue.device import Device
from experiments.display.thermocue.driver import ThermalDisplay
from experiments.display.thermocue.framing import FrameParser, encode_frame

from _ports import HidingPort


def _trial(port, mode):
    d = ThermalDisplay(port)
    frames, events = [], []
    try:
        d.handshake()
        t = np.arange(0.0, 1.5, 0.02)
        d.upload_profile(t, 32.0 - 3.0 * np.sqrt(t / 1.5))
        if mode == "record":
            d.sim_sample(roughness_m=50e-6)
        d.arm(mode=mode, force_threshold_N=2.0, max_duration_s=1.5)
        d.sim_finger(press_after_s=0.3, force_N=2.5, hold_s=1.5)
        rec = d.run_trial(timeout_s=10.0, on_telemetry=frames.append, on_event=events.append)
        st = d.status()
        return rec, frames, events, st, port.device.time_us, port.device.last_rx_us
    finally:
        d.close()


@pytest.mark.parametrize("mode", ["playback", "record"])
def test_a_trial_through_the_fast_path_equals_the_byte_path(mode):
    fast = serial.serial_for_url("emulator://?clock=virtual&seed=3", timeout=0.01)
    slow = serial.serial_for_url("emulator://?clock=virtual&seed=3", timeout=0.01)
    calls = []
    read_frames = fast.read_frames
    fast.read_frames = lambda size: calls.append(size) or read_frames(size)
    a = _trial(fast, mode)
    b = _trial(HidingPort(slow, hide=("read_frames",)), mode)   # everything through read()
    assert len(calls) > 50                                # the fast path did the trial's reads
    assert repr(a[0]) == repr(b[0]) and a[0].status == "ok"   # the TrialRecording (nan-proof)
    assert a[1] == b[1] and len(a[1]) > 150               # every telemetry frame
    assert a[2] == b[2] and [e.kind for e in a[2]][-1] == "END"
    assert a[3:] == b[3:]                                 # STATUS, device time, last host frame


def test_read_frames_gives_what_read_gives_tick_for_tick():
    ports = [serial.serial_for_url("emulator://?clock=virtual&seed=1", timeout=0.01)
             for _ in range(2)]
    fast, slow = ports
    parser = FrameParser()
    hello = encode_frame(1, m.Cmd.HELLO, m.HELLO_REQ.pack(m.PROTOCOL_VERSION))
    for p in ports:
        p.write(hello)
        p.read(4096)
    got_fast, got_slow = [], []
    for i in range(300):
        if i == 5:                     # a trial: ARM needs a profile; watch a state change too
            for p in ports:
                p.device.profile = ([31.0, 30.0, 29.0], 500_000)
                p.write(encode_frame(2, m.Cmd.ARM, m.ARM.pack(m.Mode.PLAYBACK, 200, 2000)))
                p.read(4096)
        if i % 3 == 0:
            for p in ports:
                p.write(encode_frame(0, m.Cmd.HEARTBEAT, b"\x00"))
        got_fast.append((fast.read_frames(65536), fast.device.time_us))
        got_slow.append((parser.feed(slow.read(65536)), slow.device.time_us))
    assert got_fast == got_slow
    assert sum(len(f) for f, _ in got_fast) > 100


def test_read_frames_declines_when_a_fault_or_the_real_clock_is_in_play():
    for url in ("emulator://?clock=virtual&faults=drop=0.01", "emulator://?clock=virtual&faults=stall@50",
                "emulator://?clock=real"):
        port = serial.serial_for_url(url, timeout=0.01)
        try:
            assert port.read_frames(65536) is None, url
        finally:
            port.close()
    port = serial.serial_for_url("emulator://?clock=virtual", timeout=0.01)
    try:
        assert port.read_frames(65536) == []            # idle: one tick, nothing said
        port.device.out += b"\xa5"                       # bytes waiting: the byte path
        assert port.read_frames(65536) is None
    finally:
        port.close()


def test_a_silent_heartbeat_feeds_the_watchdog_whole_or_split():
    hb = encode_frame(7, m.Cmd.HEARTBEAT, b"\x00")
    whole, split = Device(), Device()
    for dev in (whole, split):
        for _ in range(5):
            dev.step()
    whole.receive(hb)
    split.receive(hb[:4])                       # a partial frame: the parser takes the rest
    split.receive(hb[4:])
    for dev in (whole, split):
        assert dev.last_rx_us == 50_000 and dev.parser.frames == 1 and not dev.parser.buffered
        assert dev.take_output() == b""           # silent: no reply
    stalled = Device(faults="stall")
    stalled.step()
    stalled.receive(hb)
    assert stalled.last_rx_us == 0                  # a hung firmware hears nothing


# the traces of P01's emulated session (seed-0 cohort, seed 0): every telemetry value the session
# logged, at every tick. First made at main 06e98b2, before the fast path (c06ce50a...); made
# again when the simulated participant began to draw each press and skin temperature from the
# one lab model of the Figure 9 Monte Carlo (2.5 ± 0.25 N instead of one 2.5 N press), which
# changes what the finger does, not how the emulator steps. From here it pins the session's
# traces against regressions; that the fast path equals the link path is shown tick for tick by
# test_a_write_with_no_link_fault_equals_the_write_through_the_link_tick_for_tick.
P01_TRACES_SHA256 = "9af5c28dad34d027433cdf3431e7e6ef0552a3a3311197d49c8e1d0216b1319d"


@pytest.mark.slow
def test_an_emulated_session_logs_the_same_traces_as_before_the_fast_path(tmp_path):
    root = Path(__file__).resolve().parents[4]
    sys.path.insert(0, str(root / "benchmarks"))
    try:
        from bench_emulated_session import _cohort, traces_digest
    finally:
        sys.path.remove(str(root / "benchmarks"))
    run_participant, write_cohort = _cohort()
    paths = {p.stem: p for p in write_cohort(tmp_path / "participants", seed=0)}
    res = run_participant(paths["P01"], tmp_path / "data", seed=0, durable=False)
    assert res["n_trials"] == 28
    assert traces_digest(Path(res["session_dir"])) == P01_TRACES_SHA256


def _device_state(port):
    """Everything a write can change on the device's side, and what waits for the host."""
    dev, p = port.device, port.device.parser
    return (dev.last_rx_us, dev.time_us, dev.state, dev.hello, dict(dev.cache), bytes(dev.out),
            p.frames, p.bad_frames, p.bytes_skipped, p.buffered, bytes(port._rx))


def test_a_write_with_no_link_fault_equals_the_write_through_the_link_tick_for_tick():
    # the same host bytes, one port writing through EmulatorCore (to_device/to_host), the other
    # straight to the device: silent heartbeats whole and split, replies, garbage, a retry
    ports = [serial.serial_for_url("emulator://?clock=virtual&seed=2", timeout=0.01)
             for _ in range(2)]
    direct, linked = ports
    calls = []
    linked.write = lambda data: calls.append(data) or linked._write_through_link(bytes(data))
    hb = [encode_frame(s, m.Cmd.HEARTBEAT, b"\x00") for s in range(256)]
    hello = encode_frame(1, m.Cmd.HELLO, m.HELLO_REQ.pack(m.PROTOCOL_VERSION))
    writes = []
    for i in range(400):
        if i == 3:
            writes.append([hello])
        elif i == 7:
            writes.append([hb[9][:3], hb[9][3:]])          # a heartbeat split in two
        elif i == 11:
            writes.append([b"\x00\x17" + hb[10]])           # garbage, then a heartbeat
        elif i == 13:
            writes.append([encode_frame(4, m.Cmd.HEARTBEAT, b"")] * 2)   # acked, then retried
        elif i == 17:
            writes.append([hb[11][:5]])                     # a partial frame left waiting ...
        elif i == 18:
            writes.append([hb[11][5:] + hb[12]])            # ... its rest, and one more
        elif i == 20:
            writes.append([bytearray(hb[13]), memoryview(hb[14])])   # not bytes: same frames
        else:
            writes.append([hb[i % 256]])
    for i, chunk in enumerate(writes):
        for data in chunk:
            assert direct.write(data) == linked.write(data) == len(data)
            assert _device_state(direct) == _device_state(linked), (i, data)
        got = [bytes(p.read(65536)) for p in ports]
        assert got[0] == got[1], i
        assert _device_state(direct) == _device_state(linked), i
    assert len(calls) == sum(len(c) for c in writes)
    dev = direct.device
    assert dev.hello and dev.parser.frames > 390 and dev.parser.bytes_skipped == 2
    assert dev.last_rx_us == dev.time_us - 10_000           # the last heartbeat, one read ago


@pytest.mark.parametrize("mode", ["playback", "record"])
def test_a_trial_with_direct_writes_equals_the_trial_through_the_link(mode):
    direct = serial.serial_for_url("emulator://?clock=virtual&seed=5", timeout=0.01)
    linked = serial.serial_for_url("emulator://?clock=virtual&seed=5", timeout=0.01)
    direct_calls = []
    write_direct = direct._write_direct
    direct._write_direct = lambda data: direct_calls.append(data) or write_direct(data)
    linked.write = lambda data: linked._write_through_link(bytes(data))
    a = _trial(direct, mode)
    b = _trial(linked, mode)
    assert len(direct_calls) > 50                         # heartbeats and commands went direct
    assert repr(a[0]) == repr(b[0]) and a[0].status == "ok"
    assert a[1] == b[1] and len(a[1]) > 150
    assert a[2] == b[2]
    assert a[3:] == b[3:]


@pytest.mark.parametrize("url", ["emulator://?clock=virtual&faults=drop=1",
                                 "emulator://?clock=virtual&faults=disconnect@0.5",
                                 "emulator://?clock=real"])
def test_a_write_goes_through_the_link_when_a_fault_or_the_real_clock_is_in_play(url):
    port = serial.serial_for_url(url, timeout=0.01)
    try:
        seen = []
        to_device = port.core.to_device
        port.core.to_device = lambda data, at_us=None: seen.append(data) or to_device(data, at_us)
        port._write_direct = lambda data: pytest.fail("the direct write was used")
        hb = encode_frame(3, m.Cmd.HEARTBEAT, b"\x00")
        port.write(hb)
        assert seen == [hb]
        if "drop=1" in url:
            assert port.device.parser.frames == 0         # the link dropped it
    finally:
        port.close()
