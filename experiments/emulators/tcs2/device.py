"""A TCS II in software: its ASCII commands, a five-zone probe and injected faults.

:class:`Tcs2Device` is ticked every 10 ms (:meth:`~Tcs2Device.tick`) by a transport (the
``tcs2emu://`` pyserial URL of :mod:`.protocol_tcs2emu`, or the pty server of
:mod:`.pty_server`); bytes from the host go in through :meth:`~Tcs2Device.feed`, bytes to the
host come out of :meth:`~Tcs2Device.take`.

The probe: each zone follows its setpoint with a 15 ms lag and at most 300 °C/s, with 5 mK of
noise; the neutral sensor reads the neutral temperature. While a stimulation runs the device
prints the temperatures every tick (100 Hz, ``Ob``); between stimulations once a second
(``Oa``); ``F`` mutes both. A stimulation plays the user profile (``Uw``) on the zones enabled
for it (``Ue``) and ``C``/``V``/``D``/``R`` on the other enabled zones, starting from where each
zone is; it starts on ``L``, or on the trigger input when ``Os`` enabled it (the emulator's
``#T`` pulses that input). Setpoints above the maximum (``Om``) are clamped to it.

Faults (``FAULTS`` grammar): ``drop=P`` (each stream line lost with probability P),
``KIND@N:T`` for the N-th stimulation (from 1), T s after its start, with KIND one of
``garbage`` (a line of binary junk), ``unknown`` (a well-formed line the protocol does not
have), ``halfline`` (half a stream line, then 1 s of silence), ``silent`` (nothing more is
answered or printed), ``disconnect`` (the port fails), ``zone`` (``zone@N:T:Z``: zone Z, default
3, reports error 2 in ``Q`` and its sensor sticks), ``overheat`` (``overheat@N:T:Z``: zone Z's
driver sticks at full heating, whatever the maximum, towards 55 °C, until ``A``), ``runon``
(after the stimulation's profile ends, silently, the zones go on stimulating at 50 °C for 14 s
unless ``A`` stops them); ``om_cap=X`` makes the device hold at most
X °C as its maximum whatever ``Om`` asks (a device that reports another maximum).
"""
from __future__ import annotations

import math
import random
from dataclasses import dataclass

__all__ = ["Tcs2Device", "Fault", "parse_faults", "TICK_S", "FIRMWARE", "PROBE_ID"]

TICK_S = 0.01
FIRMWARE = "012 thermocue-emulator"
PROBE_ID = "EM 00 00 00 00 00 00 01"
_LAG_S = 0.015
_MAX_RATE = 300.0
_KINDS = ("garbage", "unknown", "halfline", "silent", "disconnect", "zone", "overheat", "runon")
#: What the ``overheat`` fault heats a zone to, and the ``runon`` fault keeps stimulating at, °C,
#: and for how long the run-on lasts, s.
OVERHEAT_C = 55.0
RUNON_C, RUNON_S = 50.0, 14.0
HELP_LINES = (
    "TCS2 emulator",
    f"Firmware: {FIRMWARE}",
    f"Probe ID: {PROBE_ID}",
    "Probe TYPE: 003",
    "",
    "Command list:",
    "'H' help; '?' identity; 'Nxxx' neutral; 'Sxxxxx' zones; 'Csxxx' temperature;",
    "'Vsxxxx'/'Rsxxxx' speeds; 'Dsxxxxx' duration; 'L' start; 'A' abort; 'F' mute;",
    "'Oa'/'Ob' display between/during; 'Od' follow; 'Omxxx' maximum; 'Oe'/'E' temperatures;",
    "'Os'/'Ose'/'Osd' trigger in; 'Oo' trigger out; 'Q' errors; 'P' parameters;",
    "'Uw...' profile; 'Uexxxxx' profile zones; 'Ur' read profile; '#T' emulator: trigger in",
)


@dataclass(frozen=True)
class Fault:
    """One injected fault: ``kind`` in the ``stim``-th stimulation, ``at_s`` after its start."""

    kind: str
    stim: int
    at_s: float
    arg: int = 3


def parse_faults(spec: str | None) -> tuple:
    """``(faults, drop probability, om_cap °C or None)`` from a FAULTS string.

    Raises
    ------
    ValueError
        An unknown kind or a malformed item (the item is quoted).
    """
    faults, drop, cap = [], 0.0, None
    for item in (spec or "").split(","):
        item = item.strip()
        if not item:
            continue
        try:
            if item.startswith("drop="):
                drop = float(item[5:])
                if not 0 <= drop < 1:
                    raise ValueError
            elif item.startswith("om_cap="):
                cap = float(item[7:])
            else:
                kind, _, where = item.partition("@")
                if kind not in _KINDS or not where:
                    raise ValueError
                parts = where.split(":")
                stim, at = int(parts[0]), float(parts[1]) if len(parts) > 1 else 0.0
                arg = int(parts[2]) if len(parts) > 2 else 3
                if stim < 1 or at < 0 or not 1 <= arg <= 5:
                    raise ValueError
                faults.append(Fault(kind, stim, at, arg))
        except (ValueError, IndexError):
            raise ValueError(f"TCS II emulator faults: expected drop=P, om_cap=X or "
                             f"KIND@N[:T[:ZONE]] with KIND in {', '.join(_KINDS)}, got {item!r}") from None
    return tuple(faults), drop, cap


class Tcs2Device:
    """The emulated device (see the module docstring)."""

    def __init__(self, faults: str | None = None, seed: int = 0, firmware: str | None = None):
        self.faults, self.drop, self.om_cap = parse_faults(faults)
        # another firmware string: the emulator passes for a device (no scripted participant)
        self.firmware = firmware or FIRMWARE
        self.rng = random.Random(seed)
        self.time_s = 0.0
        self.neutral_dC = 320
        self.max_dC = 500
        self.zones = (1, 1, 1, 1, 1)
        self.profile_zones = (0, 0, 0, 0, 0)
        self.profile: dict = {z: () for z in range(1, 6)}
        self.C = [320] * 5
        self.V = [100] * 5             # 0.1 °C/s
        self.R = [100] * 5
        self.D = [1000] * 5            # ms
        self.trigger_in = False
        self.ob, self.oa = True, True
        self.temps = [32.0] * 5
        self.setpoints = [32.0] * 5
        self.errors = [0] * 6
        self.stuck = [False] * 5
        self.state = "idle"            # idle, stim, follow, runon
        self.hot = [False] * 5         # overheat: the zone's driver stuck at full heating
        self.runon = False             # runon: the stimulation goes on after its profile
        self._runon_until = 0.0
        self.stim_count = 0
        self.stim_t = 0.0
        self._plans = None
        self._rx = bytearray()
        self._out = bytearray()
        self._silent_until = -1.0
        self.silent_forever = False
        self.disconnected = False
        self._fired: set = set()
        self._idle_line_t = 0.0
        self.commands: list = []       # every command line received (for tests and the log)

    # ------------------------------------------------------------------ transport side
    def feed(self, data: bytes) -> None:
        """Bytes from the host; complete lines are carried out at once."""
        self._rx += data
        while True:
            idx = min((i for i in (self._rx.find(b"\r"), self._rx.find(b"\n")) if i >= 0), default=-1)
            if idx < 0:
                if len(self._rx) > 8192:        # no line end in 8 KiB: junk, forget it
                    self._rx.clear()
                return
            line = bytes(self._rx[:idx]).decode("ascii", "replace").strip()
            del self._rx[:idx + 1]
            if line:
                self.commands.append(line)
                if not self._mute():
                    for reply in self.command(line):
                        self._emit(reply)

    def take(self) -> bytes:
        """Bytes for the host printed so far (and forget them)."""
        out = bytes(self._out)
        self._out.clear()
        return out

    def pending(self) -> int:
        return len(self._out)

    def _mute(self) -> bool:
        return self.silent_forever or self.time_s < self._silent_until

    def _emit(self, line: str) -> None:
        self._out += line.encode("ascii") + b"\r\n"

    # ------------------------------------------------------------------ commands
    def command(self, line: str) -> list:
        """Carry out one command line; return the reply lines (most commands print none)."""
        c = line
        try:
            exact = _EXACT.get(c)
            if exact is not None:
                return exact(self)
            reply = self._set_command(c)
            if reply is not None:
                return reply
        except (ValueError, IndexError):
            pass
        return [f"ERR unknown command: {c[:40]}"]

    # the commands without an argument (:data:`_EXACT`)
    def _help(self) -> list:
        return [x.replace(FIRMWARE, self.firmware) for x in HELP_LINES]

    def _parameters(self) -> list:
        return [f"N{self.neutral_dC:03d} Om{self.max_dC:03d} "
                f"S{''.join(map(str, self.zones))} Ue{''.join(map(str, self.profile_zones))} "
                f"Os{int(self.trigger_in)}"]

    def _temperatures(self) -> list:
        return ["+".join(f"{int(round(v * 10)):03d}" for v in self._readings())]

    def _error_codes(self) -> list:
        return ["".join(str(min(9, e)) for e in self.errors)]

    def _set_outputs(self, ob: bool | None = None, oa: bool | None = None) -> list:
        if ob is not None:
            self.ob = ob
        if oa is not None:
            self.oa = oa
        return []

    def _set_trigger_in(self, on: bool) -> list:
        self.trigger_in = on
        return []

    def _trigger(self) -> list:
        if self.trigger_in and self.state == "idle":
            self._start()
        return []

    def _follow(self) -> list:
        self.state = "follow"
        for z in range(5):
            if self.zones[z]:
                self.setpoints[z] = min(self.C[z], self.max_dC) / 10
        return []

    def _profile_lines(self) -> list:
        return [f"{z} {self.profile_zones[z - 1]} {len(self.profile[z]):03d}"
                + "".join(f"{d:03d}{t:03d}" for d, t in self.profile[z]) for z in range(1, 6)]

    def _set_command(self, c: str) -> list | None:
        """A command with an argument (a setting, an upload); None if ``c`` is none of them."""
        if c.startswith("Om") and len(c) == 5 and c[2:].isdigit():
            v = int(c[2:])
            if not 100 <= v <= 600:
                return [f"ERR Om out of range: {c}"]
            if self.om_cap is not None:
                v = min(v, int(round(self.om_cap * 10)))
            self.max_dC = v
            return []
        if c[0] == "N" and len(c) == 4 and c[1:].isdigit():
            v = int(c[1:])
            if not 200 <= v <= 400:
                return [f"ERR N out of range: {c}"]
            self.neutral_dC = v
            if self.state == "idle":
                self.setpoints = [v / 10] * 5
            return []
        if c[0] == "S" and len(c) == 6 and set(c[1:]) <= {"0", "1"}:
            self.zones = tuple(int(x) for x in c[1:])
            return []
        if c.startswith("Ue") and len(c) == 7 and set(c[2:]) <= {"0", "1"}:
            self.profile_zones = tuple(int(x) for x in c[2:])
            return []
        if c.startswith("Uw"):
            return self._upload(c)
        if c[0] in "CVRD" and len(c) >= 3 and c[1] in "012345" and c[2:].isdigit():
            width = {"C": 3, "V": 4, "R": 4, "D": 5}[c[0]]
            if len(c) != 2 + width:
                return [f"ERR bad length: {c}"]
            v, zone = int(c[2:]), int(c[1])
            ok = {"C": 100 <= v <= 600, "V": 1 <= v <= 9999, "R": 1 <= v <= 9999,
                  "D": 1 <= v <= 99999}[c[0]]
            if not ok:
                return [f"ERR {c[0]} out of range: {c}"]
            if c[0] == "C":
                v = min(v, self.max_dC)      # 'C' is limited to the maximum
            target = getattr(self, c[0])
            for z in (range(5) if zone == 0 else [zone - 1]):
                target[z] = v
            return []
        return None

    def _upload(self, c: str) -> list:
        mask, n, body = c[2:7], c[7:10], c[10:]
        if not (len(mask) == 5 and set(mask) <= {"0", "1"} and n.isdigit() and body.isdigit()
                and len(body) == 6 * int(n)):
            return [f"ERR Uw malformed: {c[:40]}"]
        seg = tuple((int(body[i:i + 3]), int(body[i + 3:i + 6])) for i in range(0, len(body), 6))
        if any(not (1 <= d <= 999 and 0 <= t <= 600) for d, t in seg):
            return [f"ERR Uw segment out of range: {c[:40]}"]
        for z in range(1, 6):
            if mask[z - 1] == "1":
                self.profile[z] = seg
        return []

    # ------------------------------------------------------------------ stimulation
    def _start(self) -> None:
        self.stim_count += 1
        self.stim_t = 0.0
        self.stim_ticks = 0
        self.state = "stim"
        plans = []
        for z in range(5):
            if not self.zones[z]:
                plans.append(None)
                continue
            start = self.temps[z]
            if self.profile_zones[z] and self.profile[z + 1]:
                kt, ky = [0.0], [start]
                for d, t in self.profile[z + 1]:
                    kt.append(kt[-1] + d * 0.01)
                    ky.append(min(t, self.max_dC) / 10)
            else:
                target = min(self.C[z], self.max_dC) / 10
                ramp = abs(target - start) / (self.V[z] / 10)
                kt = [0.0, ramp, ramp + self.D[z] / 1000]
                ky = [start, target, target]
            plans.append((kt, ky))
        self._plans = plans

    def _abort(self) -> None:
        self.hot = [False] * 5
        self.state = "idle"
        self._plans = None
        self.setpoints = [self.neutral_dC / 10] * 5

    def _plan_value(self, z: int, t: float):
        kt, ky = self._plans[z]
        if t > kt[-1] + 1e-9:             # the last line is the profile's end
            return None
        for i in range(1, len(kt)):
            if t <= kt[i]:
                a = (t - kt[i - 1]) / (kt[i] - kt[i - 1]) if kt[i] > kt[i - 1] else 1.0
                return ky[i - 1] + a * (ky[i] - ky[i - 1])
        return None

    # ------------------------------------------------------------------ time
    def tick(self) -> None:
        """Advance 10 ms: plant, stimulation, faults, what is printed."""
        self.time_s += TICK_S
        stream = False
        if self.state == "stim":
            self.stim_ticks += 1
            self.stim_t = self.stim_ticks * TICK_S
            running = False
            for z in range(5):
                if self._plans[z] is None:
                    continue
                v = self._plan_value(z, self.stim_t)
                if v is not None:
                    running = True
                    self.setpoints[z] = v
            if running:
                stream = self.ob
            elif self.runon:            # fault: done, yet it goes on stimulating, silently
                self.runon = False
                self.state = "runon"
                self._runon_until = self.time_s + RUNON_S
                self.setpoints = [RUNON_C] * 5
            else:
                self._abort()           # done: back to neutral at the return speed
        elif self.state == "runon" and self.time_s >= self._runon_until:
            self._abort()
        a = 1.0 - math.exp(-TICK_S / _LAG_S)
        for z in range(5):
            if self.stuck[z]:
                continue
            target = OVERHEAT_C if self.hot[z] else self.setpoints[z]
            step = (target - self.temps[z]) * a
            lim = _MAX_RATE * TICK_S
            self.temps[z] += max(-lim, min(lim, step))
        if self.state == "stim":
            self._faults_due()
        if self.disconnected or self._mute():
            return
        if stream:
            line = self._stream_line()
            if self.drop and self.rng.random() < self.drop:
                return
            self._emit(line)
        elif self.state == "idle" and self.oa and self.time_s - self._idle_line_t >= 1.0:
            self._idle_line_t = self.time_s
            self._emit(self._stream_line())

    def _readings(self) -> list:
        noise = [self.rng.gauss(0.0, 0.005) for _ in range(5)]
        return [self.neutral_dC / 10] + [t + n for t, n in zip(self.temps, noise)]

    def _stream_line(self) -> str:
        return "+".join(f"{max(0, int(round(v * 100))):04d}" for v in self._readings())

    def _faults_due(self) -> None:
        for i, f in enumerate(self.faults):
            if i in self._fired or f.stim != self.stim_count or self.stim_t + 1e-9 < f.at_s:
                continue
            self._fired.add(i)
            if f.kind == "garbage":
                self._out += b"\xfe\x00\x13#!\x7f\r\n"
            elif f.kind == "unknown":
                self._emit("OK")
            elif f.kind == "halfline":
                self._out += self._stream_line().encode()[:11]
                self._silent_until = self.time_s + 1.0
            elif f.kind == "silent":
                self.silent_forever = True
            elif f.kind == "disconnect":
                self.disconnected = True
            elif f.kind == "overheat":
                self.hot[f.arg - 1] = True
            elif f.kind == "runon":
                self.runon = True
            elif f.kind == "zone":
                self.errors[f.arg] = 2
                self.stuck[f.arg - 1] = True


#: The commands without an argument, each to its handler (a reply list; most are empty).
_EXACT = {
    "?": lambda d: ["TCS"],
    "H": Tcs2Device._help,
    "P": Tcs2Device._parameters,
    "E": Tcs2Device._temperatures,
    "Oe": lambda d: [d._stream_line()],
    "Q": Tcs2Device._error_codes,
    "L": lambda d: d._start() or [],
    "A": lambda d: d._abort() or [],
    "F": lambda d: d._set_outputs(ob=False, oa=False),
    "Ob": lambda d: d._set_outputs(ob=True),
    "Oa": lambda d: d._set_outputs(oa=True),
    "Os": lambda d: d._set_trigger_in(True),
    "Ose": lambda d: d._set_trigger_in(True),
    "Osd": lambda d: d._set_trigger_in(False),
    "Oo": lambda d: [],
    "#T": Tcs2Device._trigger,
    "Od": Tcs2Device._follow,
    "Ur": Tcs2Device._profile_lines,
}
