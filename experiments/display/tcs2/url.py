"""The ``tcs2://`` URL: the serial port (or the emulator) and the backend's options.

URL grammar::

    tcs2://PORT[?zones=12345][&start=command|trigger][&tolerance_C=0.1]
    tcs2://emulator[?clock=real|virtual][&faults=FAULTS][&seed=N][&speed=K][&zones=...]...
"""
from __future__ import annotations

import math
import urllib.parse

import serial

from experiments.errors import UserInputError

from . import commands as cmd
from .profile_compiler import RESOLUTION_C

__all__ = ["parse_tcs2_url", "URL_GRAMMAR"]

URL_GRAMMAR = ("tcs2://PORT[?zones=12345][&start=command|trigger][&tolerance_C=0.1] | "
               "tcs2://emulator[?clock=real|virtual][&faults=FAULTS][&seed=N][&speed=K][&zones=...]")
_HOST_OPTIONS = ("zones", "start", "tolerance_C")
_EMU_OPTIONS = ("clock", "faults", "seed", "speed")


def parse_tcs2_url(url: str) -> tuple:
    """``(pyserial URL, options)`` of a ``tcs2://`` URL.

    Raises
    ------
    UserInputError
        Not ``tcs2://``, no port, an unknown option or a bad value (quotes the grammar).
    """
    text = str(url)
    if not text.lower().startswith("tcs2://"):
        raise UserInputError(f"display: expected a URL of the form {URL_GRAMMAR!r}, got {text!r}")
    rest = text[len("tcs2://"):]
    port, _, query = rest.partition("?")
    if not port:
        raise UserInputError(f"display: {text!r}: expected a port after tcs2:// "
                             f"({URL_GRAMMAR!r})")
    opts = {"zones": (1, 2, 3, 4, 5), "start": "command", "tolerance_C": RESOLUTION_C}
    emu = []
    for key, values in urllib.parse.parse_qs(query, keep_blank_values=True).items():
        value = values[-1]
        try:
            if key == "zones":
                zones = tuple(sorted({int(c) for c in value}))
                cmd.fmt_zones(zones)
                opts["zones"] = zones
            elif key == "start":
                if value not in ("command", "trigger"):
                    raise ValueError(f"expected command or trigger, got {value!r}")
                opts["start"] = value
            elif key == "tolerance_C":
                v = float(value)
                if not (math.isfinite(v) and 0 < v <= 1.0):
                    raise ValueError(f"expected 0 < tolerance ≤ 1 °C, got {value!r}")
                opts["tolerance_C"] = v
            elif key in _EMU_OPTIONS and port == "emulator":
                emu.append((key, value))
            else:
                raise ValueError(f"unknown option (expected one of "
                                 f"{', '.join(_HOST_OPTIONS + (_EMU_OPTIONS if port == 'emulator' else ()))})")
        except ValueError as exc:
            raise UserInputError(f"display: {text!r}: {key}: {exc}") from None
    if port == "emulator":
        pyurl = "tcs2emu://" + ("?" + urllib.parse.urlencode(emu) if emu else "")
        _check_emulator_url(text, pyurl)
    else:
        pyurl = port
    return pyurl, opts


def _check_emulator_url(text: str, pyurl: str) -> None:
    """Check the emulator's options now, through its pyserial handler: the emulator is not the
    display's to import; its entry point (loaded by the registry) registers ``tcs2emu://``."""
    from ..registry import backends
    backends()
    try:
        port = serial.serial_for_url(pyurl, do_not_open=True)
    except ValueError:
        raise UserInputError(f"display: {text!r}: the TCS II emulator is not installed (no "
                             f"tcs2emu:// pyserial handler)") from None
    try:
        getattr(port, "parse_url", lambda _url: None)(pyurl)
    except serial.SerialException as exc:
        raise UserInputError(f"display: {text!r}: {exc}") from None
