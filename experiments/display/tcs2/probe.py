"""The TCS II bring-up (``docs/tcs2.md``, "Set-up on a real device") as steps that each report.

:func:`probe` opens the port (optionally through a :class:`~.capture.CapturingPort`), shakes
hands as a session would (``?``, ``A``, ``F``, ``H``; ``Om`` with the protocol's maximum, read
back by ``P``; ``N``, ``S``, ``Osd``, ``Ob``; ``P`` and ``Q`` showing it all held), then reads the
temperatures (``Oe``) and the errors (``Q``) once more, and closes (back to neutral). No
stimulation: the bring-up is run with the probe in its holder, not on skin.
"""
from __future__ import annotations

from experiments.errors import DisplayError

from ..base import handshake_or_close, open_serial_port
from . import commands as cmd
from .backend import Tcs2Display
from .capture import CapturingPort
from .url import parse_tcs2_url

__all__ = ["probe", "tcs2_url"]


def tcs2_url(port: str) -> str:
    """``tcs2://PORT`` for a bare port; a ``tcs2://`` URL as it is."""
    return port if str(port).lower().startswith("tcs2://") else f"tcs2://{port}"


def probe(port: str, limits, capture=None, say=print) -> bool:
    """Run the bring-up on ``port``; ``say`` gets one line per step. True when every step passed.

    Raises
    ------
    UserInputError
        A malformed URL, or a capture file that cannot be written.
    """
    url = tcs2_url(port)
    pyurl, opts = parse_tcs2_url(url)
    name = url.split("?", 1)[0]
    step = "open"
    disp = None
    try:
        raw = open_serial_port(pyurl)
        try:
            link = CapturingPort(raw, capture) if capture is not None else raw
        except BaseException:
            raw.close()
            raise
        say(f"open          {name}: opened{f', capturing to {capture}' if capture else ''}")
        step = "handshake"
        disp = handshake_or_close(Tcs2Display(link, limits, name=name, **opts), link)
        info = disp.info
        say(f"identify      probe id {info.device_id!r}, firmware {info.firmware!r} (H)")
        say(f"maximum       {disp.max_C:.1f} °C set (Om) and read back (P)")
        say(f"neutral       {disp.neutral_C:.1f} °C set (N) and read back (P); zones "
            f"{''.join(str(z) for z in disp.zones)} enabled (S), errors none (Q)")
        step = "temperatures"
        (line,) = disp.link.ask("Oe")
        temps = cmd.parse_temperatures(line)
        zones = ", ".join(f"{t:.2f}" for t in temps[1:])
        say(f"temperatures  neutral {temps[0]:.2f} °C, zones 1–5 {zones} °C (Oe)")
        step = "errors"
        (line,) = disp.link.ask("Q", skip=cmd.is_temperature_line)
        errs = cmd.parse_errors(line)
        if any(errs):
            raise DisplayError(f"Q: error digits {line.strip()} (neutral, zones 1–5)")
        say("errors        none (Q)")
        say("stimulus      none: the bring-up runs with the probe in its holder, not on skin")
        return True
    except DisplayError as exc:             # a ReplyError too
        say(f"FAILED {step}: {exc}")
        return False
    finally:
        if disp is not None:
            disp.close()
