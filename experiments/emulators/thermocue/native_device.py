"""The emulated display with the firmware's own C core (``emulator://?core=c``).

The firmware's core (:mod:`.native_core`: commands, reply store, states, limits, watchdog,
controller) runs unchanged behind a simulation HAL written here in Python: each 5 ms control
step the pad's physics advance under the drive the core commanded, the sensors are read
(contact, heat sink, IR finger, ambient, four forces, the sample's thermometer), and the core
runs one step; the finger and its skin advance once per 10 ms tick, as in the twin. The finger (:class:`~.pad_physics.FingerScript`, :class:`~.pad_physics.FingerSkin`),
the passive sample and every device fault (:mod:`.faults`) stay on this side of the HAL, as on
the sim bench: ``stuck_sensor``, ``sensor_range``, ``overtemp``, ``dead_relay`` and ``slow_pad``
act on the physics and the sensors; ``stall`` stops calling the core (the hardware watchdog
opens the relay); ``reboot`` powers the core up again; ``late_watchdog=S`` feeds the core's
watchdog for S s after the host's last byte (a firmware whose watchdog trips late).

:class:`NativeDevice` has the transports' face of :class:`~.device.Device` (``receive``,
``step``, ``take_output``, ``time_us``, ``state``, ``direct``, ...), so
:class:`~.emulator_core.EmulatorCore` runs either.

Known differences from the Python twin (the core is the firmware's: these are the firmware's
numbers): profiles of at most 32,768 samples; the device's own controller (PI with feed-forward,
float32); sim-command replies of at most 159 bytes (the ``sim_finger`` reply's model
descriptions go to the emulator's log instead); a late-stamped host byte (a starved real-time
clock) is handed to the core at once, and the core's watchdog is fed with silent heartbeats
until its stamp (the core's clock never runs backwards, so it cannot take a stamp ahead of it).
"""
from __future__ import annotations

import ctypes
import math

from experiments.display.thermocue import messages as m
from experiments.display.thermocue.framing import Frame, FrameParser, encode_frame
from experiments.display.thermocue.messages import Cmd, Err, Event, State
from .device_commands import finger_from_args, sample_from_args
from .device_constants import TICK_US
from .faults import parse_faults
from .native_core import ARMED, READY, RECORD, RELAY, NativeCore
from .pad_physics import (CONTACT_AREA_M2, FINGER_ON_PAD_MODEL, FingerScript, FingerSkin,
                          PadParams, PassiveSample, finger_pad_resistance, normal_stream)

__all__ = ["NativeDevice", "DrivenPad", "CONTROL_US"]

CONTROL_US = 5000                          # the core's control step (config.h FW_CONTROL_US)
KELVIN = 273.15
_SILENT_HEARTBEAT = encode_frame(0, Cmd.HEARTBEAT, b"\x00")


class DrivenPad:
    """Pad, Peltier module, heat sink and contact sensor, driven by the H-bridge command.

    The physics of :class:`~.pad_physics.PadPlant` without its controller (the firmware's
    controller is the C core's). ``step(drive, relay, load_W)`` advances one control step and
    returns the contact reading (°C, 0.001 °C resolution). Fault hooks as in ``PadPlant``.
    """

    def __init__(self, params: PadParams, dt: float, start_C: float, seed: int = 0):
        self.p = params
        self.dt = dt
        self.noise = normal_stream(seed)
        self.pad = float(start_C)
        self.hs = params.room + 0.5
        self.sensor_state = self.pad
        self.sensor = round(self.pad, 3)
        self.current = 0.0
        self.stuck_current = None          # overtemp: the driver stuck at full heating
        self.current_scale = 1.0           # slow_pad
        self.relay_dead = False            # dead_relay: the driver keeps its current
        self.sensor_override = None        # sensor_range: °C
        self.sensor_frozen = False         # stuck_sensor
        self._lag = 1.0 - math.exp(-dt / params.tau_sensor)

    def step(self, drive: float, relay: bool, load_W: float) -> float:
        p = self.p
        if relay:
            i = self.stuck_current if self.stuck_current is not None else drive * p.i_max
            i *= self.current_scale
        else:
            i = self.current if self.relay_dead else 0.0
        pad, hs = self.pad, self.hs
        joule = 0.5 * p.resistance * i * i
        q_pad = p.seebeck * i * (pad + KELVIN) + joule + p.conductance * (hs - pad) + load_W
        q_hs = (-p.seebeck * i * (hs + KELVIN) + joule + p.conductance * (pad - hs)
                + p.hs_conductance * (p.room - hs))
        self.pad = pad + self.dt * q_pad / p.capacity
        self.hs = hs + self.dt * q_hs / p.hs_capacity
        self.current = i
        self.sensor_state += self._lag * (self.pad - self.sensor_state)
        if self.sensor_override is not None:
            self.sensor = self.sensor_override
        elif not self.sensor_frozen:
            self.sensor = round(self.sensor_state + p.noise_sensor * next(self.noise), 3)
        return self.sensor


class NativeDevice:
    """The emulated display on the firmware's C core (see the module docstring).

    Parameters as :class:`~.device.Device`.
    """

    def __init__(self, seed: int = 0, faults=None, sim: bool = True, log=None,
                 params: PadParams | None = None, device_id: str = "EMU-0001"):
        self.params = params or PadParams()
        self.seed = seed
        self.sim = sim
        self.device_id = device_id
        self._log = log
        self.faults = (parse_faults(faults) if isinstance(faults, (str, type(None)))
                       else list(faults))
        self.fault_listeners = []
        self.noise = normal_stream(seed + 1)
        self.plant = DrivenPad(self.params, CONTROL_US * 1e-6, 32.0, seed=seed)
        self.time_us = 0
        self.boot_us = 0
        self.boots = 0
        self.out = bytearray()
        self.direct = None                 # a list while the transport takes decoded frames
        self._log_parser = FrameParser()
        self.stalled = False
        self.max_rx_gap_us = 0
        self.last_byte_us = 0
        self._alive_until_us = 0           # a late stamp: the watchdog is fed until then
        self._reboots_done = set()
        self.finger: FingerScript | None = None
        self.skin: FingerSkin | None = None
        self.sample = PassiveSample()
        self.record = False
        self.touch_us = None
        self.curves = None
        self.drive, self.relay = 0.0, False
        self.forces = (0.0, 0.0, 0.0, 0.0)
        self._r_fp = finger_pad_resistance()
        self.core = NativeCore(self._board_command)
        self._power_up()
        self._state = State(self.core.state())

    # ------------------------------------------------------------------ identity and log
    @property
    def state(self) -> State:
        return State(self.core.state())

    @property
    def boot_id(self) -> int:
        return self.core.boot_id()

    def log(self, kind: str, **fields) -> None:
        if self._log is not None:
            self._log(dict(t_s=round(self.time_us * 1e-6, 6), event=kind,
                           state=State(self.core.state()).name,
                           pad_C=round(self.plant.pad, 3), **fields))

    def _power_up(self) -> None:
        image = "native-" + self.core.path.stem.rsplit("-", 1)[-1]
        if not self.core.power_up(self.seed * 7919 + self.boots, 0, self.device_id, image,
                                  self.sim):
            raise RuntimeError("the firmware core's self-check failed")
        # powered up one control step ago: its first step reads the sensors now, so a STATUS
        # at once reports readings, not the zeros of a core that has read nothing yet
        self.boot_us = self.time_us - CONTROL_US
        self._control(self.time_us, self._world(self.time_us))

    # ------------------------------------------------------------------ bytes
    def receive(self, data: bytes, at_us: int | None = None) -> None:
        """Host bytes into the core's UART (see :meth:`.device_commands.HostCommands.receive`)."""
        if self.stalled or not data:
            return
        if at_us is not None and at_us > self.time_us:
            # bytes that waited while a starved real-time clock fell behind: the host was alive
            # until their stamp, so the core's watchdog is fed until then (see _control)
            self._alive_until_us = max(self._alive_until_us, int(at_us))
        self._feed(bytes(data), self.time_us)

    def _feed(self, data: bytes, stamp: int) -> None:
        if self.state in (State.ARMED, State.PLAYING, State.RECORDING):
            self.max_rx_gap_us = max(self.max_rx_gap_us, stamp - self.last_byte_us)
        self.last_byte_us = stamp
        self._flags(self.core.send(data, len(data)), stamp)
        self._collect(to_direct=False)

    def take_output(self) -> bytes:
        if not self.out:
            return b""
        data = bytes(self.out)
        self.out.clear()
        return data

    def _collect(self, to_direct: bool) -> None:
        if not self.core.pending():
            return
        data = self.core.take()
        if self._log is not None:
            self._log_events(data)
        if to_direct and self.direct is not None:
            self.direct.extend(_whole_frames(data))
        else:
            self.out += data

    def _log_events(self, data: bytes) -> None:
        for fr in self._log_parser.feed(data):
            if fr.type == m.Msg.EVENT and len(fr.payload) >= m.EVENT_HEAD.size:
                kind, _, arg = m.EVENT_HEAD.unpack_from(fr.payload)
                text = fr.payload[m.EVENT_HEAD.size:].decode("utf-8", "replace")
                name = Event(kind).name.lower() if kind in Event._value2member_map_ else kind
                self.log(str(name), arg=arg, text=text)

    # ------------------------------------------------------------------ the tick
    def step(self) -> None:
        """Advance 10 ms of device time (two control steps of the core)."""
        if self.faults:
            self._apply_faults()
        world = self._world(self.time_us + TICK_US)
        for _ in range(TICK_US // CONTROL_US):
            self.time_us += CONTROL_US
            self._control(self.time_us, world)
        self._collect(to_direct=True)
        state = State(self.core.state())
        if state != self._state:
            self.log("state", old=self._state.name, new=state.name)
            self._state = state

    def _fault_value(self, name: str, t: float):
        for spec in self.faults:
            if spec.name == name and spec.active(t):
                return 1.0 if spec.value is None else float(spec.value)
        return None

    def _apply_faults(self) -> None:
        t = self.time_us * 1e-6
        stalled = self._fault_value("stall", t) is not None
        if stalled != self.stalled:
            self.stalled = stalled
            self.log("stall" if stalled else "unstall")
        pl = self.plant
        pl.sensor_frozen = self._fault_value("stuck_sensor", t) is not None
        pl.sensor_override = 150.0 if self._fault_value("sensor_range", t) is not None else None
        pl.stuck_current = self.params.i_max if self._fault_value("overtemp", t) else None
        pl.relay_dead = self._fault_value("dead_relay", t) is not None
        pl.current_scale = self._fault_value("slow_pad", t) or 1.0
        if not stalled:
            for i, spec in enumerate(self.faults):
                if spec.name == "reboot" and i not in self._reboots_done and spec.active(t):
                    self._reboots_done.add(i)
                    self._reboot()
            late = self._fault_value("late_watchdog", t)
            if late is not None:           # a watchdog that trips S s after the last byte
                self._alive_until_us = max(self._alive_until_us,
                                           self.last_byte_us + int(late * 1e6) - 90_000)

    def _reboot(self) -> None:
        """A power cycle: the core powers up again (no HELLO, a new boot id, its time from 0)."""
        self.boots += 1
        self.core.take()                   # what it was sending dies with it
        self.out.clear()
        self._alive_until_us = 0
        self._power_up()
        self.log("reboot", boot_id=self.boot_id)

    def _flags(self, flags: int, t_us: int) -> None:
        self.drive, self.relay = self.core.drive, bool(flags & RELAY)
        if flags & ARMED:
            self.record = bool(flags & RECORD)
            self.touch_us = None
        if flags & READY and self.finger is not None and self.finger.start_us is None:
            self.finger.start_us = t_us

    def _world(self, t: int) -> tuple:
        """The bench for the tick ending at ``t``, as the twin's tick computes it: the finger's
        forces, the skin slab (one 10 ms step), the IR and ambient readings, the heat load."""
        fin = self.finger
        F = fin.force(t) if fin is not None else 0.0
        nz, nf, p = self.noise, self.params.noise_force, self.params
        sh = FingerScript.SHARES
        f = (F * sh[0] + nf * next(nz), F * sh[1] + nf * next(nz),
             F * sh[2] + nf * next(nz), F * sh[3] + nf * next(nz))
        self.forces = f
        touching = F > 0.1
        if touching and self.touch_us is None and self.core.state() in (1, 3):   # armed, rec.
            self.touch_us = t
        load, finger_C = 0.0, None
        skin = self.skin
        if skin is not None:
            if touching and not self.record:
                load = skin.step(True, self.plant.pad) * CONTACT_AREA_M2
                finger_C = skin.surface_C(True)
            elif not touching:
                skin.step(False, p.room)
                finger_C = skin.surface_C(False)
        if finger_C is None:
            finger_C = p.room + p.noise_ambient * next(nz)
        return f, touching, load, finger_C, p.room + p.noise_ambient * next(nz)

    def _control(self, t: int, world: tuple) -> None:
        """One control step at device time ``t``: the pad's physics, the readings, the core."""
        if t <= self._alive_until_us and not self.stalled:
            self._flags(self.core.send(_SILENT_HEARTBEAT, len(_SILENT_HEARTBEAT)), t)
        f, touching, load, finger_C, ambient_C = world
        if self.stalled:                   # hung: the hardware watchdog opened the relay
            self.plant.step(0.0, False, 0.0)
            return
        y = self.plant.step(self.drive, self.relay, load)
        sample_C, skin_side = self._sample_reading(t, touching)
        if skin_side is not None:
            finger_C = skin_side
        flags = self.core.control(t - self.boot_us, y, ambient_C, finger_C, self.plant.hs,
                                  f[0], f[1], f[2], f[3], sample_C,
                                  int(round(y * 1000.0)) & 0xFFFFFFFF)
        self._flags(flags, t)

    def _sample_reading(self, t: int, touching: bool):
        """The sample's thermometer (record mode) and the skin's side while touching."""
        s = self.sample
        if not self.record or self.touch_us is None or self.finger is None:
            return s.temperature_C, None
        if self.curves is None or self.curves[0] != self.touch_us:
            n = int(60e6 / TICK_US) + 200
            tm, ts, _ = s.planned_curves(self.finger.skin_thickness_m,
                                         self.finger.skin_temperature_C, TICK_US * 1e-6, n,
                                         force_N=self.finger.force_N)
            self.curves = (self.touch_us, tm.tolist(), ts.tolist())
        _, tm, ts = self.curves
        k = min((t - self.touch_us) // TICK_US, len(tm) - 1)
        return (tm[k] + self.params.noise_sensor * next(self.noise),
                ts[k] if touching else None)

    # ------------------------------------------------------------------ the sim bench
    def _board_command(self, mtype, payload, n, reply, cap, core_state, ready) -> int:
        """hal_board_command: SIM_SAMPLE, SIM_FINGER, SIM_FAULT (JSON, as the Python twin's)."""
        try:
            if not self.sim:
                data, code = b"not an emulator\0", -int(Err.NOT_SUPPORTED)
                ctypes.memmove(reply, data, min(len(data), cap))
                return code
            args = m.decode_json(ctypes.string_at(payload, n))
            if not isinstance(args, dict):
                raise ValueError("a sim command's payload is a JSON object")
            out = self._sim(mtype, args, State(core_state), bool(ready))
            data = m.encode_json(out)
            if len(data) > cap:
                self.log("sim_reply", reply=out)
                data = m.encode_json({k: v for k, v in out.items() if not isinstance(v, dict)})
            code = len(data)
        except Exception as exc:           # noqa: BLE001 -- nothing may unwind into the C core
            data = str(exc).encode("utf-8")[:max(cap - 1, 0)] + b"\0"
            code = -int(Err.UNKNOWN_COMMAND if mtype not in _SIM_COMMANDS else Err.BAD_ARGUMENT)
        ctypes.memmove(reply, data, min(len(data), cap))
        return code

    def _sim(self, mtype: int, a: dict, core_state: State, ready: bool) -> dict:
        if mtype == Cmd.SIM_SAMPLE:
            self.sample = sample_from_args(a)
            return dict(vars(self.sample))
        if mtype == Cmd.SIM_FINGER:
            return self._sim_finger(a, core_state, ready)
        if mtype != Cmd.SIM_FAULT:
            raise LookupError(f"type 0x{mtype:02x}")
        specs = parse_faults(a["spec"], where="sim_fault")
        now = self.time_us * 1e-6
        shifted = [s.shifted(now) for s in specs]
        self.faults += shifted
        for listener in self.fault_listeners:
            listener(shifted)
        if not self.stalled and self._fault_value("stall", now) is not None:
            self.stalled = True                                # hangs right after this reply
            self.log("stall")
        self.log("fault_injected", spec=a["spec"])
        return dict(now_s=now, faults=len(specs))

    def _sim_finger(self, a: dict, core_state: State, ready: bool) -> dict:
        f = finger_from_args(a)
        armed_waiting = core_state == State.ARMED and not ready
        if not armed_waiting:              # the finger waits for the cue (READY) when armed
            f.start_us = self.time_us
        self.finger = f
        self.skin = FingerSkin(f.skin_thickness_m, f.skin_temperature_C, TICK_US * 1e-6,
                               self._r_fp)
        self.log("finger", **a)
        reply = dict(start_s=None if f.start_us is None else f.start_us * 1e-6)
        if core_state == State.ARMED and self.record:
            n = int(60e6 / TICK_US) + 200
            plans = self.sample.planned_curves(f.skin_thickness_m, f.skin_temperature_C,
                                               TICK_US * 1e-6, n, force_N=f.force_N)[2]
            reply["sample_model"] = {k: dict(v) for k, v in plans.items()}
        elif core_state == State.ARMED:
            reply["finger_on_pad_model"] = dict(FINGER_ON_PAD_MODEL)
        return reply


_SIM_COMMANDS = (Cmd.SIM_SAMPLE, Cmd.SIM_FINGER, Cmd.SIM_FAULT)
_tuple_new = tuple.__new__


def _whole_frames(data: bytes) -> list:
    """The core's output as frames, without checking it: the core queues whole frames only
    (fw.c tx_bytes) and nothing lies between it and here (no fault injected: the direct path).
    Layout (docs/display-protocol.md §1): A5 5A, length u16, seq, type, crc8, payload, crc16."""
    out, i, n = [], 0, len(data)
    while i + 9 <= n:
        ln = data[i + 2] | data[i + 3] << 8
        out.append(_tuple_new(Frame, (data[i + 4], data[i + 5], data[i + 7:i + 7 + ln])))
        i += 9 + ln
    return out
