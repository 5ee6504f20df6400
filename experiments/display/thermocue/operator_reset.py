"""The operator's reset of a display latched in FAULT (``thermocue clear-fault URL``).

:func:`reset` is :meth:`~.driver.ThermalDisplay.operator_reset`: STATUS, then HELLO and
CLEAR_FAULT, for a person who has checked the pad and its sensors; never called by a session.
"""
from __future__ import annotations

from ..base import open_serial_port

__all__ = ["RESET_WATCH_S", "reset"]

#: After an operator's reset, how long the device is watched for a fault that trips again, s
#: (a stuck sensor takes 20 identical readings, 0.2 s; an out-of-range one trips at once).
RESET_WATCH_S = 1.0


def reset(display_cls, url: str, baudrate: int = 115200) -> tuple[str, str | None, str]:
    """The operator's reset of a display latched in FAULT: STATUS, then HELLO and CLEAR_FAULT.

    The device is watched for :data:`RESET_WATCH_S` after the reset, so that a cause still there
    (a sensor out of range or stuck) is reported as FAULT, not as a successful reset; sets no
    limits and arms nothing. A device that is not in FAULT is left as it is: it is asked STATUS
    alone (allowed before a HELLO), since a HELLO starts a new host's session on the device (a
    host using it would lose its half-done upload and its retry replies).

    Parameters
    ----------
    display_cls : type
        :class:`~.driver.ThermalDisplay` or a subclass, opened on the port without a handshake.

    Returns
    -------
    (state_before, fault, state_after) : tuple of str, str or None, str
    """
    port = open_serial_port(url, baudrate)
    try:
        disp = display_cls(port, None)
        disp._refuse_text_device()
        before = disp.wire_status()
        if before.state != "FAULT":
            return before.state, before.last_fault, before.state
        disp._hello()
        disp.clear_fault()
        # a cause still there (a sensor out of range or stuck) trips it again at once:
        # watch it for RESET_WATCH_S before calling the reset done
        clock = disp.link.clock
        end = clock() + RESET_WATCH_S
        after = disp.wire_status()
        while after.state != "FAULT" and clock() < end:
            disp.wait(0.05)
            after = disp.wire_status()
        return before.state, before.last_fault, after.state
    finally:
        try:
            port.close()
        except Exception:
            pass
