"""The emulated firmware's command handling: every host frame in, its reply out.

:class:`HostCommands` is the part of :class:`~experiments.emulators.thermocue.device.Device` that
answers the host (HELLO, limits, neutral, upload, ARM, ABORT, STATUS, the emulator-only "sim"
commands), held as ``device.commands``: it reads frames from the device's parser, acts on the
device's state and keeps the reply cache (``device.cache``) that makes every command safe to
retry. The device's own 10 ms tick (state machine, watchdog, safety monitors, telemetry) is in
:mod:`.device`. One short ``_on_*`` handler per command, looked up by name on the instance, so a
subclass (a test's misbehaving firmware) can override any of them or :meth:`HostCommands._handle`.
"""
from __future__ import annotations

import struct
import zlib

import numpy as np

from experiments.display.thermocue import messages as m
from .device_constants import (BEFORE_HELLO, END_ABORTED, END_COMPLETE, FIRMWARE, HARD_MIN_C, HARD_RATE_C_PER_S,
                               IMAGE_ID, LATCHED_FAULTS, MAX_POINTS, MIN_DT_US, OVERTEMP_C,
                               SETPOINT_MAX_C, SIM_MAX_S, STALE_US, TRIP_TEST_MIN_C, WATCHDOG_MS)
from .faults import parse_faults
from experiments.display.thermocue.framing import encode_frame
from experiments.display.thermocue.messages import Cmd, Err, Event, Mode, State
from .pad_physics import (FINGER_ON_PAD_MODEL, FingerScript, FingerSkin, PassiveSample,
                          finger_pad_resistance)

__all__ = ["HostCommands"]

#: Every silent heartbeat frame (payload 0: feed the watchdog, no reply), one per number.
_SILENT_HEARTBEATS = frozenset(encode_frame(s, Cmd.HEARTBEAT, b"\x00") for s in range(256))


def _within(args: dict, key: str, default, lo: float, hi: float, none_ok: bool = False):
    """``args[key]`` (or ``default``), a number in ``[lo, hi]`` (NaN and inf are not); else
    ValueError naming the key (the device NAKs BAD_ARGUMENT)."""
    v = args.get(key, default)
    if v is None and none_ok:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not lo <= v <= hi:
        raise ValueError(f"{key}: expected a number in {lo:g}..{hi:g}, got {v!r}")
    return float(v)


def sample_from_args(a: dict) -> PassiveSample:
    """SIM_SAMPLE's arguments as the passive sample under the finger, checked (ValueError names
    the bad field; an unknown material raises too): the one reading of them, for both cores."""
    if not isinstance(a.get("material", ""), str):
        raise ValueError("SIM_SAMPLE: material is a name")
    sample = PassiveSample(a.get("material", "stainless_steel"),
                           _within(a, "roughness_m", 1.6e-6, 1e-9, 1e-3),
                           _within(a, "thickness_m", 3e-3, 1e-5, 0.1, none_ok=True),
                           _within(a, "temperature_C", 20.0, 0.0, 60.0))
    from stimuli import material
    material(sample.material)                                  # unknown name -> error now
    return sample


def finger_from_args(a: dict) -> FingerScript:
    """SIM_FINGER's arguments as a finger script, checked (ValueError): for both cores."""
    bad = [k for k, v in a.items() if isinstance(v, bool) or not isinstance(v, (int, float))]
    if bad:
        raise ValueError(f"SIM_FINGER: {', '.join(map(str, bad))}: expected a number")
    f = FingerScript(**{k: float(v) for k, v in a.items()})
    if not (0.05 <= f.force_N <= 20 and 0 < f.hold_s <= SIM_MAX_S
            and 0 <= f.press_after_s <= SIM_MAX_S
            and 100e-6 <= f.skin_thickness_m <= 5e-3 and 25 <= f.skin_temperature_C <= 40):
        raise ValueError(f"finger out of range: {a}")
    return f


#: Each command's handler: the name of a method of :class:`HostCommands`.
_HANDLERS = {
    Cmd.HEARTBEAT: "_on_heartbeat",
    Cmd.HELLO: "_on_hello",
    Cmd.STATUS: "_on_status",
    Cmd.ABORT: "_on_abort",
    Cmd.CLEAR_FAULT: "_on_clear_fault",
    Cmd.SET_TRIP: "_on_set_trip",
    Cmd.SET_NEUTRAL: "_on_set_neutral",
    Cmd.SET_LIMITS: "_on_set_limits",
    Cmd.UPLOAD_BEGIN: "_on_upload_begin",
    Cmd.UPLOAD_CHUNK: "_on_upload_chunk",
    Cmd.UPLOAD_COMMIT: "_on_upload_commit",
    Cmd.ARM: "_on_arm",
    Cmd.SIM_SAMPLE: "_on_sim",
    Cmd.SIM_FINGER: "_on_sim",
    Cmd.SIM_FAULT: "_on_sim",
}


class HostCommands:
    """Command handling of the emulated firmware: the part ``device.commands`` of a
    :class:`~.device.Device`.

    Parameters
    ----------
    device : Device
        The firmware whose state the commands read and change, and whose output they write.
    """

    def __init__(self, device):
        self.device = device
        self._handlers = {cmd: getattr(self, name) for cmd, name in _HANDLERS.items()}

    def receive(self, data: bytes, at_us: int | None = None) -> None:
        """Handle bytes from the host (any number of frames, garbage tolerated).

        Parameters
        ----------
        data : bytes
        at_us : int, optional, µs
            Device time at which the bytes are known to have arrived, when the transport runs
            behind (a starved emulator process catching up on ticks): valid frames feed the
            watchdog as of that time. Default: now (``time_us``).
        """
        dev = self.device
        if dev.stalled:
            return
        stamp = dev.time_us if at_us is None else max(dev.time_us, int(at_us))
        if data:
            dev.last_byte_us = stamp
        if type(data) is bytes and data in _SILENT_HEARTBEATS and not dev.parser.buffered:
            dev.parser.frames += 1             # what the parser would say of it, without parsing
            dev.heard(stamp)                   # (the host's commonest frame: every 10 ms)
            return
        self._on_frames(dev.parser.feed(data), stamp)

    def drop_stale_candidate(self) -> None:
        """A partial frame that got no byte for 0.2 s of device time: skip one byte, search
        again (§1), as the firmware does each tick; else its length would swallow what the
        host sends next."""
        dev = self.device
        if (dev.parser.buffered and not dev.stalled
                and dev.time_us - dev.last_byte_us > STALE_US):
            dev.last_byte_us = dev.time_us
            self._on_frames(dev.parser.drop_candidate(), dev.time_us)

    def _on_frames(self, frames, stamp: int) -> None:
        dev = self.device
        for fr in frames:
            dev.heard(stamp)
            if fr.type == Cmd.HEARTBEAT and fr.payload == b"\x00":
                continue                           # silent: no reply, nothing to cache
            hello = fr.type == Cmd.HELLO           # a new session: always carried out
            hit = None if hello else dev.cache.get(fr.type)
            if hit is not None and hit[0] == fr.seq:
                dev.out += hit[1]                  # a retry: the same answer, not a second action
                continue
            try:
                reply = self._handle(fr.seq, fr.type, fr.payload)
            except (struct.error, IndexError, ValueError) as exc:
                reply = self._nak(fr.seq, fr.type, Err.BAD_LENGTH, f"malformed payload: {exc}")
            if not hello:
                dev.cache[fr.type] = (fr.seq, reply)

    def _nak(self, seq, cmd, code, text="") -> bytes:
        return self.device.send(seq, m.Msg.NAK, m.NAK_HEAD.pack(cmd & 0xFF, int(code)) +
                                text.encode("utf-8")[:200])

    def _ack(self, seq, cmd, payload=b"") -> bytes:
        return self.device.send(seq, (cmd | m.REPLY_BIT) & 0xFF, payload)

    def _handle(self, seq: int, cmd: int, p: bytes) -> bytes:
        """The reply frame(s) to command ``cmd`` (its ``_on_*`` handler; b"" for none)."""
        dev = self.device
        if not dev.hello and cmd not in BEFORE_HELLO:
            return self._nak(seq, cmd, Err.NO_HELLO, "no HELLO since power-up")
        handler = self._handlers.get(cmd)
        if handler is None:
            return self._nak(seq, cmd, Err.UNKNOWN_COMMAND, f"type 0x{cmd:02x}")
        return handler(seq, cmd, p)

    def _on_heartbeat(self, seq: int, cmd: int, p: bytes) -> bytes:
        """HEARTBEAT: the device time (a silent one, payload 0, is not answered)."""
        dev = self.device
        if p == b"\x00":
            return b""                         # a silent heartbeat: no reply wanted
        return self._ack(seq, cmd, m.TIME.pack(dev.time_us - dev.boot_us))

    def _on_hello(self, seq: int, cmd: int, p: bytes) -> bytes:
        """HELLO: a new host; the device forgets the last host's replies and upload."""
        dev = self.device
        (ver,) = m.HELLO_REQ.unpack(p)
        if ver != m.PROTOCOL_VERSION:
            return self._nak(seq, cmd, Err.NOT_SUPPORTED,
                             f"protocol {ver} not supported (device speaks {m.PROTOCOL_VERSION})")
        # a new host: its numbers say nothing about the last host's, so forget the replies
        # kept for retries (else its SET_LIMITS, SET_NEUTRAL, UPLOAD_BEGIN, ... could be
        # answered from the cache and not carried out) and any half-done upload
        dev.cache.clear()
        dev.upload = None
        dev.hello = True
        dev.set_trip(OVERTEMP_C)               # a lowered test trip never outlives its host
        caps = "playback,record,force4,ir,ambient" + (",sim" if dev.sim else "")
        head = m.HELLO_REPLY_HEAD.pack(m.PROTOCOL_VERSION, 100, m.centi(HARD_MIN_C),
                                       m.centi(SETPOINT_MAX_C), int(HARD_RATE_C_PER_S * 100),
                                       m.centi(dev.neutral), WATCHDOG_MS, MAX_POINTS, MIN_DT_US,
                                       dev.boot_id)
        dev.log("hello")
        return self._ack(seq, cmd, head + m.encode_strings(dev.device_id, FIRMWARE, caps, IMAGE_ID))

    def _on_status(self, seq: int, cmd: int, p: bytes) -> bytes:
        """STATUS: the device's state, sensors and last trial."""
        return self._ack(seq, cmd, self._status())

    def _on_abort(self, seq: int, cmd: int, p: bytes) -> bytes:
        """ABORT: stop whatever runs (a latched fault stays latched)."""
        dev = self.device
        if dev.state in (State.ARMED, State.PLAYING, State.RECORDING):
            dev.end_reason = END_ABORTED
            dev.event(Event.END, END_ABORTED, "aborted by host")
        if dev.state == State.FAULT and dev.last_fault in LATCHED_FAULTS:
            dev.log("abort_latched", code=m.error_name(dev.last_fault))
            return self._ack(seq, cmd)         # stopped already; the latch stays (relay open)
        dev.set_state(State.IDLE, "abort")
        dev.enabled = True
        return self._ack(seq, cmd)

    def _on_clear_fault(self, seq: int, cmd: int, p: bytes) -> bytes:
        """CLEAR_FAULT: the operator's reset of a latched fault."""
        dev = self.device
        if p != m.CLEAR_FAULT_MAGIC:
            return self._nak(seq, cmd, Err.BAD_ARGUMENT, "CLEAR_FAULT needs the operator's payload")
        if dev.state == State.FAULT:
            dev.log("fault_cleared", code=m.error_name(dev.last_fault))
            dev.set_state(State.IDLE, "operator reset")
            dev.enabled = True
            dev.plant.tripped = False
        return self._ack(seq, cmd)

    def _on_set_trip(self, seq: int, cmd: int, p: bytes) -> bytes:
        """SET_TRIP: lower the over-temperature trip for a test (never above its own)."""
        dev = self.device
        # a qualification test lowers the over-temperature trip; never above OVERTEMP_C
        if len(p) != m.CENTI.size:
            return self._nak(seq, cmd, Err.BAD_LENGTH, "malformed payload")
        (v,) = m.CENTI.unpack(p)
        if dev.state != State.IDLE and v / 100.0 < OVERTEMP_C:    # restoring: any state
            return self._nak(seq, cmd, Err.BAD_STATE, f"SET_TRIP in state {dev.state.name}")
        dev.set_trip(min(max(v / 100.0, TRIP_TEST_MIN_C), OVERTEMP_C))
        return self._ack(seq, cmd, m.CENTI.pack(m.centi(dev.trip_C)))

    def _on_set_neutral(self, seq: int, cmd: int, p: bytes) -> bytes:
        """SET_NEUTRAL: the temperature held between trials, clamped to the limits."""
        dev = self.device
        (v,) = m.CENTI.unpack(p)
        if dev.state not in (State.IDLE, State.FAULT):
            return self._nak(seq, cmd, Err.BAD_STATE, f"SET_NEUTRAL in state {dev.state.name}")
        dev.neutral = min(max(v / 100.0, dev.lim_min), dev.lim_max)
        dev.log("neutral", asked_C=v / 100.0, neutral_C=dev.neutral)
        return self._ack(seq, cmd, m.CENTI.pack(m.centi(dev.neutral)))

    def _on_set_limits(self, seq: int, cmd: int, p: bytes) -> bytes:
        """SET_LIMITS: the host's range and rate, inside the device's own."""
        dev = self.device
        lo, hi, rate = m.LIMITS.unpack(p)
        lo, hi = max(lo / 100.0, HARD_MIN_C), min(hi / 100.0, SETPOINT_MAX_C)
        if dev.state != State.IDLE:
            return self._nak(seq, cmd, Err.BAD_STATE, f"SET_LIMITS in state {dev.state.name}")
        if not lo < hi or rate <= 0:
            return self._nak(seq, cmd, Err.BAD_ARGUMENT, "empty range or zero rate")
        dev.lim_min, dev.lim_max = lo, hi
        dev.lim_rate = min(rate / 100.0, HARD_RATE_C_PER_S)
        dev.neutral = min(max(dev.neutral, lo), hi)
        dev.log("limits", min_C=lo, max_C=hi, rate_C_per_s=dev.lim_rate,
                neutral_C=dev.neutral)
        return self._ack(seq, cmd, m.LIMITS.pack(m.centi(lo), m.centi(hi),
                                                 int(round(dev.lim_rate * 100))))

    def _on_upload_begin(self, seq: int, cmd: int, p: bytes) -> bytes:
        """UPLOAD_BEGIN: discard any profile; start an upload of n samples."""
        dev = self.device
        n, dt_us = m.UPLOAD_BEGIN.unpack(p)
        if dev.state != State.IDLE:
            return self._nak(seq, cmd, Err.BAD_STATE, f"UPLOAD in state {dev.state.name}")
        # any UPLOAD_BEGIN in IDLE discards the committed profile and any upload, also one
        # whose arguments are refused: a host that refused a profile is never left with it
        dev.profile = None
        dev.upload = None
        if not (2 <= n <= MAX_POINTS) or dt_us < MIN_DT_US:
            return self._nak(seq, cmd, Err.OUT_OF_RANGE,
                             f"n={n} (2..{MAX_POINTS}), dt={dt_us} µs (≥ {MIN_DT_US})")
        dev.upload = dict(n=n, dt_us=dt_us, data=bytearray(2 * n), got=np.zeros(n, bool))
        dev.profile = None
        return self._ack(seq, cmd)

    def _on_upload_chunk(self, seq: int, cmd: int, p: bytes) -> bytes:
        """UPLOAD_CHUNK: samples at an offset; acknowledged with their CRC."""
        dev = self.device
        off, count = m.UPLOAD_CHUNK_HEAD.unpack_from(p)
        body = p[m.UPLOAD_CHUNK_HEAD.size:]
        if dev.upload is None:
            return self._nak(seq, cmd, Err.BAD_STATE, "no UPLOAD_BEGIN")
        if len(body) != 2 * count:
            return self._nak(seq, cmd, Err.BAD_LENGTH, f"{count} samples need {2 * count} bytes")
        if off + count > dev.upload["n"]:
            return self._nak(seq, cmd, Err.OUT_OF_RANGE, f"chunk {off}+{count} > {dev.upload['n']}")
        dev.upload["data"][2 * off:2 * (off + count)] = body
        dev.upload["got"][off:off + count] = True
        return self._ack(seq, cmd, m.UPLOAD_CHUNK_ACK.pack(off, count, zlib.crc32(body)))

    def _on_upload_commit(self, seq: int, cmd: int, p: bytes) -> bytes:
        """UPLOAD_COMMIT: check the whole profile's CRC, clamp it to the limits, keep it."""
        dev = self.device
        (crc,) = m.COMMIT.unpack(p)
        up = dev.upload
        if up is None or not up["got"].all():
            return self._nak(seq, cmd, Err.PROFILE_INCOMPLETE, "missing samples")
        mine = zlib.crc32(bytes(up["data"]))
        if mine != crc:
            return self._nak(seq, cmd, Err.PROFILE_CRC, f"crc32 {mine:08x} != {crc:08x}")
        vals = np.frombuffer(bytes(up["data"]), dtype="<i2").astype(float) / 100.0
        clamped = np.clip(vals, dev.lim_min, dev.lim_max)
        n_clamped = int(np.count_nonzero(clamped != vals))
        if n_clamped:
            dev.log("profile_clamped", samples=n_clamped)
        dev.profile = (clamped.tolist(), up["dt_us"])
        dev.upload = None
        return self._ack(seq, cmd, m.COMMIT_ACK.pack(len(vals), mine, min(n_clamped, 65535)))

    def _on_arm(self, seq: int, cmd: int, p: bytes) -> bytes:
        """ARM: wait for the starting temperature, then a fresh contact."""
        dev = self.device
        mode, thr, maxdur = m.ARM.unpack(p)
        if dev.state == State.FAULT:
            return self._nak(seq, cmd, Err.FAULT_LATCHED, f"fault {m.error_name(dev.last_fault)}")
        if dev.state != State.IDLE:
            return self._nak(seq, cmd, Err.BAD_STATE, f"ARM in state {dev.state.name}")
        if mode not in (Mode.PLAYBACK, Mode.RECORD) or thr == 0 or maxdur == 0:
            return self._nak(seq, cmd, Err.BAD_ARGUMENT, "mode, threshold or duration")
        if mode == Mode.PLAYBACK and dev.profile is None:
            return self._nak(seq, cmd, Err.PROFILE_INCOMPLETE, "no profile committed")
        dev.arm_mode = Mode(mode)
        dev.threshold = thr / 100.0
        dev.max_duration_us = maxdur * 1000
        dev.ready = False
        dev.ready_count = 0
        dev.fresh = False              # contact only after the force fell below half the
        dev.contact_us = 0             # threshold since ARM: a fresh touch, not the last one
        dev.touch_us = None
        dev.end_reason = END_COMPLETE
        dev.set_state(State.ARMED, f"arm {dev.arm_mode.name.lower()}")
        return self._ack(seq, cmd, m.COUNTER.pack(dev.counter))

    def _on_sim(self, seq: int, cmd: int, p: bytes) -> bytes:
        """SIM_SAMPLE, SIM_FINGER, SIM_FAULT: the emulator's scripted bench (JSON arguments)."""
        dev = self.device
        if not dev.sim:
            return self._nak(seq, cmd, Err.NOT_SUPPORTED, "not an emulator")
        try:
            args = m.decode_json(p)
            if not isinstance(args, dict):
                raise ValueError("a sim command's payload is a JSON object")
            reply = self._sim(cmd, args)
        except (ValueError, TypeError, KeyError) as exc:
            return self._nak(seq, cmd, Err.BAD_ARGUMENT, str(exc))
        return self._ack(seq, cmd, m.encode_json(reply))

    def _sim(self, cmd, a):
        dev = self.device
        if cmd == Cmd.SIM_SAMPLE:
            dev.sample = sample_from_args(a)
            return dict(vars(dev.sample))
        if cmd == Cmd.SIM_FINGER:
            f = finger_from_args(a)
            # the finger waits for the cue: if armed but not ready, its clock starts at READY
            if not (dev.state == State.ARMED and not dev.ready):
                f.start_us = dev.time_us
            dev.finger = f
            if dev.r_finger_pad is None:
                dev.r_finger_pad = finger_pad_resistance()
            dev.skin = FingerSkin(f.skin_thickness_m, f.skin_temperature_C, dev.tick_s,
                                  dev.r_finger_pad)
            dev.log("finger", **a)
            reply = dict(start_s=None if f.start_us is None else f.start_us * 1e-6)
            # what models the finger's next touch, and the planner's decisions (for the host's log)
            if dev.state == State.ARMED and dev.arm_mode == Mode.RECORD:
                reply["sample_model"] = {k: dict(v) for k, v in dev.sample_model()[2].items()}
            elif dev.state == State.ARMED:
                reply["finger_on_pad_model"] = dict(FINGER_ON_PAD_MODEL)
            return reply
        specs = parse_faults(a["spec"], where="sim_fault")
        now = dev.time_us * 1e-6
        shifted = [s.shifted(now) for s in specs]
        dev.faults += shifted
        for listener in dev.fault_listeners:
            listener(shifted)
        if not dev.stalled and dev.fault_active("stall"):
            dev.stalled = True                     # hangs right after this reply
            dev.log("stall")
        dev.log("fault_injected", spec=a["spec"])
        return dict(now_s=now, faults=len(specs))

    def _status(self) -> bytes:
        """STATUS's payload: the device's state, sensors and last trial, now."""
        dev = self.device
        f = dev.forces
        return m.STATUS_REPLY.pack(
            dev.state, dev.last_fault, dev.time_us - dev.boot_us, m.centi(dev.sp),
            m.centi(dev.contact_C),
            m.centi(dev.ambient_C), m.centi(dev.finger_C), m.centi(dev.plant.hs),
            m.centi(f[0]), m.centi(f[1]), m.centi(f[2]), m.centi(f[3]), m.centi(dev.neutral),
            0 if dev.profile is None else len(dev.profile[0]),
            0 if not dev.contact_us else dev.contact_us - dev.boot_us, dev.end_reason,
            dev.counter, dev.trials, dev.boot_id)

