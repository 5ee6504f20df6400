"""What every emulated port shares with pyserial's own ``loop://``: a :class:`SerialBase` with
no wires to configure.

An emulator's URL handler (``emulator://``, ``tcs2emu://``) subclasses :class:`EmulatedPort`, sets
``parse_url`` to its URL grammar's parser and writes only what differs: opening its device, its
clock, ``read`` and ``write``. Baud rate, break, RTS and DTR have nothing to act on, and the
modem lines read as a connected cable (CTS, DSR and CD high, no ring).
"""
from __future__ import annotations

import threading

from serial.serialutil import PortNotOpenError, SerialBase, SerialException

__all__ = ["EmulatedPort"]


class EmulatedPort(SerialBase):
    """A pyserial port whose other end is an emulator in this process."""

    #: ``parse_url(url) -> dict``: checks the handler's URL, raises ``SerialException``
    parse_url = None

    def from_url(self, url):
        """Check the URL against the handler's grammar; return its options."""
        return type(self).parse_url(url)

    def _check_open(self):
        if not self.is_open:
            raise PortNotOpenError()

    def _check_can_open(self):
        """pyserial's two refusals before ``open``: already open, or no URL configured."""
        if self.is_open:
            raise SerialException("Port is already open.")
        if self._port is None:
            raise SerialException("Port must be configured before it can be used.")

    # ------------------------------------------------------------------ a real-time clock
    def _start_clock(self, target, name: str) -> None:
        """Run ``target`` (the device's real-time loop, which returns once ``_stop`` is set) in a
        daemon thread."""
        self._stop = False
        self._thread = threading.Thread(target=target, name=name, daemon=True)
        self._thread.start()

    def _stop_clock(self, cond) -> None:
        """Set ``_stop`` under ``cond`` (waking a reader), and join the clock thread (1 s)."""
        with cond:
            self._stop = True
            cond.notify_all()
        thread = getattr(self, "_thread", None)
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=1.0)
        self._thread = None

    # nothing to configure on an emulated wire
    def _reconfigure_port(self):
        pass

    def _update_break_state(self):
        pass

    def _update_rts_state(self):
        pass

    def _update_dtr_state(self):
        pass

    def reset_output_buffer(self):
        self._check_open()

    @property
    def out_waiting(self):
        self._check_open()
        return 0

    @property
    def cts(self):
        self._check_open()
        return True

    @property
    def dsr(self):
        self._check_open()
        return True

    @property
    def ri(self):
        self._check_open()
        return False

    @property
    def cd(self):
        self._check_open()
        return True
