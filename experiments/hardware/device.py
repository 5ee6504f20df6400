"""The emulated display's firmware: command handling, state machine, watchdog, safety monitors.

A :class:`Device` knows nothing about clocks or ports: a transport feeds it host bytes
(:meth:`Device.receive`), advances it in fixed ticks (:meth:`Device.step`, 10 ms of device time)
and takes what it wants to send (:meth:`Device.take_output`). :mod:`protocol_emulator` runs it
in-process (real or virtual clock), :mod:`pty_server` on a pseudo-terminal.

States and transitions (``docs/display-protocol.md`` has the full table)::

    IDLE --ARM--> ARMED --(ready, force >= threshold)--> PLAYING | RECORDING --(end)--> IDLE
    any --ABORT--> IDLE;  ARMED/PLAYING/RECORDING --(watchdog)--> IDLE (neutral, fault latched)
    any --(over-temperature, sensor failure)--> FAULT (Peltier relay open, latched)
    FAULT --CLEAR_FAULT (operator reset)--> IDLE;  ABORT leaves a latched fault latched

Safe on its own (docs/display-protocol.md §6, firmware requirements): the watchdog runs whenever
the device is armed, playing or recording, HELLO or not; every command but HELLO, HEARTBEAT,
STATUS and ABORT is refused (NO_HELLO) until a HELLO; the over-temperature cut acts inside the
5 ms control loop at :data:`OVERTEMP_C` < :data:`HARD_MAX_C`; each power-up draws a new boot id
(HELLO and STATUS) and restarts device time at 0, so a host can tell a restart.
"""
from __future__ import annotations

import math
import struct
import zlib
from binascii import crc_hqx
from collections import deque

import numpy as np

from . import messages as m
from .faults import FaultSpec, parse_faults
from .framing import FrameParser, crc8, encode_frame
from .messages import Cmd, Err, Event, Mode, State
from .pad_physics import (CONTACT_AREA_M2, FingerSkin, PadParams, PadPlant, PassiveSample,
                          finger_pad_resistance, normal_stream)

__all__ = ["Device", "FingerScript", "FIRMWARE", "HARD_MIN_C", "HARD_MAX_C", "SETPOINT_MAX_C",
           "OVERTEMP_C", "HARD_RATE_C_PER_S", "LATCHED_FAULTS"]

FIRMWARE = "thermocue-emu 1.0.0"
HARD_MIN_C = 10.0          # the firmware's own range: setpoints are clamped to it, always
HARD_MAX_C = 45.0          # the skin-safe maximum: the pad is never above it for a tick
SETPOINT_MAX_C = 44.5      # highest setpoint (HELLO's hard_max): a margin below the trip
HARD_RATE_C_PER_S = 100.0  # largest setpoint step per second the firmware ever makes
DEFAULT_NEUTRAL_C = 32.0
WATCHDOG_MS = 90           # host silence that trips the watchdog, checked every 10 ms tick:
                           # the setpoint goes to neutral ≤ WATCHDOG_MS + one tick = 100 ms
                           # after the last host frame (docs/display-protocol.md, timing budget)
RATE_WINDOW_TICKS = 10     # the rate limit is also held over any 10 ticks (0.1 s), the host's
                           # window (SafetyLimits.rate_window_s): playback may step faster for a
                           # tick (a sqrt(t) profile's first samples), never faster over 0.1 s
RATE_SLACK_C = 0.01        # one setpoint resolution step, as the host's check allows
MAX_POINTS = 65536         # 65.5 s at 1 ms, 655 s at 10 ms
MIN_DT_US = 1000
TICK_US = 10_000
READY_BAND_C = 0.1         # |contact - first sample| to declare READY
RELEASE_MS = 50            # force below half the threshold this long ends a trial
OVERTEMP_C = HARD_MAX_C - 0.2   # contact sensor reading that cuts the Peltier current within
                                # the same 5 ms control step (PadPlant.trip_C): the sensor's lag
                                # and one step of a stuck full-current heater stay below 45 °C
HEATSINK_MAX_C = 70.0
STUCK_SAMPLES = 20         # identical raw readings in a row (100 ms at 200 Hz)
_IDLE, _ARMED, _PLAYING, _RECORDING, _FAULT = (State.IDLE, State.ARMED, State.PLAYING,
                                               State.RECORDING, State.FAULT)
_ACTIVE = (State.ARMED, State.PLAYING, State.RECORDING)
_PLAYBACK, _RECORD = Mode.PLAYBACK, Mode.RECORD
_TEL_HEAD = struct.Struct("<HBB")
_TEL_PREFIX = [h + bytes((crc8(h),)) for h in
               (_TEL_HEAD.pack(m.TELEMETRY.size, q, m.Msg.TELEMETRY) for q in range(256))]
_TEL_PACK = m.TELEMETRY.pack
_CRC = struct.Struct("<H")
END_COMPLETE, END_RELEASED, END_MAX_DURATION, END_ABORTED, END_FAULT = 0, 1, 2, 3, 4
#: Faults that stay latched through ABORT until an operator reset (CLEAR_FAULT).
LATCHED_FAULTS = (Err.OVER_TEMPERATURE, Err.SENSOR_FAILURE, Err.SENSOR_STUCK)
#: Commands a device carries out before any HELLO (everything else: NAK NO_HELLO).
_BEFORE_HELLO = (Cmd.HELLO, Cmd.HEARTBEAT, Cmd.STATUS, Cmd.ABORT, Cmd.CLEAR_FAULT,
                 Cmd.SIM_SAMPLE, Cmd.SIM_FINGER, Cmd.SIM_FAULT)


def _boot_id(seed: int, boots: int) -> int:
    """A power-up's boot id (non-zero, different at every power-up of one device)."""
    return (zlib.crc32(f"{seed}:{boots}".encode()) or 1) & 0xFFFFFFFF


class FingerScript:
    """A scripted fingertip: approach, press, hold, release (times in s, forces in N).

    The press ramps to 1.15 × ``force_N`` in 0.15 s (people overshoot a little), settles to
    ``force_N`` with a 0.2 s time constant, holds for ``hold_s`` from the start of the press, and
    releases in 0.1 s. The four pressure sensors share the force 27/24/26/23 %.
    """

    SHARES = (0.27, 0.24, 0.26, 0.23)

    def __init__(self, press_after_s=0.3, force_N=2.0, hold_s=20.0, skin_thickness_m=650e-6,
                 skin_temperature_C=35.5):
        self.press_after_s = float(press_after_s)
        self.force_N = float(force_N)
        self.hold_s = float(hold_s)
        self.skin_thickness_m = float(skin_thickness_m)
        self.skin_temperature_C = float(skin_temperature_C)
        self.start_us = None     # set when the script starts

    def force(self, t_us: int) -> float:
        if self.start_us is None:
            return 0.0
        tau = (t_us - self.start_us) * 1e-6 - self.press_after_s
        F = self.force_N
        if tau <= 0.0:
            return 0.0
        if tau < 0.15:
            return 1.15 * F * tau / 0.15
        if tau < self.hold_s:
            return F * (1.0 + 0.15 * math.exp(-(tau - 0.15) / 0.2))
        if tau < self.hold_s + 0.1:
            return F * (1.0 - (tau - self.hold_s) / 0.1)
        return 0.0


class Device:
    """The emulated display (see module docstring).

    Parameters
    ----------
    seed : int
        Seeds sensor noise and link faults.
    faults : str or list of FaultSpec
        Device-side faults (stall, stuck_sensor, sensor_range, overtemp); link faults are the
        transport's business but are accepted here and ignored.
    sim : bool
        Whether the emulator-only "sim" commands are offered.
    log : callable, optional
        Called with a dict for every state change, fault and watchdog trip.
    params : PadParams
    """

    def __init__(self, seed: int = 0, faults=None, sim: bool = True, log=None,
                 params: PadParams | None = None, device_id: str = "EMU-0001"):
        self.params = params or PadParams()
        self.tick_s = TICK_US * 1e-6
        self.time_us = 0
        self.parser = FrameParser()
        self.out = bytearray()
        self.sim = sim
        self.device_id = device_id
        self._log = log
        self.noise = normal_stream(seed + 1)
        self.faults: list[FaultSpec] = (parse_faults(faults) if isinstance(faults, (str, type(None)))
                                        else list(faults))
        self.state = State.IDLE
        self.last_fault = 0
        self.neutral = DEFAULT_NEUTRAL_C
        self.lim_min, self.lim_max, self.lim_rate = HARD_MIN_C, SETPOINT_MAX_C, 10.0
        self.plant = PadPlant(self.params, self.tick_s, self.neutral, seed=seed)
        self.plant.trip_C = OVERTEMP_C
        self.seed = seed
        self.boots = 0
        self.boot_us = 0                   # device time counts from the last power-up
        self.boot_id = _boot_id(seed, 0)
        self._reboots_done = set()
        self.sp = self.neutral
        self._sp_window = deque([self.sp], maxlen=RATE_WINDOW_TICKS)   # setpoints, last 0.1 s
        self.enabled = True
        self.hello = False
        self.last_rx_us = 0
        self.cache = {}                    # command type -> (seq, reply bytes)
        self.upload = None                 # dict while uploading
        self.profile = None                # committed: (values °C list, dt_us)
        self.arm_mode = Mode.PLAYBACK
        self.threshold = 2.0
        self.max_duration_us = 20_000_000
        self.ready = False
        self.ready_count = 0
        self.fresh = False
        self.contact_us = 0
        self.touch_us = None
        self.release_count = 0
        self.end_reason = END_COMPLETE
        self.counter = 0
        self.tx_seq = 0
        self.trials = 0
        self.finger: FingerScript | None = None
        self.skin: FingerSkin | None = None
        self.sample = PassiveSample()
        self.curves = None
        self.forces = (0.0, 0.0, 0.0, 0.0)
        self.finger_C = self.params.room
        self.ambient_C = self.params.room
        self.contact_C = self.plant.sensor
        self.stalled = False
        self.fault_listeners = []          # transports that apply link faults (drop, delay, ...)
        self._r_fp = finger_pad_resistance()     # imports stimuli now, not mid-trial

    # ------------------------------------------------------------------ output helpers
    def log(self, kind: str, **fields) -> None:
        if self._log is not None:
            self._log(dict(t_s=round(self.time_us * 1e-6, 6), event=kind, state=self.state.name,
                           setpoint_C=round(self.sp, 3), pad_C=round(self.plant.pad, 3), **fields))

    def _send(self, seq: int, mtype: int, payload: bytes = b"") -> bytes:
        frame = encode_frame(seq, mtype, payload)
        self.out += frame
        return frame

    def _event(self, kind: Event, arg: int = 0, text: str = "") -> None:
        self.tx_seq = (self.tx_seq + 1) & 0xFF
        self._send(self.tx_seq, m.Msg.EVENT,
                   m.EVENT_HEAD.pack(kind, self.time_us - self.boot_us, arg)
                   + text.encode("utf-8")[:200])

    def take_output(self) -> bytes:
        """Bytes waiting to go to the host (and forget them)."""
        if not self.out:
            return b""
        data = bytes(self.out)
        self.out.clear()
        return data

    def _set_state(self, new: State, why: str) -> None:
        if new != self.state:
            old = self.state
            self.state = new
            self.log("state", old=old.name, why=why)

    # ------------------------------------------------------------------ host input
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
        if self.stalled:
            return
        stamp = self.time_us if at_us is None else max(self.time_us, int(at_us))
        for fr in self.parser.feed(data):
            self.last_rx_us = stamp
            if fr.type == Cmd.HEARTBEAT and fr.payload == b"\x00":
                continue                           # silent: no reply, nothing to cache
            hello = fr.type == Cmd.HELLO           # a new session: always carried out
            hit = None if hello else self.cache.get(fr.type)
            if hit is not None and hit[0] == fr.seq:
                self.out += hit[1]                 # a retry: the same answer, not a second action
                continue
            try:
                reply = self._handle(fr.seq, fr.type, fr.payload)
            except (struct.error, IndexError, ValueError) as exc:
                reply = self._nak(fr.seq, fr.type, Err.BAD_LENGTH, f"malformed payload: {exc}")
            if not hello:
                self.cache[fr.type] = (fr.seq, reply)

    def _nak(self, seq, cmd, code, text="") -> bytes:
        return self._send(seq, m.Msg.NAK, m.NAK_HEAD.pack(cmd & 0xFF, int(code)) +
                          text.encode("utf-8")[:200])

    def _ack(self, seq, cmd, payload=b"") -> bytes:
        return self._send(seq, (cmd | m.REPLY_BIT) & 0xFF, payload)

    def _handle(self, seq: int, cmd: int, p: bytes) -> bytes:
        if not self.hello and cmd not in _BEFORE_HELLO:
            return self._nak(seq, cmd, Err.NO_HELLO, "no HELLO since power-up")
        if cmd == Cmd.HEARTBEAT:
            if p == b"\x00":
                return b""                         # a silent heartbeat: no reply wanted
            return self._ack(seq, cmd, m.TIME.pack(self.time_us - self.boot_us))
        if cmd == Cmd.HELLO:
            (ver,) = m.HELLO_REQ.unpack(p)
            if ver != m.PROTOCOL_VERSION:
                return self._nak(seq, cmd, Err.NOT_SUPPORTED,
                                 f"protocol {ver} not supported (device speaks {m.PROTOCOL_VERSION})")
            # a new host: its numbers say nothing about the last host's, so forget the replies
            # kept for retries (else its SET_LIMITS, SET_NEUTRAL, UPLOAD_BEGIN, ... could be
            # answered from the cache and not carried out) and any half-done upload
            self.cache.clear()
            self.upload = None
            self.hello = True
            caps = "playback,record,force4,ir,ambient" + (",sim" if self.sim else "")
            head = m.HELLO_REPLY_HEAD.pack(m.PROTOCOL_VERSION, 100, m.centi(HARD_MIN_C),
                                           m.centi(SETPOINT_MAX_C), int(HARD_RATE_C_PER_S * 100),
                                           m.centi(self.neutral), WATCHDOG_MS, MAX_POINTS, MIN_DT_US,
                                           self.boot_id)
            self.log("hello")
            return self._ack(seq, cmd, head + m.encode_strings(self.device_id, FIRMWARE, caps))
        if cmd == Cmd.STATUS:
            return self._ack(seq, cmd, self._status())
        if cmd == Cmd.ABORT:
            if self.state in (State.ARMED, State.PLAYING, State.RECORDING):
                self.end_reason = END_ABORTED
                self._event(Event.END, END_ABORTED, "aborted by host")
            if self.state == State.FAULT and self.last_fault in LATCHED_FAULTS:
                self.log("abort_latched", code=m.error_name(self.last_fault))
                return self._ack(seq, cmd)         # stopped already; the latch stays (relay open)
            self._set_state(State.IDLE, "abort")
            self.enabled = True
            return self._ack(seq, cmd)
        if cmd == Cmd.CLEAR_FAULT:
            if p != m.CLEAR_FAULT_MAGIC:
                return self._nak(seq, cmd, Err.BAD_ARGUMENT, "CLEAR_FAULT needs the operator's payload")
            if self.state == State.FAULT:
                self.log("fault_cleared", code=m.error_name(self.last_fault))
                self._set_state(State.IDLE, "operator reset")
                self.enabled = True
                self.plant.tripped = False
            return self._ack(seq, cmd)
        if cmd == Cmd.SET_NEUTRAL:
            (v,) = m.CENTI.unpack(p)
            if self.state not in (State.IDLE, State.FAULT):
                return self._nak(seq, cmd, Err.BAD_STATE, f"SET_NEUTRAL in state {self.state.name}")
            self.neutral = min(max(v / 100.0, self.lim_min), self.lim_max)
            self.log("neutral", asked_C=v / 100.0, neutral_C=self.neutral)
            return self._ack(seq, cmd, m.CENTI.pack(m.centi(self.neutral)))
        if cmd == Cmd.SET_LIMITS:
            lo, hi, rate = m.LIMITS.unpack(p)
            lo, hi = max(lo / 100.0, HARD_MIN_C), min(hi / 100.0, SETPOINT_MAX_C)
            if self.state != State.IDLE:
                return self._nak(seq, cmd, Err.BAD_STATE, f"SET_LIMITS in state {self.state.name}")
            if not lo < hi or rate <= 0:
                return self._nak(seq, cmd, Err.BAD_ARGUMENT, "empty range or zero rate")
            self.lim_min, self.lim_max = lo, hi
            self.lim_rate = min(rate / 100.0, HARD_RATE_C_PER_S)
            self.neutral = min(max(self.neutral, lo), hi)
            self.log("limits", min_C=lo, max_C=hi, rate_C_per_s=self.lim_rate,
                     neutral_C=self.neutral)
            return self._ack(seq, cmd, m.LIMITS.pack(m.centi(lo), m.centi(hi),
                                                     int(round(self.lim_rate * 100))))
        if cmd == Cmd.UPLOAD_BEGIN:
            n, dt_us = m.UPLOAD_BEGIN.unpack(p)
            if self.state != State.IDLE:
                return self._nak(seq, cmd, Err.BAD_STATE, f"UPLOAD in state {self.state.name}")
            if not (2 <= n <= MAX_POINTS) or dt_us < MIN_DT_US:
                return self._nak(seq, cmd, Err.OUT_OF_RANGE,
                                 f"n={n} (2..{MAX_POINTS}), dt={dt_us} µs (≥ {MIN_DT_US})")
            self.upload = dict(n=n, dt_us=dt_us, data=bytearray(2 * n), got=np.zeros(n, bool))
            self.profile = None
            return self._ack(seq, cmd)
        if cmd == Cmd.UPLOAD_CHUNK:
            off, count = m.UPLOAD_CHUNK_HEAD.unpack_from(p)
            body = p[m.UPLOAD_CHUNK_HEAD.size:]
            if self.upload is None:
                return self._nak(seq, cmd, Err.BAD_STATE, "no UPLOAD_BEGIN")
            if len(body) != 2 * count:
                return self._nak(seq, cmd, Err.BAD_LENGTH, f"{count} samples need {2 * count} bytes")
            if off + count > self.upload["n"]:
                return self._nak(seq, cmd, Err.OUT_OF_RANGE, f"chunk {off}+{count} > {self.upload['n']}")
            self.upload["data"][2 * off:2 * (off + count)] = body
            self.upload["got"][off:off + count] = True
            return self._ack(seq, cmd, m.UPLOAD_CHUNK_ACK.pack(off, count, zlib.crc32(body)))
        if cmd == Cmd.UPLOAD_COMMIT:
            (crc,) = m.COMMIT.unpack(p)
            up = self.upload
            if up is None or not up["got"].all():
                return self._nak(seq, cmd, Err.PROFILE_INCOMPLETE, "missing samples")
            mine = zlib.crc32(bytes(up["data"]))
            if mine != crc:
                return self._nak(seq, cmd, Err.PROFILE_CRC, f"crc32 {mine:08x} != {crc:08x}")
            vals = np.frombuffer(bytes(up["data"]), dtype="<i2").astype(float) / 100.0
            clamped = np.clip(vals, self.lim_min, self.lim_max)
            n_clamped = int(np.count_nonzero(clamped != vals))
            if n_clamped:
                self.log("profile_clamped", samples=n_clamped)
            self.profile = (clamped.tolist(), up["dt_us"])
            self.upload = None
            return self._ack(seq, cmd, m.COMMIT_ACK.pack(len(vals), mine, min(n_clamped, 65535)))
        if cmd == Cmd.ARM:
            mode, thr, maxdur = m.ARM.unpack(p)
            if self.state == State.FAULT:
                return self._nak(seq, cmd, Err.FAULT_LATCHED, f"fault {m.error_name(self.last_fault)}")
            if self.state != State.IDLE:
                return self._nak(seq, cmd, Err.BAD_STATE, f"ARM in state {self.state.name}")
            if mode not in (Mode.PLAYBACK, Mode.RECORD) or thr == 0 or maxdur == 0:
                return self._nak(seq, cmd, Err.BAD_ARGUMENT, "mode, threshold or duration")
            if mode == Mode.PLAYBACK and self.profile is None:
                return self._nak(seq, cmd, Err.PROFILE_INCOMPLETE, "no profile committed")
            self.arm_mode = Mode(mode)
            self.threshold = thr / 100.0
            self.max_duration_us = maxdur * 1000
            self.ready = False
            self.ready_count = 0
            self.fresh = False             # contact only after the force fell below half the
            self.contact_us = 0            # threshold since ARM: a fresh touch, not the last one
            self.touch_us = None
            self.end_reason = END_COMPLETE
            self._set_state(State.ARMED, f"arm {self.arm_mode.name.lower()}")
            return self._ack(seq, cmd, m.COUNTER.pack(self.counter))
        if cmd in (Cmd.SIM_SAMPLE, Cmd.SIM_FINGER, Cmd.SIM_FAULT):
            if not self.sim:
                return self._nak(seq, cmd, Err.NOT_SUPPORTED, "not an emulator")
            try:
                args = m.decode_json(p)
                reply = self._sim(cmd, args)
            except (ValueError, TypeError, KeyError) as exc:
                return self._nak(seq, cmd, Err.BAD_ARGUMENT, str(exc))
            return self._ack(seq, cmd, m.encode_json(reply))
        return self._nak(seq, cmd, Err.UNKNOWN_COMMAND, f"type 0x{cmd:02x}")

    def _sim(self, cmd, a):
        if cmd == Cmd.SIM_SAMPLE:
            self.sample = PassiveSample(a.get("material", "stainless_steel"),
                                        a.get("roughness_m", 1.6e-6), a.get("thickness_m", 3e-3),
                                        a.get("temperature_C", 20.0))
            from stimuli import material
            material(self.sample.material)                         # unknown name -> error now
            return dict(vars(self.sample))
        if cmd == Cmd.SIM_FINGER:
            f = FingerScript(**{k: float(v) for k, v in a.items()})
            if not (0.05 <= f.force_N <= 20 and f.hold_s > 0 and f.press_after_s >= 0
                    and 100e-6 <= f.skin_thickness_m <= 5e-3 and 25 <= f.skin_temperature_C <= 40):
                raise ValueError(f"finger out of range: {a}")
            # the finger waits for the cue: if armed but not ready, its clock starts at READY
            if not (self.state == State.ARMED and not self.ready):
                f.start_us = self.time_us
            self.finger = f
            if self._r_fp is None:
                self._r_fp = finger_pad_resistance()
            self.skin = FingerSkin(f.skin_thickness_m, f.skin_temperature_C, self.tick_s, self._r_fp)
            self.log("finger", **a)
            return dict(start_s=None if f.start_us is None else f.start_us * 1e-6)
        specs = parse_faults(a["spec"], where="sim_fault")
        now = self.time_us * 1e-6
        shifted = [s.shifted(now) for s in specs]
        self.faults += shifted
        for listener in self.fault_listeners:
            listener(shifted)
        if not self.stalled and self._fault_active("stall"):
            self.stalled = True                    # hangs right after this reply
            self.log("stall")
        self.log("fault_injected", spec=a["spec"])
        return dict(now_s=now, faults=len(specs))

    def _status(self) -> bytes:
        f = self.forces
        return m.STATUS_REPLY.pack(
            self.state, self.last_fault, self.time_us - self.boot_us, m.centi(self.sp),
            m.centi(self.contact_C),
            m.centi(self.ambient_C), m.centi(self.finger_C), m.centi(self.plant.hs),
            m.centi(f[0]), m.centi(f[1]), m.centi(f[2]), m.centi(f[3]), m.centi(self.neutral),
            0 if self.profile is None else len(self.profile[0]),
            0 if not self.contact_us else self.contact_us - self.boot_us, self.end_reason,
            self.counter, self.trials, self.boot_id)

    # ------------------------------------------------------------------ faults & safety
    def _fault_active(self, name: str) -> bool:
        t = self.time_us * 1e-6
        for s in self.faults:
            if s.name == name and s.active(t):
                return True
        return False

    def _trip(self, code: Err, text: str) -> None:
        """Enter the safe state: Peltier relay open, setpoint neutral, fault latched, reported."""
        if self.state in (State.ARMED, State.PLAYING, State.RECORDING):
            self.end_reason = END_FAULT
        self.last_fault = int(code)
        self.enabled = False
        self.sp = self.neutral              # the relay is open: no heat is pumped towards it
        self._sp_window.clear()
        self._sp_window.append(self.sp)
        self._set_state(State.FAULT, code.name)
        self.log("fault", code=code.name, text=text)
        self._event(Event.FAULT, int(code), text)

    def _maybe_reboot(self) -> None:
        """The ``reboot`` fault: a power cycle (a USB brown-out) at its time, once per spec."""
        t = self.time_us * 1e-6
        for i, spec in enumerate(self.faults):
            if spec.name == "reboot" and i not in self._reboots_done and spec.active(t):
                self._reboots_done.add(i)
                self._reboot()

    def _reboot(self) -> None:
        """Power-up state again: no HELLO, firmware limits, no profile, new boot id, time 0."""
        self.boots += 1
        self.boot_us = self.time_us
        self.boot_id = _boot_id(self.seed, self.boots)
        self.parser = FrameParser()
        self.out.clear()
        self.state = State.IDLE
        self.last_fault = 0
        self.neutral = DEFAULT_NEUTRAL_C
        self.lim_min, self.lim_max, self.lim_rate = HARD_MIN_C, SETPOINT_MAX_C, 10.0
        self.sp = self.neutral
        self._sp_window.clear()
        self._sp_window.append(self.sp)
        self.enabled = True
        self.plant.tripped = False
        self.hello = False
        self.last_rx_us = self.time_us
        self.cache = {}
        self.upload = self.profile = None
        self.ready, self.ready_count, self.fresh = False, 0, False
        self.contact_us, self.touch_us, self.release_count = 0, None, 0
        self.end_reason = END_COMPLETE
        self.counter = self.tx_seq = self.trials = 0
        self.log("reboot", boot_id=self.boot_id)

    # ------------------------------------------------------------------ the tick
    def step(self) -> None:
        """Advance 10 ms of device time."""
        self.time_us += TICK_US
        t_us = self.time_us
        if self.faults:
            stalled = self._fault_active("stall")
            if stalled != self.stalled:
                self.stalled = stalled
                self.log("stall" if stalled else "unstall")
            pl = self.plant
            pl.sensor_frozen = self._fault_active("stuck_sensor")
            pl.sensor_override = 150.0 if self._fault_active("sensor_range") else None
            pl.stuck_current = pl.p.i_max if self._fault_active("overtemp") else None
        if self.faults and not self.stalled:
            self._maybe_reboot()
        if self.stalled:
            # firmware hung: the hardware watchdog has opened the relay; only physics goes on
            self.plant.step(self.sp, self.sp, 0.0, False)
            return
        state = prev_state = self.state
        # watchdog: host silent while the pad is doing something (HELLO or not)
        if (state in _ACTIVE
                and t_us - self.last_rx_us > WATCHDOG_MS * 1000):
            ms = (t_us - self.last_rx_us) // 1000
            self.last_fault = int(Err.WATCHDOG)
            self.end_reason = END_FAULT
            self.log("watchdog", since_last_rx_ms=ms)
            self._event(Event.WATCHDOG, ms, "host heartbeat lost")
            self._set_state(_IDLE, "watchdog")
            state = self.state
        # finger and forces
        fin = self.finger
        F = fin.force(t_us) if fin is not None else 0.0
        nz = self.noise
        nf = self.params.noise_force
        sh = FingerScript.SHARES
        self.forces = (F * sh[0] + nf * next(nz), F * sh[1] + nf * next(nz),
                       F * sh[2] + nf * next(nz), F * sh[3] + nf * next(nz))
        Fsum = self.forces[0] + self.forces[1] + self.forces[2] + self.forces[3]
        touching = F > 0.1
        if touching and self.touch_us is None and state in _ACTIVE:
            self.touch_us = t_us
        # setpoint
        sp_prev = self.sp
        max_step = self.lim_rate * self.tick_s
        if state == _PLAYING:
            vals, dt_us = self.profile
            x = (t_us - self.contact_us) / dt_us
            i = int(x)
            if i >= len(vals) - 1:
                goal = vals[-1]
            else:
                goal = vals[i] + (x - i) * (vals[i + 1] - vals[i])
            max_step = HARD_RATE_C_PER_S * self.tick_s
        elif state == _ARMED and self.arm_mode == _PLAYBACK:
            goal = self.profile[0][0]
        else:
            goal = self.neutral
        goal = min(max(goal, self.lim_min), self.lim_max)
        d = goal - sp_prev
        sp = goal if -max_step <= d <= max_step else sp_prev + math.copysign(max_step, d)
        # whatever the profile: the setpoints of any 0.1 s window span at most the rate limit
        # times the window (so no |T(t + w) - T(t)| beyond it, the host's measure). The last
        # setpoint is always inside these bounds, so this only ever shortens a step.
        span = self.lim_rate * self.tick_s * RATE_WINDOW_TICKS + RATE_SLACK_C
        sp = min(max(sp, max(self._sp_window) - span), min(self._sp_window) + span)
        self.sp = sp = min(max(sp, HARD_MIN_C, self.lim_min), SETPOINT_MAX_C, self.lim_max)
        self._sp_window.append(sp)
        # physics
        load = 0.0
        skin = self.skin
        if skin is not None:
            if touching and self.arm_mode == _PLAYBACK:      # the finger is on the pad
                load = skin.step(True, self.plant.pad) * CONTACT_AREA_M2
                self.finger_C = skin.surface_C(True)
            elif not touching:
                skin.step(False, self.params.room)
                self.finger_C = skin.surface_C(False)
        else:
            self.finger_C = self.params.room + self.params.noise_ambient * next(nz)
        y = self.plant.step(sp_prev, sp, load, self.enabled)
        self.ambient_C = self.params.room + self.params.noise_ambient * next(nz)
        if self.arm_mode == _RECORD and state in (_ARMED, _RECORDING):
            self.contact_C = self._sample_reading(t_us, touching)
        else:
            self.contact_C = y
        # safety monitors (on the pad's own sensor, whatever the mode)
        if state != _FAULT:
            if not (-10.0 < y < 90.0):
                self._trip(Err.SENSOR_FAILURE, f"contact sensor reads {y:.2f} °C")
            elif self.enabled and self.plant.same_count >= STUCK_SAMPLES:
                self._trip(Err.SENSOR_STUCK, f"contact sensor stuck at {y:.3f} °C")
            elif self.plant.tripped or y > OVERTEMP_C or self.plant.hs > HEATSINK_MAX_C:
                self._trip(Err.OVER_TEMPERATURE,
                           f"pad {y:.2f} °C, heat sink {self.plant.hs:.2f} °C")
        state = self.state
        # trial logic
        if state == _ARMED:
            # a finger still pressing from the last trial is not a new contact: contact only
            # once the force has dropped below half the threshold since ARM (a fresh touch)
            if not self.fresh and Fsum < 0.5 * self.threshold:
                self.fresh = True
            if not self.ready:
                near = (self.arm_mode == _RECORD or
                        (abs(y - self.profile[0][0]) < READY_BAND_C and sp == goal))
                self.ready_count = self.ready_count + 1 if near else 0
                if self.ready_count >= 10:
                    self.ready = True
                    self._event(Event.READY, 0, "ready for contact")
                    self.log("ready")
                    if fin is not None and fin.start_us is None:
                        fin.start_us = t_us
            elif Fsum >= self.threshold and self.fresh:
                self.contact_us = t_us
                self.trials += 1
                self.release_count = 0
                self._event(Event.CONTACT, 0, f"{Fsum:.2f} N")
                self._set_state(_PLAYING if self.arm_mode == _PLAYBACK else _RECORDING,
                                "contact")
        elif state in (_PLAYING, _RECORDING):
            elapsed = t_us - self.contact_us
            self.release_count = self.release_count + 1 if Fsum < 0.5 * self.threshold else 0
            reason = None
            if self.release_count * TICK_US >= RELEASE_MS * 1000:
                reason = END_RELEASED
            elif elapsed >= self.max_duration_us:
                reason = END_MAX_DURATION
            elif state == _PLAYING and elapsed >= (len(self.profile[0]) - 1) * self.profile[1]:
                reason = END_COMPLETE
            if reason is not None:
                self.end_reason = reason
                self._event(Event.END, reason, ("complete", "released", "max duration")[reason])
                self._set_state(_IDLE, "end")
        # telemetry: while a trial is on, in FAULT, and on the tick a trial ends
        if self.state != _IDLE or prev_state != _IDLE:
            self.counter += 1
            self.tx_seq = seq = (self.tx_seq + 1) & 0xFF
            f = self.forces
            fault = self.last_fault if self.state == _FAULT else 0
            try:
                body = _TEL_PREFIX[seq] + _TEL_PACK(
                    self.counter, t_us - self.boot_us, round(sp * 100), round(self.contact_C * 100),
                    round(self.ambient_C * 100), round(self.finger_C * 100), round(f[0] * 100),
                    round(f[1] * 100), round(f[2] * 100), round(f[3] * 100), self.state, fault)
            except struct.error:                   # a reading beyond ±327.67: saturate
                c = m.centi
                body = _TEL_PREFIX[seq] + _TEL_PACK(
                    self.counter, t_us - self.boot_us, c(sp), c(self.contact_C), c(self.ambient_C),
                    c(self.finger_C), c(f[0]), c(f[1]), c(f[2]), c(f[3]), self.state, fault)
            self.out += b"\xa5\x5a" + body + _CRC.pack(crc_hqx(body, 0xFFFF))

    def _sample_reading(self, t_us, touching) -> float:
        """Contact sensor on the passive sample (record mode)."""
        s = self.sample
        if self.touch_us is None or self.finger is None:
            return s.temperature_C
        if self.curves is None or self.curves[0] != self.touch_us:
            n = int(self.max_duration_us / TICK_US) + 200
            tm, ts = s.curves(self.finger.skin_thickness_m, self.finger.skin_temperature_C,
                              self.tick_s, n, force_N=self.finger.force_N)
            self.curves = (self.touch_us, tm, ts)
        _, tm, ts = self.curves
        k = min((t_us - self.touch_us) // TICK_US, len(tm) - 1)
        if touching:
            self.finger_C = float(ts[k])
        return float(tm[k]) + self.params.noise_sensor * next(self.noise)
