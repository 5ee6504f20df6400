"""The TCS II's ASCII commands and replies: formatting on the host, parsing on both ends.

One command per line (the host ends each with ``\\r``); replies are lines ended by ``\\r\\n``.
The command letters, fields and ranges are those of the device's own ``H`` listing as reproduced
by open-source host libraries (``docs/tcs2.md`` names each source and where they disagree). The
reply formats of ``P``, ``Ur``, ``E``/``Oe`` and the 100 Hz stream are those the emulator
(:mod:`.device`) uses; ``docs/tcs2.md`` says which were verified only against it.

Temperatures are integers in tenths (``dC``) or hundredths (``cC``) of a °C on the wire;
functions here take and return °C at their edges.
"""
from __future__ import annotations

import re

from experiments.errors import DisplayError

__all__ = ["ZONES", "NEUTRAL_RANGE_C", "SETPOINT_RANGE_C", "fmt_neutral", "fmt_max",
           "fmt_zones", "fmt_temperature", "fmt_speed", "fmt_duration", "fmt_profile",
           "fmt_profile_enable", "parse_temperatures", "is_temperature_line", "parse_errors", "parse_parameters",
           "parse_profile_lines", "parse_help", "ReplyError"]

#: Number of stimulation zones (areas) of the probe.
ZONES = 5
#: ``N``'s range, °C (``xxx`` = 200..400 tenths).
NEUTRAL_RANGE_C = (20.0, 40.0)
#: ``C``'s and ``Om``'s range, °C (``xxx`` = 100..600 tenths).
SETPOINT_RANGE_C = (10.0, 60.0)


class ReplyError(DisplayError):
    """A reply the host cannot read (garbage, a half line, an unknown answer)."""


def _tenths(value_C: float, lo_C: float, hi_C: float, field: str) -> int:
    v = float(value_C)
    if not lo_C <= v <= hi_C:
        raise ValueError(f"TCS II {field}: expected {lo_C:g} ≤ T ≤ {hi_C:g} °C, got {v!r}")
    q = int(round(v * 10))
    return q


def _zone_mask(zones) -> str:
    zones = tuple(zones)
    if not zones or any(z not in range(1, ZONES + 1) for z in zones):
        raise ValueError(f"TCS II zones: expected a non-empty subset of 1..{ZONES}, got {zones!r}")
    return "".join("1" if z in zones else "0" for z in range(1, ZONES + 1))


def fmt_neutral(value_C: float) -> str:
    """``Nxxx``: neutral temperature, 0.1 °C, 20.0–40.0 °C."""
    return f"N{_tenths(value_C, *NEUTRAL_RANGE_C, 'N'):03d}"


def fmt_max(value_C: float) -> str:
    """``Omxxx``: maximum stimulation temperature, 0.1 °C (``C`` is limited to it)."""
    return f"Om{_tenths(value_C, *SETPOINT_RANGE_C, 'Om'):03d}"


def fmt_zones(zones) -> str:
    """``Sxxxxx``: enable the zones ``zones`` (1..5), disable the others."""
    return "S" + _zone_mask(zones)


def fmt_temperature(value_C: float, zone: int = 0) -> str:
    """``Csxxx``: stimulation temperature of zone ``zone`` (0: all), 0.1 °C."""
    return f"C{int(zone)}{_tenths(value_C, *SETPOINT_RANGE_C, 'C'):03d}"


def fmt_speed(rate_C_per_s: float, zone: int = 0, *, ret: bool = False) -> str:
    """``Vsxxxx`` (ramp) or ``Rsxxxx`` (return) speed, 0.1 °C/s, 0.1–999.9 °C/s."""
    q = int(round(float(rate_C_per_s) * 10))
    if not 1 <= q <= 9999:
        raise ValueError(f"TCS II {'R' if ret else 'V'}: expected 0.1–999.9 °C/s, got {rate_C_per_s!r}")
    return f"{'R' if ret else 'V'}{int(zone)}{q:04d}"


def fmt_duration(duration_s: float, zone: int = 0) -> str:
    """``Dsxxxxx``: stimulation duration, ms, 1–99999."""
    q = int(round(float(duration_s) * 1000))
    if not 1 <= q <= 99999:
        raise ValueError(f"TCS II D: expected 1 ms–99.999 s, got {duration_s!r}")
    return f"D{int(zone)}{q:05d}"


def fmt_profile(zones, segments) -> str:
    """``Uwxxxxxnnn(dddttt)*``: a user profile of ``segments`` (steps of 10 ms, ends in 0.1 °C)."""
    segments = tuple(segments)
    if not 1 <= len(segments) <= 999:
        raise ValueError(f"TCS II Uw: expected 1–999 segments, got {len(segments)}")
    body = []
    for s in segments:
        if not (1 <= s.steps <= 999 and 0 <= s.end_dC <= 600):
            raise ValueError(f"TCS II Uw: expected 10 ms–9.99 s and 0–60.0 °C per segment, got "
                             f"{s.steps * 10} ms to {s.end_dC / 10} °C")
        body.append(f"{s.steps:03d}{s.end_dC:03d}")
    return f"Uw{_zone_mask(zones)}{len(segments):03d}" + "".join(body)


def fmt_profile_enable(zones) -> str:
    """``Uexxxxx``: play the user profile on ``zones`` (the others play C/V/R/D)."""
    return "Ue" + ("00000" if not tuple(zones) else _zone_mask(zones))


_TEMPS = re.compile(r"^\+?(\d{3,4})(?:\+(\d{3,4})){5}$")


def parse_temperatures(line: str) -> tuple:
    """An ``E``/``Oe`` reply or a stream line: neutral and zones 1–5, °C.

    Six fields joined by ``+`` (an optional leading ``+``): three digits are tenths of a °C
    (``E``), four are hundredths (``Oe``, the stream).

    Raises
    ------
    ReplyError
        Anything else (the line is quoted).
    """
    text = line.strip()
    if not _TEMPS.match(text):
        raise ReplyError(f"TCS II: expected six temperatures joined by '+', got {line!r}")
    fields = text.lstrip("+").split("+")
    return tuple(int(f) / (10.0 if len(f) == 3 else 100.0) for f in fields)


def is_temperature_line(line: str) -> bool:
    """Whether ``line`` is a temperature line (``E``, ``Oe``, the display of temperatures)."""
    return bool(_TEMPS.match(line.strip()))


def parse_errors(line: str) -> tuple:
    """A ``Q`` reply: an error digit for neutral and zones 1–5 (0: OK)."""
    text = line.strip()
    if not re.fullmatch(r"\d{6}", text):
        raise ReplyError(f"TCS II Q: expected six error digits, got {line!r}")
    return tuple(int(c) for c in text)


_PARAM = re.compile(r"^N(\d{3}) Om(\d{3}) S([01]{5}) Ue([01]{5}) Os([01])$")


def parse_parameters(line: str) -> dict:
    """A ``P`` reply: neutral and maximum (°C), enabled zones, profile zones, trigger input."""
    m = _PARAM.match(line.strip())
    if not m:
        raise ReplyError(f"TCS II P: expected 'Nxxx Omxxx Sxxxxx Uexxxxx Osx', got {line!r}")
    n, om, s, ue, os_ = m.groups()
    return {"neutral_C": int(n) / 10, "max_C": int(om) / 10,
            "zones": tuple(i + 1 for i, c in enumerate(s) if c == "1"),
            "profile_zones": tuple(i + 1 for i, c in enumerate(ue) if c == "1"),
            "trigger_in": os_ == "1"}


_UR = re.compile(r"^([1-5]) ([01]) (\d{3})((?:\d{6})*)$")


def parse_profile_lines(lines) -> dict:
    """``Ur``'s five lines: per zone, ``(enabled, ((steps, end_dC), ...))``."""
    out = {}
    for line in lines:
        m = _UR.match(line.strip())
        if not m:
            raise ReplyError(f"TCS II Ur: expected 'zone enabled nnn dddttt...', got {line!r}")
        zone, enabled, n, pts = m.groups()
        seg = tuple((int(pts[i:i + 3]), int(pts[i + 3:i + 6])) for i in range(0, len(pts), 6))
        if len(seg) != int(n):
            raise ReplyError(f"TCS II Ur: zone {zone}: {n} segments announced, {len(seg)} listed")
        out[int(zone)] = (enabled == "1", seg)
    if sorted(out) != list(range(1, ZONES + 1)):
        raise ReplyError(f"TCS II Ur: expected lines for zones 1–5, got {sorted(out)}")
    return out


def parse_help(lines) -> dict:
    """The ``H`` listing's header: firmware and probe id (``Firmware:``, ``Probe ID:``)."""
    info = {}
    for line in lines:
        key, _, value = line.partition(":")
        key = key.strip().lower()
        if key == "firmware":
            info["firmware"] = value.strip()
        elif key == "probe id":
            info["probe_id"] = value.strip()
        elif key == "probe type":
            info["probe_type"] = value.strip()
    for need in ("firmware", "probe_id"):
        if not info.get(need):
            raise ReplyError(f"TCS II H: expected a '{need.replace('_', ' ')}:' line, got "
                             f"{list(lines)[:6]!r}")
    return info
