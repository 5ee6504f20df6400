"""What the host accepts in a device's HELLO reply, and why (``docs/display-protocol.md`` §3, §6).

The host's safety argument rests on numbers the device declares: the watchdog that returns the
pad to neutral when the host falls silent, the device's own setpoint range and rate (its second
layer of limits), and the telemetry rate from which the host tells a delivered trial and measures
the tracking error. A device that declares numbers outside what the argument needs is refused at
the handshake, with one line naming the port and the field; a reply too short or malformed to
decode is refused the same way, never with a ``struct.error``. Then the host sends its limits
(:func:`send_limits`); :func:`device_capabilities` is what the reply declares.

Bounds (the spec's, not the emulator's):

========================  ============  ===========================================================
field                     accepted      why
========================  ============  ===========================================================
``version``               2             the frame format (a header CRC) of this host
``watchdog_ms``           50 … 90       ≤ 90: timeout + one 10 ms tick ≤ 100 ms to neutral;
                                        ≥ 50: at least 5 of the host's 10 ms heartbeats fit in it
``telemetry_hz``          50 … 250      ≥ 50: contact time and tracking error to ≤ 20 ms;
                                        ≤ 250: 39-byte frames within 115200 baud (≤ 295 Hz)
``hard_min_C``            ≥ 10.0        the protocol's coldest setpoint
``hard_max_C``            ≤ 44.5        the protocol's highest setpoint, below the 45 °C trip
``max_rate_C_per_s``      0 < r ≤ 100   the protocol's largest setpoint step (1 °C a 10 ms tick)
``neutral_C``             in range      within the device's own range
``max_points``            ≥ 2           an upload needs two samples
``min_dt_s``              ≥ 0.001       the protocol's smallest profile step
========================  ============  ===========================================================
"""
from __future__ import annotations

import struct
import time

from experiments.errors import DisplayError, SafetyLimitError

from . import messages as m
from .framing import SOF
from ..base import Capabilities
from .messages import DeviceInfo

__all__ = ["HandshakeRefused", "decode_hello", "refuse_text_device", "protocol_capabilities",
           "device_capabilities", "send_limits", "TEXT_PROBE", "WATCHDOG_MS_RANGE", "TELEMETRY_HZ_RANGE",
           "PROTOCOL_MIN_C", "PROTOCOL_MAX_SETPOINT_C", "PROTOCOL_MAX_RATE_C_PER_S"]

WATCHDOG_MS_RANGE = (50, 90)
TELEMETRY_HZ_RANGE = (50, 250)
PROTOCOL_MIN_C = 10.0
PROTOCOL_MAX_SETPOINT_C = 44.5
PROTOCOL_MAX_RATE_C_PER_S = 100.0
PROTOCOL_MIN_DT_S = 1e-3


class HandshakeRefused(DisplayError):
    """The device's HELLO reply is malformed or declares what the host's safety cannot accept."""


def decode_hello(payload: bytes, port: str) -> DeviceInfo:
    """Decode and check a HELLO reply.

    Parameters
    ----------
    payload : bytes
        The ACK's payload.
    port : str
        The port's name, for messages.

    Returns
    -------
    DeviceInfo

    Raises
    ------
    HandshakeRefused
        One line: ``display {port}: HELLO reply: {field}: expected ..., got ...``.
    """
    def refuse(field: str, expected: str, got) -> HandshakeRefused:
        return HandshakeRefused(f"display {port}: HELLO reply: {field}: expected {expected}, "
                                f"got {got}; not using this device")

    head = m.HELLO_REPLY_HEAD
    if len(payload) < head.size + 3:
        raise refuse("length", f"at least {head.size + 3} bytes", f"{len(payload)}")
    try:
        (ver, hz, hmin, hmax, rate, neutral, wd, npts, mindt, boot) = head.unpack_from(payload)
    except struct.error as exc:   # cannot happen after the length check; kept as a guard
        raise refuse("header", "the version 2 layout", str(exc)) from None
    strings, pos = [], head.size
    for name in ("device_id", "firmware", "capabilities", "image_id"):
        if pos >= len(payload) and name == "image_id":
            strings.append("")     # an older firmware's three-string reply: no image id
            break
        if pos >= len(payload):
            raise refuse(name, "a length-prefixed string", "the end of the reply")
        n = payload[pos]
        raw = payload[pos + 1:pos + 1 + n]
        if len(raw) != n:
            raise refuse(name, f"{n} bytes", f"{len(raw)}")
        try:
            strings.append(raw.decode("utf-8"))
        except UnicodeDecodeError as exc:
            raise refuse(name, "UTF-8 text", f"a bad byte at offset {exc.start}") from None
        pos += 1 + n
    if ver != m.PROTOCOL_VERSION:
        raise refuse("version", f"protocol {m.PROTOCOL_VERSION}", ver)
    lo, hi = WATCHDOG_MS_RANGE
    if not lo <= wd <= hi:
        raise refuse("watchdog_ms", f"{lo}–{hi} ms (≤ 100 ms from host silence to neutral)", wd)
    lo, hi = TELEMETRY_HZ_RANGE
    if not lo <= hz <= hi:
        raise refuse("telemetry_hz", f"{lo}–{hi} Hz", hz)
    if hmin / 100 < PROTOCOL_MIN_C:
        raise refuse("hard_min_C", f"≥ {PROTOCOL_MIN_C} °C (the protocol's range)", hmin / 100)
    if hmax / 100 > PROTOCOL_MAX_SETPOINT_C:
        raise refuse("hard_max_C", f"≤ {PROTOCOL_MAX_SETPOINT_C} °C (the protocol's range)",
                     hmax / 100)
    if not hmin < hmax:
        raise refuse("hard_min_C, hard_max_C", "min < max", f"{hmin / 100}, {hmax / 100}")
    if not 0 < rate / 100 <= PROTOCOL_MAX_RATE_C_PER_S:
        raise refuse("max_rate_C_per_s", f"0 < rate ≤ {PROTOCOL_MAX_RATE_C_PER_S} °C/s", rate / 100)
    if not hmin <= neutral <= hmax:
        raise refuse("neutral_C", f"within {hmin / 100}–{hmax / 100} °C", neutral / 100)
    if npts < 2:
        raise refuse("max_points", "≥ 2", npts)
    if mindt * 1e-6 < PROTOCOL_MIN_DT_S:
        raise refuse("min_dt_s", f"≥ {PROTOCOL_MIN_DT_S} s", mindt * 1e-6)
    dev_id, fw, caps, image_id = strings
    return DeviceInfo(dev_id, fw, tuple(c for c in caps.split(",") if c), ver, hz,
                      hmin / 100, hmax / 100, rate / 100, neutral / 100, wd, npts,
                      mindt * 1e-6, boot, image_id)


#: The text probe written before the first frame on an OS serial port (a TCS II answers it), and
#: how long its answer is awaited, s (a TCS II answers within a few ms over USB).
TEXT_PROBE = b"?\r"
TEXT_PROBE_WAIT_S = 0.15


def refuse_text_device(port, name: str) -> None:
    """Is a QST.Lab TCS II (a text protocol) on ``port``? Ask before any binary frame.

    Writes ``?`` and a carriage return: a TCS II answers ``TCS``; a device of this protocol skips
    the two bytes as noise before a frame's start. A TCS II is refused in one line naming the
    scheme to open it with; no binary frame is ever sent to it (what one would do to a real
    TCS II is unknown). Port errors propagate (``serial.SerialException``, ``OSError``).

    Raises
    ------
    DisplayError
        The device answered as a TCS II.
    """
    port.reset_input_buffer()
    port.write(TEXT_PROBE)
    got = bytearray()
    end = time.monotonic() + TEXT_PROBE_WAIT_S
    while time.monotonic() < end and b"\r" not in got and b"\n" not in got:
        got += port.read(max(1, port.in_waiting))
    if b"TCS" in got and SOF not in got:
        raise DisplayError(f"display: {name} answers '?' with text ({bytes(got[:20])!r}): a QST.Lab "
                           f"TCS II, not a display of the thermocue protocol; open it as "
                           f"tcs2://{name} (nothing else was sent to it)")


def protocol_capabilities() -> Capabilities:
    """The :class:`~..base.Capabilities` the protocol allows (before a device states its own)."""
    return Capabilities(contact_detection="force", force_sensing=True, telemetry_hz=100.0,
                        max_profile_points=65536, min_profile_step_s=PROTOCOL_MIN_DT_S,
                        safe_range_C=(PROTOCOL_MIN_C, PROTOCOL_MAX_SETPOINT_C),
                        max_rate_C_per_s=PROTOCOL_MAX_RATE_C_PER_S,
                        modes=("playback", "record"), scripted_bench=False,
                        notes="numbers as the protocol allows them; the device states its own "
                              "at the handshake")


def device_capabilities(info) -> Capabilities:
    """The :class:`~..base.Capabilities` a device declared at the handshake (``info``: the
    neutral :class:`~..types.DeviceInfo`)."""
    modes = tuple(md for md in ("playback", "record") if md in info.capabilities)
    return Capabilities(contact_detection="force", force_sensing=True,
                        telemetry_hz=float(info.telemetry_hz), max_profile_points=info.max_points,
                        min_profile_step_s=info.min_dt_s,
                        safe_range_C=(info.hard_min_C, info.hard_max_C),
                        max_rate_C_per_s=info.max_rate_C_per_s,
                        modes=modes or ("playback", "record"),
                        scripted_bench="sim" in info.capabilities,
                        notes=f"{info.device_id}, {info.firmware}")


def send_limits(link, info, lim) -> None:
    """SET_LIMITS with the host's limits ``lim``, checked against the device's range (``info``,
    neutral :class:`~..types.DeviceInfo`) before and against its acknowledgement after.

    Raises
    ------
    SafetyLimitError
        If ``lim`` does not lie inside the device's range (nothing sent).
    DisplayError
        If the device acknowledged limits other than those sent.
    """
    rate = int(round(info.max_rate_C_per_s * 100))
    if lim.min_C < info.hard_min_C or lim.max_C > info.hard_max_C:
        reason = (f"expected a range inside the device's [{info.hard_min_C}, "
                  f"{info.hard_max_C}] °C, got [{lim.min_C}, {lim.max_C}]")
        raise SafetyLimitError(f"display: limits: {reason}", reason=reason)
    sent = (m.centi(lim.min_C), m.centi(lim.max_C),
            min(int(round(lim.max_rate_C_per_s * 100)), 0xFFFF))
    got = link.ask(m.Cmd.SET_LIMITS, m.LIMITS, m.LIMITS.pack(*sent))
    # the range lies inside the device's, so it must hold it exactly; the rate may be
    # lowered to the device's own maximum (a tighter limit, and so not a mismatch)
    want = (sent[0], sent[1], min(sent[2], rate))
    if got != want:
        raise DisplayError(
            f"display: SET_LIMITS: sent {sent[0] / 100}–{sent[1] / 100} °C at "
            f"{sent[2] / 100} °C/s, the device acknowledged {got[0] / 100}–{got[1] / 100} °C "
            f"at {got[2] / 100} °C/s (a stale reply?); not going on with limits it does "
            f"not hold")
