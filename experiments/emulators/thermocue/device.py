"""The emulated display's firmware: its state machine, run as a 10 ms tick.

One concept, the firmware's tick (watchdog, setpoint and rate limits, physics, safety monitors,
trial logic, telemetry); its command handling is the part it holds, ``device.commands``
(:class:`~.device_commands.HostCommands`), its fixed numbers are in :mod:`.device_constants`, the
physics in :mod:`.pad_physics`.

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
from binascii import crc_hqx
from collections import deque

from experiments.display.thermocue import messages as m
from .device_commands import HostCommands
from .device_constants import (DEFAULT_NEUTRAL_C, FIRMWARE, HARD_MAX_C, HARD_MIN_C,  # noqa: F401
                               HARD_RATE_C_PER_S, HEATSINK_MAX_C, LATCHED_FAULTS, MAX_POINTS,
                               MIN_DT_US, OVERTEMP_C, RATE_SLACK_C, RATE_WINDOW_TICKS,
                               READY_BAND_C, RELEASE_MS, SETPOINT_MAX_C, STUCK_SAMPLES, TICK_US,
                               WATCHDOG_MS, make_boot_id)
from .device_constants import (END_ABORTED, END_COMPLETE, END_FAULT,  # noqa: F401
                               END_MAX_DURATION, END_RELEASED)
from .faults import FaultSpec, parse_faults
from experiments.display.thermocue.framing import Frame, FrameParser, crc8, encode_frame
from experiments.display.thermocue.messages import Err, Event, Mode, State
from .pad_physics import (CONTACT_AREA_M2, FingerScript, FingerSkin, PadParams, PadPlant,  # noqa: F401
                          PassiveSample, finger_pad_resistance, normal_stream)

__all__ = ["Device", "FingerScript", "FIRMWARE", "HARD_MIN_C", "HARD_MAX_C", "SETPOINT_MAX_C",
           "OVERTEMP_C", "HARD_RATE_C_PER_S", "LATCHED_FAULTS"]

_IDLE, _ARMED, _PLAYING, _RECORDING, _FAULT = (State.IDLE, State.ARMED, State.PLAYING,
                                               State.RECORDING, State.FAULT)
_ACTIVE = (State.ARMED, State.PLAYING, State.RECORDING)
_PLAYBACK, _RECORD = Mode.PLAYBACK, Mode.RECORD
_TEL_HEAD = struct.Struct("<HBB")
_TEL_PREFIX = [h + bytes((crc8(h),)) for h in
               (_TEL_HEAD.pack(m.TELEMETRY.size, q, m.Msg.TELEMETRY) for q in range(256))]
_TEL_PACK = m.TELEMETRY.pack
_TELEMETRY = int(m.Msg.TELEMETRY)
_SH0, _SH1, _SH2, _SH3 = FingerScript.SHARES
_tuple_new = tuple.__new__
_CRC = struct.Struct("<H")


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
        self.set_trip(OVERTEMP_C)
        self.watchdog_us = WATCHDOG_MS * 1000   # longer only under the late_watchdog fault
        self.seed = seed
        self.boots = 0
        self.boot_us = 0                   # device time counts from the last power-up
        self.boot_id = make_boot_id(seed, 0)
        self._reboots_done = set()
        self.sp = self.neutral
        self._sp_window = deque([self.sp], maxlen=RATE_WINDOW_TICKS)   # setpoints, last 0.1 s
        self.enabled = True
        self.hello = False
        self.last_rx_us = self.last_byte_us = 0
        #: The longest host silence the watchdog saw while armed, playing or recording, µs
        #: (logged with the emulator's stop record: a session's heartbeat gaps, as the device saw them)
        self.max_rx_gap_us = 0
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
        # a list while a transport takes the tick's output as decoded frames, not bytes (the
        # in-process virtual clock with no fault injected: nothing on the line to damage)
        self.direct: list[Frame] | None = None
        self.r_finger_pad = finger_pad_resistance()     # imports stimuli now, not mid-trial
        #: The command handling (HELLO, limits, upload, ARM, ...): the part that answers the host
        self.commands = HostCommands(self)

    # ------------------------------------------------------------------ output helpers
    def heard(self, stamp_us: int) -> None:
        """A valid host frame at ``stamp_us``: it feeds the watchdog."""
        if self.state in _ACTIVE and stamp_us - self.last_rx_us > self.max_rx_gap_us:
            self.max_rx_gap_us = stamp_us - self.last_rx_us
        self.last_rx_us = stamp_us

    def log(self, kind: str, **fields) -> None:
        if self._log is not None:
            self._log(dict(t_s=round(self.time_us * 1e-6, 6), event=kind, state=self.state.name,
                           setpoint_C=round(self.sp, 3), pad_C=round(self.plant.pad, 3), **fields))

    def send(self, seq: int, mtype: int, payload: bytes = b"") -> bytes:
        """One frame out to the host (a reply of :attr:`commands`); returns its bytes."""
        frame = encode_frame(seq, mtype, payload)
        self.out += frame
        return frame

    def event(self, kind: Event, arg: int = 0, text: str = "") -> None:
        """An EVENT frame to the host, on the device's own sequence numbers."""
        self.tx_seq = (self.tx_seq + 1) & 0xFF
        payload = m.EVENT_HEAD.pack(kind, self.time_us - self.boot_us, arg) + text.encode("utf-8")[:200]
        if self.direct is not None:
            self.direct.append(Frame(self.tx_seq, m.Msg.EVENT, payload))
        else:
            self.send(self.tx_seq, m.Msg.EVENT, payload)

    def take_output(self) -> bytes:
        """Bytes waiting to go to the host (and forget them)."""
        if not self.out:
            return b""
        data = bytes(self.out)
        self.out.clear()
        return data

    def set_state(self, new: State, why: str) -> None:
        """Change state (logged with ``why``); nothing when it is the state already."""
        if new != self.state:
            old = self.state
            self.state = new
            self.log("state", old=old.name, why=why)

    # ------------------------------------------------------------------ host input
    def receive(self, data: bytes, at_us: int | None = None) -> None:
        """Handle bytes from the host (:meth:`.device_commands.HostCommands.receive`)."""
        self.commands.receive(data, at_us)

    # ------------------------------------------------------------------ faults & safety
    def fault_active(self, name: str) -> bool:
        """Whether an injected fault ``name`` is active now."""
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
        self.set_state(State.FAULT, code.name)
        self.log("fault", code=code.name, text=text)
        self.event(Event.FAULT, int(code), text)

    def _fault_value(self, name: str, default: float) -> float:
        """The VALUE of an active fault ``name``, else ``default``."""
        t = self.time_us * 1e-6
        for spec in self.faults:
            if spec.name == name and spec.active(t):
                return float(spec.value)
        return default

    def set_trip(self, trip_C: float) -> None:
        """The over-temperature trip (°C): :data:`OVERTEMP_C`, or lower for a test (SET_TRIP)."""
        self.trip_C = self.plant.trip_C = float(trip_C)

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
        self.boot_id = make_boot_id(self.seed, self.boots)
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
        self.set_trip(OVERTEMP_C)
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
        """Advance 10 ms of device time: faults, host watch, forces, setpoint, physics, safety,
        the trial's logic, telemetry (each a part below, in this order)."""
        self.time_us += TICK_US
        t_us = self.time_us
        if self.faults:
            self._apply_faults()
        if self.faults and not self.stalled:
            self._maybe_reboot()
        if self.parser.buffered and not self.stalled:   # (the commonest tick: nothing held)
            self.commands.drop_stale_candidate()
        if self.stalled:
            # firmware hung: the hardware watchdog has opened the relay; only physics goes on
            self.plant.step(self.sp, self.sp, 0.0, False)
            return
        prev_state = state = self.state
        # the host watch acts only after a silence longer than one of its limits (each tick
        # with a fresher host frame it would only compare and return)
        quiet_us = t_us - self.last_rx_us
        if quiet_us > self.watchdog_us or quiet_us > WATCHDOG_MS * 1000:
            state = self._watch_host(t_us, prev_state)
        fin = self.finger
        Fsum, touching = self._read_forces(t_us, fin, state)
        sp_prev = self.sp
        goal, sp = self._next_setpoint(t_us, state, sp_prev)
        y = self._physics(t_us, state, sp_prev, sp, touching)
        self._monitor_safety(state, y)
        state = self.state
        if state == _ARMED:
            self._armed_tick(t_us, fin, Fsum, y, sp, goal)
        elif state in (_PLAYING, _RECORDING):
            self._trial_tick(t_us, state, Fsum)
        # telemetry: while a trial is on, in FAULT, and on the tick a trial ends
        if self.state != _IDLE or prev_state != _IDLE:
            self._send_telemetry(t_us, sp)

    def _apply_faults(self) -> None:
        """The injected faults active now, applied to the firmware and the plant."""
        stalled = self.fault_active("stall")
        if stalled != self.stalled:
            self.stalled = stalled
            self.log("stall" if stalled else "unstall")
        pl = self.plant
        pl.sensor_frozen = self.fault_active("stuck_sensor")
        pl.sensor_override = 150.0 if self.fault_active("sensor_range") else None
        pl.stuck_current = pl.p.i_max if self.fault_active("overtemp") else None
        pl.relay_dead = self.fault_active("dead_relay")
        pl.current_scale = self._fault_value("slow_pad", 1.0)
        self.watchdog_us = int(self._fault_value("late_watchdog", WATCHDOG_MS / 1000) * 1e6)

    def _watch_host(self, t_us: int, state: int) -> int:
        """Host loss restores the normal trip; the watchdog ends a silent host's trial.
        Returns the state after it."""
        # host loss restores the normal trip, in any state
        if self.trip_C != OVERTEMP_C and t_us - self.last_rx_us > WATCHDOG_MS * 1000:
            self.set_trip(OVERTEMP_C)
        # watchdog: host silent while the pad is doing something (HELLO or not)
        if (state in _ACTIVE
                and t_us - self.last_rx_us > self.watchdog_us):
            ms = (t_us - self.last_rx_us) // 1000
            self.last_fault = int(Err.WATCHDOG)
            self.end_reason = END_FAULT
            self.log("watchdog", since_last_rx_ms=ms)
            self.event(Event.WATCHDOG, ms, "host heartbeat lost")
            self.set_state(_IDLE, "watchdog")
            state = self.state
        return state

    def _read_forces(self, t_us: int, fin, state: int) -> tuple:
        """The four force sensors (``self.forces``); returns their sum, N, and whether the
        finger touches."""
        F = fin.force(t_us) if fin is not None else 0.0
        nz = self.noise
        nf = self.params.noise_force
        f0 = F * _SH0 + nf * next(nz)
        f1 = F * _SH1 + nf * next(nz)
        f2 = F * _SH2 + nf * next(nz)
        f3 = F * _SH3 + nf * next(nz)
        self.forces = (f0, f1, f2, f3)
        Fsum = f0 + f1 + f2 + f3
        touching = F > 0.1
        if touching and self.touch_us is None and state in _ACTIVE:
            self.touch_us = t_us
        return Fsum, touching

    def _next_setpoint(self, t_us: int, state: int, sp_prev: float) -> tuple:
        """This tick's goal and setpoint (``self.sp``), °C: the profile, its start or neutral,
        clamped to the limits and the rate limit over every 0.1 s window."""
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
        # the clamps below are min()/max() written as comparisons (the same value, ties and
        # NaN included: max(x, a) is a only when a > x, min(x, b) is b only when b < x)
        lo, hi = self.lim_min, self.lim_max
        if lo > goal:
            goal = lo
        if hi < goal:
            goal = hi
        d = goal - sp_prev
        sp = goal if -max_step <= d <= max_step else sp_prev + math.copysign(max_step, d)
        # whatever the profile: the setpoints of any 0.1 s window span at most the rate limit
        # times the window (so no |T(t + w) - T(t)| beyond it, the host's measure). The last
        # setpoint is always inside these bounds, so this only ever shortens a step.
        span = self.lim_rate * self.tick_s * RATE_WINDOW_TICKS + RATE_SLACK_C
        window = self._sp_window
        bound = max(window) - span
        if bound > sp:
            sp = bound
        bound = min(window) + span
        if bound < sp:
            sp = bound
        if HARD_MIN_C > sp:
            sp = HARD_MIN_C
        if lo > sp:
            sp = lo
        if SETPOINT_MAX_C < sp:
            sp = SETPOINT_MAX_C
        if hi < sp:
            sp = hi
        self.sp = sp
        window.append(sp)
        return goal, sp

    def _physics(self, t_us: int, state: int, sp_prev: float, sp: float, touching: bool) -> float:
        """The finger's skin, the pad, the ambient and contact readings; returns the pad's
        sensor, °C."""
        load = 0.0
        skin = self.skin
        params = self.params
        nz = self.noise
        if skin is not None:
            if touching and self.arm_mode == _PLAYBACK:      # the finger is on the pad
                load = skin.step(True, self.plant.pad) * CONTACT_AREA_M2
                self.finger_C = skin.surface_C(True)
            elif not touching:
                skin.step(False, params.room)
                self.finger_C = skin.surface_C(False)
        else:
            self.finger_C = params.room + params.noise_ambient * next(nz)
        y = self.plant.step(sp_prev, sp, load, self.enabled)
        self.ambient_C = params.room + params.noise_ambient * next(nz)
        if self.arm_mode == _RECORD and state in (_ARMED, _RECORDING):
            self.contact_C = self._sample_reading(t_us, touching)
        else:
            self.contact_C = y
        return y

    def _monitor_safety(self, state: int, y: float) -> None:
        """The safety monitors, on the pad's own sensor ``y`` (°C), whatever the mode (none in
        FAULT: ``state``, the state after the host watch)."""
        if state != _FAULT:
            if not (-10.0 < y < 90.0):
                self._trip(Err.SENSOR_FAILURE, f"contact sensor reads {y:.2f} °C")
            elif self.enabled and self.plant.same_count >= STUCK_SAMPLES:
                self._trip(Err.SENSOR_STUCK, f"contact sensor stuck at {y:.3f} °C")
            elif self.plant.tripped or y > self.trip_C or self.plant.hs > HEATSINK_MAX_C:
                self._trip(Err.OVER_TEMPERATURE,
                           f"pad {y:.2f} °C, heat sink {self.plant.hs:.2f} °C")

    def _armed_tick(self, t_us: int, fin, Fsum: float, y: float, sp: float, goal: float) -> None:
        """ARMED: wait for the starting temperature (READY), then a fresh contact."""
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
                self.event(Event.READY, 0, "ready for contact")
                self.log("ready")
                if fin is not None and fin.start_us is None:
                    fin.start_us = t_us
        elif Fsum >= self.threshold and self.fresh:
            self.contact_us = t_us
            self.trials += 1
            self.release_count = 0
            self.event(Event.CONTACT, 0, f"{Fsum:.2f} N")
            self.set_state(_PLAYING if self.arm_mode == _PLAYBACK else _RECORDING,
                            "contact")

    def _trial_tick(self, t_us: int, state: int, Fsum: float) -> None:
        """PLAYING or RECORDING: end on release, on the maximum duration, at the profile's end."""
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
            self.event(Event.END, reason, ("complete", "released", "max duration")[reason])
            self.set_state(_IDLE, "end")

    def _send_telemetry(self, t_us: int, sp: float) -> None:
        """One TELEMETRY frame of this tick."""
        f0, f1, f2, f3 = self.forces
        self.counter += 1
        self.tx_seq = seq = (self.tx_seq + 1) & 0xFF
        fault = self.last_fault if self.state == _FAULT else 0
        try:
            payload = _TEL_PACK(
                self.counter, t_us - self.boot_us, round(sp * 100), round(self.contact_C * 100),
                round(self.ambient_C * 100), round(self.finger_C * 100), round(f0 * 100),
                round(f1 * 100), round(f2 * 100), round(f3 * 100), self.state, fault)
        except struct.error:                   # a reading beyond ±327.67: saturate
            c = m.centi
            payload = _TEL_PACK(
                self.counter, t_us - self.boot_us, c(sp), c(self.contact_C), c(self.ambient_C),
                c(self.finger_C), c(f0), c(f1), c(f2), c(f3), self.state, fault)
        direct = self.direct
        if direct is not None:
            direct.append(_tuple_new(Frame, (seq, _TELEMETRY, payload)))  # Frame(...), sooner
        else:
            body = _TEL_PREFIX[seq] + payload
            self.out += b"\xa5\x5a" + body + _CRC.pack(crc_hqx(body, 0xFFFF))


    def sample_model(self):
        """``(material_side_C, skin_side_C, plans)`` of the passive sample under the scripted
        finger for the armed duration (:meth:`PassiveSample.planned_curves`, cached): what a
        record-mode touch reads, and the scene planner's decisions for it."""
        n = int(self.max_duration_us / TICK_US) + 200
        return self.sample.planned_curves(self.finger.skin_thickness_m,
                                          self.finger.skin_temperature_C, self.tick_s, n,
                                          force_N=self.finger.force_N)

    def _sample_reading(self, t_us, touching) -> float:
        """Contact sensor on the passive sample (record mode)."""
        s = self.sample
        if self.touch_us is None or self.finger is None:
            return s.temperature_C
        if self.curves is None or self.curves[0] != self.touch_us:
            tm, ts, _ = self.sample_model()
            self.curves = (self.touch_us, tm.tolist(), ts.tolist())   # the same floats
        _, tm, ts = self.curves
        k = (t_us - self.touch_us) // TICK_US
        if k >= len(tm):
            k = len(tm) - 1
        if touching:
            self.finger_C = ts[k]
        return tm[k] + self.params.noise_sensor * next(self.noise)
