"""Messages of the display protocol: type codes, error codes, payload layouts, typed responses.

The authoritative description is ``docs/display-protocol.md``; this module is its executable form.
Temperatures travel as int16 hundredths of a degree Celsius, forces as int16 hundredths of a
newton, device time as uint64 microseconds. Replies carry the command's type with bit 7 set
(``Cmd.HELLO | 0x80``) and echo the command's sequence number.
"""
from __future__ import annotations

import enum
import json
import struct
from dataclasses import asdict, dataclass
from typing import NamedTuple

__all__ = [
    "PROTOCOL_VERSION", "Cmd", "Msg", "Err", "State", "Event", "Mode", "REPLY_BIT",
    "DeviceInfo", "Status", "Telemetry", "DeviceEvent", "UploadAck", "CommitAck",
    "centi", "from_centi", "error_name", "END_COMPLETE", "END_RELEASED", "END_MAX_DURATION",
    "END_ABORTED", "END_FAULT", "END_NAMES",
    "HELLO_REQ", "CLEAR_FAULT_MAGIC", "HELLO_REPLY_HEAD", "TIME", "CENTI", "LIMITS", "UPLOAD_BEGIN", "UPLOAD_CHUNK_HEAD",
    "UPLOAD_CHUNK_ACK", "COMMIT", "COMMIT_ACK", "ARM", "COUNTER", "STATUS_REPLY", "TELEMETRY", "EVENT_HEAD",
    "NAK_HEAD", "encode_strings", "encode_json", "decode_json",
]

PROTOCOL_VERSION = 2      # 2: frames carry a CRC-8 of their header (docs/display-protocol.md §1)
REPLY_BIT = 0x80


class Cmd(enum.IntEnum):
    """Host-to-device command types."""

    HELLO = 0x01
    HEARTBEAT = 0x02
    SET_NEUTRAL = 0x03
    SET_LIMITS = 0x04
    UPLOAD_BEGIN = 0x10
    UPLOAD_CHUNK = 0x11
    UPLOAD_COMMIT = 0x12
    ARM = 0x20
    ABORT = 0x21
    STATUS = 0x22
    CLEAR_FAULT = 0x23     # operator reset of a latched fault (never sent by a session)
    SET_TRIP = 0x24        # a qualification test lowers the over-temperature trip (thermocue check)
    SIM_SAMPLE = 0x30      # emulator only (capability "sim")
    SIM_FINGER = 0x31
    SIM_FAULT = 0x32


class Msg(enum.IntEnum):
    """Device-originated message types that are not replies."""

    TELEMETRY = 0xA0
    EVENT = 0xA1
    NAK = 0xFF


class Err(enum.IntEnum):
    """Error codes (refusals, 1..19) and fault codes (20..)."""

    OK = 0
    UNKNOWN_COMMAND = 1
    BAD_LENGTH = 2
    BAD_ARGUMENT = 3
    BAD_STATE = 4
    OUT_OF_RANGE = 5
    PROFILE_INCOMPLETE = 6
    PROFILE_CRC = 7
    NOT_SUPPORTED = 8
    NO_HELLO = 9
    FAULT_LATCHED = 10
    WATCHDOG = 20
    OVER_TEMPERATURE = 21
    SENSOR_FAILURE = 22
    SENSOR_STUCK = 23


def error_name(code: int) -> str:
    """The name of an error code (``"CODE_<n>"`` for an unknown one)."""
    try:
        return Err(code).name
    except ValueError:
        return f"CODE_{code}"


class State(enum.IntEnum):
    """Device states (see the transition table in ``docs/display-protocol.md``)."""

    IDLE = 0        # holding neutral
    ARMED = 1       # moving to / holding the profile's first value; contact detection once ready
    PLAYING = 2     # profile running since contact
    RECORDING = 3   # record mode: Peltier idle, sensors streamed since contact
    FAULT = 4       # safe state after a fault: Peltier relay open; over-temperature and sensor
    #                 faults stay latched until CLEAR_FAULT (an operator reset), ABORT keeps them


class Mode(enum.IntEnum):
    """Arm modes."""

    PLAYBACK = 0
    RECORD = 1


class Event(enum.IntEnum):
    """Kinds of EVENT messages."""

    READY = 1       # armed and at the starting temperature; contact detection on
    CONTACT = 2     # summed force crossed the threshold; time = contact time stamp
    END = 3         # trial over; arg = 0 complete, 1 released, 2 max duration, 3 aborted
    FAULT = 4       # arg = fault code
    WATCHDOG = 5    # heartbeat lost; arg = ms since the last heartbeat


#: Why a trial ended (EVENT END argument, STATUS end_reason): the device sends them, the host
#: names them.
END_COMPLETE, END_RELEASED, END_MAX_DURATION, END_ABORTED, END_FAULT = 0, 1, 2, 3, 4
END_NAMES = {END_COMPLETE: "complete", END_RELEASED: "released", END_MAX_DURATION: "max_duration",
             END_ABORTED: "aborted", END_FAULT: "fault"}


# --- payload layouts -------------------------------------------------------------------------
HELLO_REQ = struct.Struct("<B")                 # host protocol version
HELLO_REPLY_HEAD = struct.Struct("<BHhhHhHIII")  # version, telemetry_hz, hard_min, hard_max,
#                                                 max_rate (c°C/s), neutral, watchdog_ms,
#                                                 max_points, min_dt_us, boot_id; then 3
#                                                 length-prefixed strings
TIME = struct.Struct("<Q")                      # device time, µs
CENTI = struct.Struct("<h")
LIMITS = struct.Struct("<hhH")                  # min, max (c°C), max rate (c°C/s)
UPLOAD_BEGIN = struct.Struct("<II")             # n points, dt µs
UPLOAD_CHUNK_HEAD = struct.Struct("<IH")        # offset, count; then count int16
UPLOAD_CHUNK_ACK = struct.Struct("<IHI")        # offset, count, crc32 of the chunk's bytes
COMMIT = struct.Struct("<I")                    # crc32 of the whole profile's bytes
COMMIT_ACK = struct.Struct("<IIH")              # n points, crc32, samples clamped by the device
ARM = struct.Struct("<BHI")                     # mode, threshold (cN), max duration (ms)
COUNTER = struct.Struct("<I")                   # ARM's reply: telemetry counter at arming
STATUS_REPLY = struct.Struct("<BBQhhhhhhhhhhIQBIII")
#   state, last fault, time, setpoint, contact, ambient, finger, heat sink, forces x4, neutral,
#   profile points, contact time (µs, 0 = none), end reason, telemetry counter, trials, boot id
TELEMETRY = struct.Struct("<IQhhhhhhhhBB")
#   counter, time µs, setpoint, contact, ambient, finger, forces x4 (cN), state, fault
EVENT_HEAD = struct.Struct("<BQh")              # kind, time µs, arg; then utf-8 text
NAK_HEAD = struct.Struct("<BB")                 # refused command type, error code; then utf-8 text
CLEAR_FAULT_MAGIC = b"OPERATOR-RESET"           # CLEAR_FAULT's payload: no stray frame is one


def centi(value: float) -> int:
    """Round a value to an int16 count of hundredths (saturating)."""
    v = int(round(value * 100.0))
    return -32768 if v < -32768 else 32767 if v > 32767 else v


def from_centi(v: int) -> float:
    """Hundredths back to a float."""
    return v / 100.0


def encode_strings(*items: str) -> bytes:
    out = bytearray()
    for s in items:
        b = s.encode("utf-8")[:255]
        out.append(len(b))
        out += b
    return bytes(out)


def encode_json(obj) -> bytes:
    return json.dumps(obj, separators=(",", ":"), sort_keys=True).encode("utf-8")


def decode_json(data: bytes):
    return json.loads(data.decode("utf-8"))


# --- typed responses -------------------------------------------------------------------------
class _Response:
    def to_json(self) -> str:
        """The response as a JSON object (field names as keys)."""
        return json.dumps(asdict(self), sort_keys=True)


@dataclass(frozen=True)
class DeviceInfo(_Response):
    """What the device said in the handshake.

    Parameters
    ----------
    device_id, firmware : str
    capabilities : tuple of str
        ``"playback"``, ``"record"``, ``"sim"`` (emulator), ...
    protocol : int
    telemetry_hz : int, Hz
    hard_min_C, hard_max_C : float, °C
        The firmware's own range; setpoints are clamped to it regardless of the host.
    max_rate_C_per_s : float, °C/s
    neutral_C : float, °C
    watchdog_ms : int, ms
    max_points : int
    min_dt_s : float, s
    boot_id : int
        Drawn afresh at every power-up: a different one means the device restarted.
    image_id : str
        The running image's id (the reference firmware: its GNU build id, as ``firmware/build``
        records it in ``build.json``; the emulator: ``emulator-<version>``); ``""`` when the
        device's HELLO reply has no fourth string (an older firmware).
    """

    device_id: str
    firmware: str
    capabilities: tuple
    protocol: int
    telemetry_hz: int
    hard_min_C: float
    hard_max_C: float
    max_rate_C_per_s: float
    neutral_C: float
    watchdog_ms: int
    max_points: int
    min_dt_s: float
    boot_id: int = 0
    image_id: str = ""


@dataclass(frozen=True)
class Status(_Response):
    """A STATUS reply (temperatures °C, forces N, times s)."""

    state: str
    last_fault: str | None
    device_time_s: float
    setpoint_C: float
    contact_C: float
    ambient_C: float
    finger_C: float
    heatsink_C: float
    forces_N: tuple
    neutral_C: float
    profile_points: int
    contact_time_s: float | None
    end_reason: int
    telemetry_counter: int
    trials: int
    boot_id: int = 0

    @classmethod
    def decode(cls, payload: bytes) -> "Status":
        (st, fault, t, sp, ct, amb, fin, hs, f1, f2, f3, f4, neu, npts, tc, endr, cnt,
         trials, boot) = STATUS_REPLY.unpack(payload)
        return cls(State(st).name, None if fault == 0 else error_name(fault), t * 1e-6, sp / 100,
                   ct / 100, amb / 100, fin / 100, hs / 100, (f1 / 100, f2 / 100, f3 / 100, f4 / 100),
                   neu / 100, npts, None if tc == 0 else tc * 1e-6, endr, cnt, trials, boot)


class Telemetry(NamedTuple):
    """One telemetry frame (a named tuple: 100 of them a second must stay cheap).

    Fields: ``counter`` (frame number since power-up), ``device_time_s`` (s), ``setpoint_C``,
    ``contact_C``, ``ambient_C``, ``finger_C`` (°C), ``forces_N`` (4 × N), ``state`` (str),
    ``fault`` (str or None).
    """

    counter: int
    device_time_s: float
    setpoint_C: float
    contact_C: float
    ambient_C: float
    finger_C: float
    forces_N: tuple
    state: str
    fault: str | None

    @classmethod
    def decode(cls, payload: bytes) -> "Telemetry":
        c, t, sp, ct, amb, fin, f1, f2, f3, f4, st, fault = _TEL_UNPACK(payload)
        # tuple.__new__ directly: the named tuple's own __new__ is a Python call (a third of
        # the cost of a frame's decoding, 100 times a second)
        return _tuple_new(cls, (c, t * 1e-6, sp * 0.01, ct * 0.01, amb * 0.01, fin * 0.01,
                                (f1 * 0.01, f2 * 0.01, f3 * 0.01, f4 * 0.01), _STATE_NAMES[st],
                                None if fault == 0 else error_name(fault)))

    @property
    def force_N(self) -> float:
        """Summed force, N."""
        return sum(self.forces_N)


_STATE_NAMES = {s.value: s.name for s in State}
_TEL_UNPACK = TELEMETRY.unpack
_tuple_new = tuple.__new__


@dataclass(frozen=True)
class DeviceEvent(_Response):
    """An EVENT message: ``kind`` (READY, CONTACT, END, FAULT, WATCHDOG), time s, arg, text."""

    kind: str
    device_time_s: float
    arg: int
    text: str

    @classmethod
    def decode(cls, payload: bytes) -> "DeviceEvent":
        kind, t, arg = EVENT_HEAD.unpack_from(payload)
        return cls(Event(kind).name, t * 1e-6, arg,
                   payload[EVENT_HEAD.size:].decode("utf-8", "replace"))


@dataclass(frozen=True)
class UploadAck(_Response):
    """The device's receipt for one upload chunk."""

    offset: int
    count: int
    crc32: int


@dataclass(frozen=True)
class CommitAck(_Response):
    """The device's receipt for a whole profile (``clamped``: samples it had to clamp)."""

    points: int
    crc32: int
    clamped: int
