"""Which serial ports are here: the ``available`` column of ``thermocue displays`` for backends on
a serial port (``serial``: the thermocue display's USB-serial cable; ``tcs2``: the TCS II's USB
virtual serial port).

A port counts when pyserial's ``serial.tools.list_ports`` lists it as a USB device (it has a USB
vendor id): the thermocue display is reached through a 3.3 V USB-serial cable (FTDI, CP2102) or
the board's USB, the TCS II is a USB virtual serial port. The legacy on-board ports pyserial also
lists (``/dev/ttyS0`` with no hardware id) are left out: nothing of either kind is wired to them.
A pseudo-terminal or a pyserial URL (``socket://``, ``loop://``) can still be opened, it is just
not something plugged in.
"""
from __future__ import annotations

__all__ = ["usb_serial_ports", "port_availability"]


def usb_serial_ports() -> list:
    """``[(device, description)]`` of the USB serial ports pyserial lists, sorted."""
    try:
        from serial.tools import list_ports
        ports = list_ports.comports()
    except Exception:                # pyserial's scan failing is "none found", not a crash
        return []
    return sorted((p.device, p.description or "") for p in ports if getattr(p, "vid", None) is not None)


def port_availability(what: str) -> tuple:
    """``(True, "")`` when a USB serial port is here, else ``(False, reason)`` naming ``what``."""
    ports = usb_serial_ports()
    if ports:
        return True, ""
    return False, (f"no USB serial port found (pyserial list_ports): connect {what}; a pty or a "
                   f"pyserial URL can still be given")
