"""The driver against the display under test (``--display``; default: the in-process emulator)."""
import numpy as np
import pytest

from experiments.errors import DisplayError, DisplayRefused, SafetyLimitError, UserInputError
from experiments.display import SafetyLimits, Telemetry, open_display
from experiments.display.thermocue import messages as m
from experiments.emulators.thermocue.device import Device
from experiments.emulators.thermocue.device_commands import HostCommands
from experiments.display.thermocue.framing import HEADER_SIZE
from experiments.display.thermocue.messages import PROTOCOL_VERSION, Cmd

T = np.arange(0, 3.0001, 0.01)
PROFILE = np.round(26.0 + 2.0 * np.sqrt(T / 3.0), 2)        # a gentle 3 s profile, °C


def emulator_only(display):
    if not hasattr(display.port, "device"):
        pytest.skip("white-box check of the in-process emulator")
    return display.port.device


def test_handshake(display):
    info = display.info
    assert info.protocol == PROTOCOL_VERSION and info.telemetry_hz >= 100
    assert info.min_dt_s <= 1e-3 and info.max_points * info.min_dt_s >= 30.0
    assert "playback" in info.capabilities
    st = display.status()
    assert st.state == "IDLE" and st.neutral_C == 32.0
    assert display.is_awake()


def test_playback_trial_end_to_end(sim_display):
    d = sim_display
    d.upload_profile(T, PROFILE)
    d.arm("playback", force_threshold_N=2.0, max_duration_s=20.0)
    d.sim_finger(press_after_s=0.2, force_N=2.0, hold_s=10.0)
    frames, events = [], []
    rec = d.run_trial(timeout_s=30.0, on_telemetry=frames.append, on_event=events.append)
    assert rec.status == "ok" and rec.end_reason == "complete" and rec.fault_code is None
    assert isinstance(frames[0], Telemetry) and rec.frames == len(frames) and rec.frames_lost == 0
    assert [e.kind for e in events][:2] == ["READY", "CONTACT"]
    assert rec.contact_time_s == events[1].device_time_s == d.last_contact.device_time_s
    assert d.last_contact.force_N >= 2.0
    playing = [f for f in frames if f.state == "PLAYING"]
    assert len(playing) == pytest.approx(300, abs=2)                     # 100 Hz for 3 s
    assert sum(playing[0].forces_N) >= 2.0 - 4 * 0.005      # four readings rounded to 0.01 N
    assert rec.duration_s == pytest.approx(3.0, abs=0.02)
    assert rec.tracking_rms_C < 0.05 and rec.tracking_max_C < 0.5
    # the finger warms the pad; the IR thermometer sees a finger cooler than its 35.5 °C core
    assert 26.0 < playing[-1].finger_C < 35.5
    assert d.status().state == "IDLE"


def test_record_trial_reports_the_exact_interface_temperature(sim_display):
    stimuli = pytest.importorskip("stimuli")
    d = sim_display
    d.sim_sample(material="stainless_steel", roughness_m=50e-6, thickness_m=3e-3, temperature_C=20.0)
    d.arm("record", max_duration_s=4.0)
    d.sim_finger(press_after_s=0.1, hold_s=10.0, skin_thickness_m=1000e-6, skin_temperature_C=36.0)
    frames = []
    rec = d.run_trial(on_telemetry=frames.append)
    assert rec.status == "ok" and rec.end_reason == "max_duration" and np.isnan(rec.tracking_rms_C)
    skin = stimuli.Skin(1000e-6)
    steel = stimuli.material("stainless_steel", thickness=3e-3)
    R = stimuli.contact_resistance(50e-6, skin=skin, material=steel)
    c = stimuli.Contact(skin, steel, resistance=R, skin_temperature=36.0, material_temperature=20.0)
    rec_frames = [f for f in frames if f.state == "RECORDING"]
    t = np.array([f.device_time_s for f in rec_frames]) - rec.contact_time_s
    y = np.array([f.contact_C for f in rec_frames])
    # thermal contact starts at first touch, 0.10-0.16 s before the 2 N crossing stamps contact
    lo = c.interface_temperature(t + 0.09)
    hi = c.interface_temperature(t + 0.17)
    assert np.all(y > lo - 0.03) and np.all(y < hi + 0.03)


def test_host_refuses_before_sending(display):
    writes = []
    real = display.port.write
    display.port.write = lambda data: (writes.append(data), real(data))[1]
    hot = PROFILE.copy()
    hot[100] = 45.0
    with pytest.raises(SafetyLimitError, match=r"target_C\[100\]"):
        display.upload_profile(T, hot)
    with pytest.raises(SafetyLimitError, match="rate"):
        display.upload_profile(T, 26.0 + 10.0 * (T > 1.0))
    with pytest.raises(SafetyLimitError):
        display.set_neutral(43.0)
    assert writes == []


def test_refusal_is_typed(sim_display):
    sim_display.upload_profile(T, PROFILE)
    sim_display.arm("playback")
    with pytest.raises(DisplayRefused) as e:
        sim_display.link.transact(0x20, b"\x00\xc8\x00\x10\x27\x00\x00")      # a second ARM
    assert e.value.code == 4 and "BAD_STATE" in str(e.value)
    sim_display.abort()
    assert sim_display.status().state == "IDLE"


def test_a_stalled_device_is_not_awake():
    with open_display("emulator://?clock=virtual") as d:
        assert d.is_awake()
        d.sim_fault("stall")
        assert not d.is_awake()
        with pytest.raises(DisplayError, match="expected a reply"):
            d.status()


def test_sim_commands_need_an_emulator():
    with open_display("emulator://?clock=virtual&sim=0") as d:
        with pytest.raises(DisplayError, match="capability 'sim'"):
            d.sim_finger()


def test_unopenable_url_is_a_display_error():
    # a URL its backend refuses is bad input, checked before anything is opened (as the
    # session checks it); a device that is not there is a display error
    with pytest.raises(UserInputError, match="unknown option 'colour'") as exc:
        open_display("emulator://?colour=red")
    assert not isinstance(exc.value, DisplayError)
    with pytest.raises(DisplayError, match="cannot open"):
        open_display("/dev/no-such-display")


def _telemetry_frame(counter):
    from experiments.display.thermocue import messages as m
    from experiments.display.thermocue.framing import encode_frame
    body = m.TELEMETRY.pack(counter, counter * 10_000, 3000, 3000, 2000, 3400, 50, 50, 50, 50,
                            m.State.PLAYING, 0)
    return encode_frame(counter & 0xFF, m.Msg.TELEMETRY, body)


def _loop_display(**options):
    import serial

    from experiments.display.thermocue.driver import ThermalDisplay
    return ThermalDisplay(serial.serial_for_url("loop://", timeout=0.01), **options)


def test_a_frame_split_by_a_slow_kernel_is_not_lost():
    # a pty hands a frame over in two pieces when its buffers wrap; on a loaded machine the
    # second piece can come after a read timed out: the parser must wait for it (it used to
    # drop the first byte after one empty 10 ms read, and the frame with it)
    d = _loop_display(stale_s=0.5)
    fr = _telemetry_frame(7)
    d.port.write(fr[:20])
    assert d.link.read_frames() == []
    for _ in range(5):                                   # five empty reads (50 ms): still waiting
        assert d.link.read_frames() == []
    d.port.write(fr[20:])
    got = d.link.read_frames()
    assert [f.payload for f in got] == [fr[HEADER_SIZE:-2]] and d.link.parser.bytes_skipped == 0


def test_a_garbage_length_is_abandoned_after_stale_s():
    d = _loop_display(stale_s=0.05)
    good = _telemetry_frame(8)
    from experiments.display.thermocue.framing import encode_frame
    cut = encode_frame(3, 0xA0, bytes(1008))[:HEADER_SIZE + 4]   # 1008 bytes that never come
    d.port.write(cut + good)
    got = []
    for _ in range(40):                                  # ≥ 0.4 s of empty reads
        got += d.link.read_frames()
        if got:
            break
    assert [f.payload for f in got] == [good[HEADER_SIZE:-2]]
    assert d.link.parser.bytes_skipped == len(cut)


def test_the_heartbeat_helper_feeds_the_watchdog_while_the_host_holds_the_gil(tmp_path):
    # on a port with a descriptor the heartbeat comes from a helper process: here the host
    # process holds the GIL in one C call (sorting floats) for well over the watchdog's 90 ms
    import os
    import pty
    import random
    import time

    import serial

    from experiments.display.thermocue.driver import ThermalDisplay
    from experiments.display.thermocue.framing import FrameParser
    master, slave = pty.openpty()
    try:
        port = serial.serial_for_url(os.ttyname(slave), timeout=0.01)
        d = ThermalDisplay(port)
        d.start_heartbeat()
        assert d.link._hb_proc is not None and d.link._hb_proc.running
        big = [random.random() for _ in range(1_000_000)]
        t0 = time.monotonic()
        big.sort()                                        # one C call: the GIL is ours
        held = time.monotonic() - t0
        time.sleep(0.05)
        os.set_blocking(master, False)
        frames = FrameParser().feed(os.read(master, 65536))
        d.stop_heartbeat()
        port.close()
    finally:
        os.close(master)
        os.close(slave)
    assert held > 0.12
    hb = [f for f in frames if f.type == 0x02 and f.payload == b"\x00"]
    assert len(hb) >= 0.5 * held / d.link.heartbeat_s         # ≥ half the 10 ms ticks got through


def _pty_display():
    import os
    import pty

    import serial

    from experiments.display.thermocue.driver import ThermalDisplay
    master, slave = pty.openpty()
    return master, slave, ThermalDisplay(serial.serial_for_url(os.ttyname(slave), timeout=0.01))


def test_the_display_is_handed_over_only_once_the_heartbeat_helper_runs(monkeypatch):
    # a second Python on a loaded machine can take more than the watchdog's 90 ms to write its
    # first heartbeat; the driver's thread used to stand down as soon as the process existed
    import os
    import time

    from experiments.display.thermocue import heartbeat
    from experiments.display.thermocue.framing import FrameParser
    monkeypatch.setattr(heartbeat, "_HELPER", "import time; time.sleep(0.4)\n" + heartbeat._HELPER)
    master, slave, d = _pty_display()
    try:
        t0 = time.monotonic()
        d.start_heartbeat()
        waited = time.monotonic() - t0
        assert d.link._hb_proc is not None and d.link._hb_proc.ready and waited >= 0.4
        time.sleep(0.1)
        os.set_blocking(master, False)
        hb = [f for f in FrameParser().feed(os.read(master, 65536))
              if f.type == Cmd.HEARTBEAT and f.payload == b"\x00"]
        assert len(hb) >= 3                      # the helper writes from the moment it is handed over
        d.stop_heartbeat()
        d.port.close()
    finally:
        os.close(master)
        os.close(slave)


def test_a_heartbeat_helper_that_does_not_start_leaves_the_heartbeat_to_the_thread(monkeypatch):
    import os
    import time

    from experiments.display.thermocue import heartbeat, link
    monkeypatch.setattr(heartbeat, "_HELPER", "import time; time.sleep(60)\n")
    monkeypatch.setattr(link, "HELPER_START_S", 0.3)
    master, slave, d = _pty_display()
    try:
        d.start_heartbeat()
        assert d.link._hb_proc is None           # stopped, not left half started
        deadline = time.monotonic() + 5
        while d.link.heartbeats_sent < 5 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert d.link.heartbeats_sent >= 5       # the thread's, every 10 ms
        d.stop_heartbeat()
        d.port.close()
    finally:
        os.close(master)
        os.close(slave)


@pytest.mark.parametrize("hold_s", [0.3])
def test_the_in_process_emulator_is_heartbeated_by_the_helper_while_the_host_holds_the_gil(hold_s):
    # emulator:// on a real clock runs the device in this process: a thread heartbeat and the
    # device's clock thread were held off together, and whichever got the GIL first decided
    # whether the watchdog tripped (a spurious WATCHDOG in a normal session on a busy machine).
    # The helper process writes to the emulator's descriptor, read by its clock thread first
    import random
    import time
    with open_display("emulator://?clock=real") as d:
        assert d.link._hb_proc is not None and d.link._hb_proc.running
        d.arm("record", force_threshold_N=2.0, max_duration_s=20.0)
        big = [random.random() for _ in range(100_000)]
        held = 0.0
        for _ in range(3):                               # 3 holds of ≥ 0.3 s of C calls
            t0 = time.monotonic()
            while time.monotonic() - t0 < hold_s:
                sorted(big)                              # the GIL is ours for the whole call
            held = max(held, time.monotonic() - t0)
            d.poll()                                     # a frame loop's pass: the host lives
            time.sleep(0.03)
        st = d.status()
        late_s = d.port.core.max_late_s
        assert st.state == "ARMED" and st.fault is None, (st.state, st.fault, late_s)
        d.abort()
    assert held >= hold_s


def test_a_hung_host_on_the_in_process_emulator_still_meets_the_watchdog(tmp_path):
    # the helper keeps heartbeating only while the host's I/O thread shows signs of life: a host
    # silent for host_stall_s (here 0.5 s; 2 s by default) lets the watchdog act within
    # host_stall_s + 100 ms of the host's last sign of life (at the latest, the ARM)
    import json
    import time
    log = tmp_path / "emu.jsonl"
    with open_display(f"emulator://?clock=real&log={log}", host_stall_s=0.5) as d:
        assert d.link._hb_proc is not None and d.link._hb_proc.running
        d.wait(0.5)               # the helper up (its own start counts as a sign of life)
        d.arm("record", force_threshold_N=2.0, max_duration_s=20.0)
        time.sleep(1.5)                                  # hung: no I/O, no pings
        st = d.status()
        late_s = d.port.core.max_late_s                  # bytes read late count as of then
    assert st.state == "IDLE" and st.fault == "WATCHDOG"
    recs = [json.loads(line) for line in log.read_text().splitlines()]
    armed = next(r["t_s"] for r in recs if r["event"] == "state" and r["state"] == "ARMED")
    trip = next(r["t_s"] for r in recs if r["event"] == "watchdog")
    # heartbeats went on while the host was silent less than host_stall_s (the last ping may
    # precede the ARM by up to host_stall_s / 8), and stopped after it: the trip within
    # host_stall_s + the helper's 10 ms wake-up + 100 ms (+ the emulator's own lateness, by
    # which the bytes it read late are stamped ahead)
    assert 0.5 - 0.5 / 8 - 0.02 <= trip - armed <= 0.5 + 0.01 + 0.1 + late_s + 1e-6, \
        (armed, trip, late_s)


def test_each_connection_starts_at_a_random_sequence_number():
    # audit 34: every host started at 1, so a restarted host repeated its predecessor's numbers
    # and got its cached replies (the device side is fixed too: HELLO clears them)
    seen = []
    for _ in range(8):
        with open_display("emulator://?clock=virtual") as d:
            seen.append(d.port.device.cache[Cmd.SET_LIMITS][0])   # the number the device saw
    assert len(set(seen)) > 1                            # all equal: chance 256**-7


class StaleFirmware(HostCommands):
    """A firmware that answers SET_LIMITS or SET_NEUTRAL with an earlier session's reply."""

    stale = {Cmd.SET_LIMITS: m.LIMITS.pack(1500, 4200, 1000), Cmd.SET_NEUTRAL: m.CENTI.pack(3200)}

    def __init__(self, device, replay):
        super().__init__(device)
        self.replay = replay

    def _handle(self, seq, cmd, p):
        if cmd == self.replay:
            return self._ack(seq, cmd, self.stale[cmd])     # not carried out
        return super()._handle(seq, cmd, p)


@pytest.mark.parametrize("replay", [Cmd.SET_LIMITS, Cmd.SET_NEUTRAL])
def test_limits_and_neutral_not_echoed_are_a_display_error(replay):
    # audit 34: stale acknowledgements were taken as success; the host checks the echo
    import serial

    from experiments.display.thermocue.driver import ThermalDisplay
    port = serial.serial_for_url("emulator://?clock=virtual", timeout=0.01)
    port.device = Device()
    port.device.commands = StaleFirmware(port.device, replay)
    limits = SafetyLimits(min_C=20.0, max_C=38.0, max_rate_C_per_s=10.0, neutral_C=30.0)
    d = ThermalDisplay(port, limits)
    try:
        with pytest.raises(DisplayError, match=replay.name) as e:
            d.handshake()
        assert ("20.0" in str(e.value) and "15.0" in str(e.value) if replay == Cmd.SET_LIMITS
                else "30.0" in str(e.value) and "32.0" in str(e.value))
    finally:
        d.close()


def test_a_device_rate_below_the_hosts_is_accepted(monkeypatch):
    # the device may lower the rate to its own maximum: that is not a mismatch (the host's own
    # limit is at most the protocol's 100 °C/s, so the emulator's maximum is lowered to 50 here)
    import experiments.emulators.thermocue.device_commands as dc
    monkeypatch.setattr(dc, "HARD_RATE_C_PER_S", 50.0)
    limits = SafetyLimits(max_rate_C_per_s=80.0)
    with open_display("emulator://?clock=virtual", limits=limits) as d:
        assert d.port.device.lim_rate == 50.0


def _device_arms_playback(d) -> bool:
    """ARM in playback sent raw (past the host's own check): whether the device accepts it."""
    try:
        d.link.transact(Cmd.ARM, m.ARM.pack(0, 200, 1000))
    except DisplayRefused as exc:
        assert exc.code == m.Err.PROFILE_INCOMPLETE
        return False
    d.abort()
    return True


def test_a_profile_the_host_refuses_after_a_clamped_commit_is_not_left_on_the_device():
    # limits widened on the host after the handshake: the host's check passes a 43 °C sample,
    # the device clamps it to the 42 °C it holds, the host refuses; the device must hold no
    # profile (it kept the clamped one, and a raw ARM played it)
    with open_display("emulator://?clock=virtual") as d:
        d.upload_profile(T, PROFILE)                    # a good profile first
        assert _device_arms_playback(d)
        d._held_limits = None                           # as before the fix: no check of limits
        d.limits = SafetyLimits(max_C=44.0)
        y = np.round(np.minimum(26.0 + 8.0 * T, 43.0), 2)   # 8 °C/s up to 43 °C from 2.1 s
        with pytest.raises(SafetyLimitError, match="clamped"):
            d.upload_profile(T, y)
        assert d.port.device.profile is None
        assert not _device_arms_playback(d)
        with pytest.raises(Exception, match="profile uploaded before"):
            d.arm("playback")


def test_limits_widened_after_the_handshake_are_refused_and_leave_no_profile():
    with open_display("emulator://?clock=virtual") as d:
        d.upload_profile(T, PROFILE)
        d.limits = SafetyLimits(max_C=44.0)
        with pytest.raises(SafetyLimitError, match="changed since the handshake"):
            d.upload_profile(T, PROFILE)
        assert not _device_arms_playback(d)


def test_a_profile_the_host_check_refuses_discards_the_previous_one():
    with open_display("emulator://?clock=virtual") as d:
        d.upload_profile(T, PROFILE)
        with pytest.raises(SafetyLimitError, match="rate"):
            d.upload_profile(T, np.where(T < 1.0, 26.0, 38.0))
        assert not _device_arms_playback(d)
        d.upload_profile(T, PROFILE)                    # a good upload works again
        assert _device_arms_playback(d)


@pytest.mark.parametrize("cmd, frame_type, payload", [
    (Cmd.ARM, m.Msg.TELEMETRY, _telemetry_frame(5)[HEADER_SIZE:-2]),
    (Cmd.ABORT, m.Msg.EVENT, m.EVENT_HEAD.pack(3, 10_000, 0) + b"aborted by host"),
], ids=["ARM", "ABORT"])
def test_telemetry_and_events_are_not_taken_for_replies(cmd, frame_type, payload):
    # ARM's and ABORT's reply types (0x20 | 0x80, 0x21 | 0x80) are TELEMETRY's and EVENT's: a
    # telemetry frame whose number happened to be ARM's was taken for its reply (struct.error
    # in arm()), an END event for ABORT's acknowledgement (an abort that never happened)
    from experiments.errors import DisplayTimeout
    from experiments.display.thermocue.framing import encode_frame
    d = _loop_display(reply_timeout_s=0.05, retries=0)
    d.link._seq = 41                                          # the command goes out as number 42
    d.port.write(encode_frame(42, frame_type, payload))
    with pytest.raises(DisplayTimeout, match=cmd.name):  # loop:// answers nothing
        d.link.transact(cmd, m.ARM.pack(1, 200, 1000) if cmd == Cmd.ARM else b"")
    assert d.link.dev_time == pytest.approx(0.05 if cmd == Cmd.ARM else 0.01)   # routed as telemetry / event
