"""The emulated firmware on its own: no port, no driver, frames in and out."""
import zlib

import numpy as np
import pytest

from experiments.display.thermocue import messages as m
from experiments.emulators.thermocue.device import WATCHDOG_MS, Device
from experiments.display.thermocue.framing import FrameParser, encode_frame
from experiments.display.thermocue.messages import Cmd, Err, Msg, State


class Host:
    """A bare-hands host: raw frames, no safety checks (to test the device's own)."""

    def __init__(self, dev):
        self.dev, self.parser, self.seq, self.other = dev, FrameParser(), 0, []

    def send(self, cmd, payload=b"", seq=None):
        if seq is None:
            self.seq = seq = (self.seq + 1) & 0xFF
        self.dev.receive(encode_frame(seq, cmd, payload))
        reply = None
        for fr in self.parser.feed(self.dev.take_output()):
            if fr.seq == seq and fr.type in ((cmd | 0x80), Msg.NAK):
                reply = fr
            else:
                self.other.append(fr)
        return reply

    def step(self, n=1, heartbeat=True):
        frames = []
        for _ in range(n):
            self.dev.step()
            if heartbeat:
                self.dev.receive(encode_frame(0, Cmd.HEARTBEAT, b"\x00"))
            frames += self.parser.feed(self.dev.take_output())
        return [m.Telemetry.decode(f.payload) for f in frames if f.type == Msg.TELEMETRY], \
               [m.DeviceEvent.decode(f.payload) for f in frames if f.type == Msg.EVENT]

    def upload(self, values_C, dt_us=10_000):
        raw = np.round(np.asarray(values_C) * 100).astype("<i2").tobytes()
        assert self.send(Cmd.UPLOAD_BEGIN, m.UPLOAD_BEGIN.pack(len(values_C), dt_us)).type == 0x90
        for off in range(0, len(values_C), 400):
            body = raw[2 * off:2 * min(off + 400, len(values_C))]
            r = self.send(Cmd.UPLOAD_CHUNK, m.UPLOAD_CHUNK_HEAD.pack(off, len(body) // 2) + body)
            assert m.UPLOAD_CHUNK_ACK.unpack(r.payload)[2] == zlib.crc32(body)
        return self.send(Cmd.UPLOAD_COMMIT, m.COMMIT.pack(zlib.crc32(raw)))


def nak_code(fr):
    assert fr.type == Msg.NAK
    return m.NAK_HEAD.unpack_from(fr.payload)[1]


@pytest.fixture
def host():
    log = []
    h = Host(Device(seed=5, log=log.append))
    h.log = log
    assert h.send(Cmd.HELLO, m.HELLO_REQ.pack(m.PROTOCOL_VERSION)).type == Cmd.HELLO | 0x80
    assert h.send(Cmd.SET_LIMITS, m.LIMITS.pack(1500, 4200, 1000)).type == Cmd.SET_LIMITS | 0x80
    return h


def finger(h, **kw):
    args = dict(press_after_s=0.1, force_N=2.0, hold_s=30.0, skin_thickness_m=650e-6,
                skin_temperature_C=35.5)
    args.update(kw)
    return h.send(Cmd.SIM_FINGER, m.encode_json(args))


def test_refusals_carry_codes(host):
    assert nak_code(host.send(0x55)) == Err.UNKNOWN_COMMAND
    assert nak_code(host.send(Cmd.SET_NEUTRAL, b"\x01")) == Err.BAD_LENGTH
    assert nak_code(host.send(Cmd.ARM, m.ARM.pack(0, 200, 1000))) == Err.PROFILE_INCOMPLETE
    assert nak_code(host.send(Cmd.UPLOAD_BEGIN, m.UPLOAD_BEGIN.pack(10, 500))) == Err.OUT_OF_RANGE
    assert nak_code(host.send(Cmd.HELLO, m.HELLO_REQ.pack(99))) == Err.NOT_SUPPORTED


def test_device_clamps_what_a_careless_host_sends(host):
    r = host.send(Cmd.SET_NEUTRAL, m.CENTI.pack(6000))                 # 60 °C
    assert m.CENTI.unpack(r.payload)[0] == 4200
    vals = np.r_[np.full(50, 30.0), np.full(150, 50.0)]                # 50 °C: beyond 42
    ack = m.COMMIT_ACK.unpack(host.upload(vals).payload)
    assert ack[2] == 150
    assert host.send(Cmd.ARM, m.ARM.pack(0, 200, 5000)).type == Cmd.ARM | 0x80
    finger(host)
    tel, _ = host.step(400)
    sp = np.array([t.setpoint_C for t in tel])
    assert {"PLAYING"} <= {t.state for t in tel}
    assert sp.max() <= 42.0 and sp.min() >= 15.0
    assert max(t.contact_C for t in tel) < 42.3


def test_a_repeated_sequence_number_is_answered_not_acted_on(host):
    host.upload(np.full(100, 30.0))
    a = host.send(Cmd.ARM, m.ARM.pack(0, 200, 5000), seq=77)
    b = host.send(Cmd.HEARTBEAT, b"", seq=78)
    c = host.send(Cmd.ARM, m.ARM.pack(0, 200, 5000), seq=77)          # the host's retry
    assert a.type == c.type == Cmd.ARM | 0x80 and a.payload == c.payload
    d = host.send(Cmd.ARM, m.ARM.pack(0, 200, 5000), seq=79)          # a genuinely new ARM
    assert nak_code(d) == Err.BAD_STATE


def test_watchdog_returns_to_neutral_within_100_ms(host):
    host.upload(np.full(3000, 25.0))
    host.send(Cmd.ARM, m.ARM.pack(0, 200, 30000))
    finger(host)
    tel, ev = host.step(300)                                           # armed, ready, playing
    assert tel[-1].state == "PLAYING"
    last_rx = host.dev.time_us
    tel, ev = host.step(30, heartbeat=False)                           # the host dies
    trip = next(e for e in ev if e.kind == "WATCHDOG")
    assert trip.device_time_s * 1e6 - last_rx <= 100_000
    assert (trip.device_time_s * 1e6 - last_rx) >= WATCHDOG_MS * 1000
    first_idle = next(t for t in tel if t.state == "IDLE")
    assert first_idle.device_time_s == trip.device_time_s
    assert host.dev.state == State.IDLE and host.dev.last_fault == Err.WATCHDOG
    for _ in range(300):
        host.dev.step()
    assert host.dev.sp == 32.0 and abs(host.dev.plant.pad - 32.0) < 0.1
    assert any(r["event"] == "watchdog" for r in host.log)


def test_the_longest_host_silence_while_active_is_kept(host):
    # the session's heartbeat gaps as the device sees them (benchmarks/bench_monitor.py)
    host.step(50, heartbeat=False)                       # idle: a silence that does not count
    assert host.dev.max_rx_gap_us == 0
    host.upload(np.full(3000, 25.0))
    host.send(Cmd.ARM, m.ARM.pack(0, 200, 30000))
    host.step(20)                                        # a heartbeat every 10 ms tick
    assert host.dev.max_rx_gap_us == 10_000
    host.step(5, heartbeat=False)
    host.step(1)                                         # 60 ms without a host frame, armed
    assert host.dev.max_rx_gap_us == 60_000


def test_heartbeats_keep_the_watchdog_quiet(host):
    host.upload(np.full(3000, 25.0))
    host.send(Cmd.ARM, m.ARM.pack(0, 200, 30000))
    finger(host)
    tel, ev = host.step(600)
    assert not any(e.kind == "WATCHDOG" for e in ev) and tel[-1].state == "PLAYING"


@pytest.mark.parametrize("spec, code", [("overtemp", Err.OVER_TEMPERATURE),
                                        ("sensor_range", Err.SENSOR_FAILURE),
                                        ("stuck_sensor", Err.SENSOR_STUCK)])
def test_faults_open_the_relay_and_are_reported(host, spec, code):
    host.upload(np.full(3000, 30.0))
    host.send(Cmd.ARM, m.ARM.pack(0, 200, 30000))
    finger(host)
    host.step(200)
    host.send(Cmd.SIM_FAULT, m.encode_json({"spec": spec}))
    tel, ev = host.step(100)
    assert [e.arg for e in ev if e.kind == "FAULT"] == [code]
    assert tel[-1].state == "FAULT" and tel[-1].fault == code.name
    assert host.dev.enabled is False and host.dev.sp == 32.0
    assert max(t.setpoint_C for t in tel) <= 42.0
    assert nak_code(host.send(Cmd.ARM, m.ARM.pack(0, 200, 1000))) == Err.FAULT_LATCHED
    st = m.Status.decode(host.send(Cmd.STATUS).payload)
    assert st.state == "FAULT" and st.last_fault == code.name


def test_overtemperature_is_caught_before_harm():
    dev = Device(seed=2, faults="overtemp@1")
    pads = []
    for _ in range(500):
        dev.step()
        pads.append(dev.plant.pad)
    assert dev.state == State.FAULT and dev.last_fault == Err.OVER_TEMPERATURE
    assert max(pads) < 50.0 and pads[-1] < max(pads) - 1.0       # cooling once the relay opened


def test_sim_commands_refused_by_a_real_device():
    h = Host(Device(sim=False))
    assert nak_code(finger(h)) == Err.NO_HELLO           # requirement 2 first, as the firmware
    assert h.send(Cmd.HELLO, m.HELLO_REQ.pack(m.PROTOCOL_VERSION)).type == Cmd.HELLO | 0x80
    assert nak_code(finger(h)) == Err.NOT_SUPPORTED


def test_silent_heartbeats_are_not_cached(host):
    # the heartbeat helper sends silent heartbeats with seq 0; an acknowledged heartbeat with
    # the same number must still get its answer
    assert host.send(Cmd.HEARTBEAT, b"\x00", seq=5) is None
    r = host.send(Cmd.HEARTBEAT, b"", seq=5)
    assert r is not None and r.type == Cmd.HEARTBEAT | 0x80
    assert m.TIME.unpack(r.payload)[0] == host.dev.time_us


def test_bytes_stamped_late_feed_the_watchdog_from_then(host):
    # a starved transport catching up on ticks stamps what it read with the caught-up time
    host.upload(np.full(3000, 25.0))
    host.send(Cmd.ARM, m.ARM.pack(0, 200, 30000))
    t0 = host.dev.time_us
    host.dev.receive(encode_frame(1, Cmd.HEARTBEAT, b"\x00"), at_us=t0 + 80_000)
    for _ in range(17):                     # 170 ms: silence counted from t0 + 80 ms only
        host.dev.step()
    assert host.dev.state == State.ARMED
    for _ in range(2):
        host.dev.step()
    assert host.dev.state == State.IDLE and host.dev.last_fault == Err.WATCHDOG


def test_a_new_host_is_a_new_session():
    # audit 34: every host numbers its commands from where it likes (the old driver: from 1);
    # the device answered the second host's HELLO, SET_LIMITS and SET_NEUTRAL from the first
    # host's cached replies without carrying them out, and its UPLOAD_BEGIN too
    dev = Device(seed=3)
    first = Host(dev)
    assert first.send(Cmd.HELLO, m.HELLO_REQ.pack(m.PROTOCOL_VERSION)).type == Cmd.HELLO | 0x80
    assert m.LIMITS.unpack(first.send(Cmd.SET_LIMITS, m.LIMITS.pack(1500, 4200, 1000)).payload) \
        == (1500, 4200, 1000)
    assert m.CENTI.unpack(first.send(Cmd.SET_NEUTRAL, m.CENTI.pack(3200)).payload) == (3200,)
    assert first.send(Cmd.UPLOAD_BEGIN, m.UPLOAD_BEGIN.pack(300, 10_000)).type == 0x90
    second = Host(dev)                                  # same numbers: 1, 2, 3, 4, ...
    assert second.send(Cmd.HELLO, m.HELLO_REQ.pack(m.PROTOCOL_VERSION)).type == Cmd.HELLO | 0x80
    r = second.send(Cmd.SET_LIMITS, m.LIMITS.pack(2000, 3800, 500))
    assert m.LIMITS.unpack(r.payload) == (2000, 3800, 500)
    assert (dev.lim_min, dev.lim_max, dev.lim_rate) == (20.0, 38.0, 5.0)
    assert m.CENTI.unpack(second.send(Cmd.SET_NEUTRAL, m.CENTI.pack(3000)).payload) == (3000,)
    assert dev.neutral == 30.0
    ack = m.COMMIT_ACK.unpack(second.upload(np.full(300, 37.0)).payload)   # begins anew
    assert ack[0] == 300 and ack[2] == 0
    # within the new session a retry is still answered, not acted on
    a = second.send(Cmd.ARM, m.ARM.pack(0, 200, 5000), seq=200)
    assert second.send(Cmd.ARM, m.ARM.pack(0, 200, 5000), seq=200).payload == a.payload
    assert dev.state == State.ARMED


@pytest.mark.parametrize("bit", range(16))
def test_a_corrupted_length_does_not_stall_the_device(host, bit):
    # audit 34: a flipped bit in a heartbeat's length made the device wait for up to 1100 bytes
    # (~570 ms of heartbeats) before its CRC check; the watchdog fired meanwhile
    host.upload(np.full(300, 30.0))
    host.send(Cmd.ARM, m.ARM.pack(0, 200, 5000))
    host.step(5)
    bad = bytearray(encode_frame(0, Cmd.HEARTBEAT, b"\x00"))
    bad[2 + bit // 8] ^= 1 << (bit % 8)                 # the length field, little-endian
    dev = host.dev
    frames = dev.parser.frames
    dev.step()
    dev.receive(bytes(bad))
    dev.receive(encode_frame(0, Cmd.HEARTBEAT, b"\x00"))   # the next heartbeat is parsed at once
    assert dev.parser.frames == frames + 1 and dev.last_rx_us == dev.time_us
    assert dev.parser.buffered == 0
    tel, ev = host.step(30)
    assert [e.kind for e in ev if e.kind == "WATCHDOG"] == [] and dev.state == State.ARMED


# --------------------------------------------------------------------------- safe alone (no host)
def test_nothing_but_hello_status_heartbeat_abort_before_a_hello():
    # Regression: a device restarted mid-session took ARM, uploads and raw profiles without a
    # HELLO, with its watchdog off and the firmware's limits, and played on with a silent host.
    h = Host(Device(seed=3))
    for cmd, payload in ((Cmd.ARM, m.ARM.pack(1, 200, 1000)),
                         (Cmd.UPLOAD_BEGIN, m.UPLOAD_BEGIN.pack(100, 10_000)),
                         (Cmd.SET_LIMITS, m.LIMITS.pack(1500, 4200, 1000)),
                         (Cmd.SET_NEUTRAL, m.CENTI.pack(3000))):
        assert nak_code(h.send(cmd, payload)) == Err.NO_HELLO
    assert h.send(Cmd.STATUS).type == Cmd.STATUS | 0x80
    assert h.send(Cmd.ABORT).type == Cmd.ABORT | 0x80
    assert h.send(Cmd.HEARTBEAT).type == Cmd.HEARTBEAT | 0x80


def test_the_watchdog_does_not_depend_on_a_hello(host):
    host.upload(np.full(3000, 25.0))
    host.send(Cmd.ARM, m.ARM.pack(0, 200, 30000))
    host.dev.hello = False          # whatever forgot the HELLO, an armed device guards itself
    tel, ev = host.step(20, heartbeat=False)
    assert [e.kind for e in ev].count("WATCHDOG") == 1 and host.dev.state == State.IDLE


def _stuck_heater(dev, at_s):
    """Step ``dev`` with a heater stuck from ``at_s``; return the pad temperature per 5 ms step."""
    pads = []
    sub = dev.plant.step

    def spy(*a):                    # the pad at the end of each 10 ms tick and its two 5 ms steps
        y = sub(*a)
        pads.append(dev.plant.pad)
        return y
    dev.plant.step = spy
    dev.faults += [f for f in __import__("experiments.emulators.thermocue.faults", fromlist=["x"])
                   .parse_faults(f"overtemp@{at_s}")]
    for _ in range(int((at_s + 2.0) / 0.01)):
        dev.step()
    return np.array(pads)


@pytest.mark.parametrize("start", ["neutral", "hottest setpoint"])
def test_a_stuck_heater_never_holds_the_pad_above_45_C_for_a_tick(host, start):
    # Regression: the trip was at 48 °C (HARD_MAX_C + 3): 48.6 °C reached, 0.22 s above 45 °C.
    from experiments.emulators.thermocue.device import HARD_MAX_C, SETPOINT_MAX_C
    assert host.send(Cmd.SET_LIMITS, m.LIMITS.pack(1500, 4500, 1000)).type == Cmd.SET_LIMITS | 0x80
    if start != "neutral":
        assert m.CENTI.unpack(host.send(Cmd.SET_NEUTRAL, m.CENTI.pack(4500)).payload)[0] == \
            round(SETPOINT_MAX_C * 100)
        host.step(500)                                     # settled at the highest setpoint
        assert host.dev.state == State.IDLE                # no false trip at the ceiling
    pads = _stuck_heater(host.dev, host.dev.time_us * 1e-6 + 0.5)
    assert host.dev.state == State.FAULT and host.dev.last_fault == Err.OVER_TEMPERATURE
    assert np.count_nonzero(pads > HARD_MAX_C) <= 1        # at most one 10 ms tick above 45 °C
    assert pads.max() < HARD_MAX_C + 0.2


def test_overtemperature_and_sensor_faults_stay_latched_through_abort(host):
    # Regression: the host's ABORT cleared the latch and re-closed the relay within 10-20 ms.
    host.upload(np.full(3000, 30.0))
    host.send(Cmd.ARM, m.ARM.pack(0, 200, 30000))
    host.send(Cmd.SIM_FAULT, m.encode_json({"spec": "overtemp+0.5"}))
    host.step(100)
    assert host.dev.state == State.FAULT
    assert host.send(Cmd.ABORT).type == Cmd.ABORT | 0x80
    host.step(100)                                         # the stuck driver has healed by now
    assert host.dev.state == State.FAULT and host.dev.enabled is False
    assert nak_code(host.send(Cmd.ARM, m.ARM.pack(0, 200, 1000))) == Err.FAULT_LATCHED
    assert nak_code(host.send(Cmd.CLEAR_FAULT, b"please")) == Err.BAD_ARGUMENT
    assert host.send(Cmd.CLEAR_FAULT, m.CLEAR_FAULT_MAGIC).type == Cmd.CLEAR_FAULT | 0x80
    host.step(10)
    assert host.dev.state == State.IDLE and host.dev.enabled is True


def test_a_restart_changes_the_boot_id_and_starts_device_time_again():
    h = Host(Device(seed=4, faults="reboot@1"))
    hello = h.send(Cmd.HELLO, m.HELLO_REQ.pack(m.PROTOCOL_VERSION))
    boot0 = m.HELLO_REPLY_HEAD.unpack_from(hello.payload)[-1]
    h.step(50)
    st = m.Status.decode(h.send(Cmd.STATUS).payload)
    assert st.boot_id == boot0 and st.device_time_s == pytest.approx(0.5)
    h.step(100)                                            # the power cycle at 1 s
    st = m.Status.decode(h.send(Cmd.STATUS).payload)
    assert st.boot_id != boot0 and st.device_time_s == pytest.approx(0.5)
    assert nak_code(h.send(Cmd.ARM, m.ARM.pack(1, 200, 1000))) == Err.NO_HELLO
    h.step(200)
    assert h.dev.boots == 1                                # once per spec, not at every 1 s


def test_a_finger_still_pressing_is_not_a_new_contact(host):
    # Regression: re-armed while the finger still pressed, a trial "started" at once and ended
    # 0.05 s later. Contact needs the force below half the threshold since ARM first.
    host.upload(np.full(300, 32.0))
    finger(host, press_after_s=0.0, hold_s=3.0)            # pressing before ARM, until 3 s
    host.step(100)
    host.send(Cmd.ARM, m.ARM.pack(0, 200, 30000))
    tel, ev = host.step(150)                               # ready, still pressed: no contact
    assert "READY" in [e.kind for e in ev] and "CONTACT" not in [e.kind for e in ev]
    tel, ev = host.step(100)                               # released at 3 s
    assert "CONTACT" not in [e.kind for e in ev]
    finger(host, press_after_s=0.1, hold_s=3.0)            # a fresh touch
    tel, ev = host.step(50)
    assert [e.kind for e in ev].count("CONTACT") == 1


def test_the_device_answers_through_the_command_part_it_holds_and_a_subclass_overrides_a_handler():
    # composition: the device's replies come from ``device.commands``; a HostCommands subclass
    # put in its place (a test's misbehaving firmware) has its own _on_* handler called
    from experiments.emulators.thermocue.device_commands import HostCommands

    class SilentAbort(HostCommands):
        def _on_abort(self, seq, cmd, p):
            return b""                                 # never acknowledges ABORT

    dev = Device(seed=1)
    assert isinstance(dev.commands, HostCommands) and dev.commands.device is dev
    h = Host(dev)
    assert h.send(Cmd.HELLO, m.HELLO_REQ.pack(m.PROTOCOL_VERSION)).type == Cmd.HELLO | 0x80
    assert h.send(Cmd.ABORT).type == Cmd.ABORT | 0x80
    dev.commands = SilentAbort(dev)
    assert h.send(Cmd.ABORT) is None
    assert h.send(Cmd.STATUS).type == Cmd.STATUS | 0x80    # the other handlers are the base's
