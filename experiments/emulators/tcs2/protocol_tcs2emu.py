"""The TCS II emulator as a pyserial URL handler, in the manner of pyserial's ``loop://``.

URL grammar::

    tcs2emu://[?clock=real|virtual][&faults=FAULTS][&seed=N][&speed=K]

    clock    real: the device ticks every 10 ms of wall time in its own thread (default);
             virtual: it advances only while the host waits for bytes -- a read that finds
             nothing ticks it until there is something or the read's timeout, counted in
             device time, is used up
    faults   see experiments.emulators.tcs2.device (e.g. "zone@2:5.0,drop=0.001")
    seed     sensor noise and dropped lines (default 0)
    speed    real clock only: device seconds per wall second (default 1)

pyserial finds this module because :mod:`experiments.display.tcs2` adds itself to
``serial.protocol_handler_packages`` on import.
"""
from __future__ import annotations

import threading
import time
import urllib.parse

from serial.serialutil import SerialException

from ..port.emulated_port import EmulatedPort
from .device import TICK_S, Tcs2Device

__all__ = ["Serial", "URL_GRAMMAR", "parse_url"]

URL_GRAMMAR = "tcs2emu://[?clock=real|virtual][&faults=FAULTS][&seed=N][&speed=K]"


def parse_url(url: str) -> dict:
    """Options of a ``tcs2emu://`` URL.

    Raises
    ------
    SerialException
        Wrong scheme, unknown option or bad value; the message quotes the grammar.
    """
    parts = urllib.parse.urlsplit(url)
    if parts.scheme != "tcs2emu":
        raise SerialException(f"expected a URL of the form {URL_GRAMMAR!r}, got {url!r}")
    opts = dict(clock="real", faults="", seed=0, speed=1.0)
    try:
        for key, values in urllib.parse.parse_qs(parts.query, keep_blank_values=True).items():
            value = values[-1]
            if key == "clock":
                if value not in ("real", "virtual"):
                    raise ValueError(f"clock: expected real or virtual, got {value!r}")
                opts["clock"] = value
            elif key == "faults":
                opts["faults"] = value
            elif key == "seed":
                opts["seed"] = int(value)
            elif key == "speed":
                opts["speed"] = float(value)
                if not 0 < opts["speed"] <= 100:
                    raise ValueError(f"speed: expected 0 < K ≤ 100, got {value!r}")
            else:
                raise ValueError(f"unknown option {key!r}")
        Tcs2Device(opts["faults"])          # the fault spec checked now
    except ValueError as exc:
        raise SerialException(f"expected a URL of the form {URL_GRAMMAR!r}: {exc}") from None
    return opts


class Serial(EmulatedPort):
    """An emulated TCS II behind the pyserial API (see the module docstring)."""

    parse_url = staticmethod(parse_url)

    def __init__(self, *args, **kwargs):
        self.device: Tcs2Device | None = None
        self.virtual = False
        self._lock = threading.Condition()
        self._buf = bytearray()
        self._thread = None
        self._stop = False
        super().__init__(*args, **kwargs)

    def open(self):
        self._check_can_open()
        opts = parse_url(self.port)
        self.device = Tcs2Device(opts["faults"], seed=opts["seed"])
        self.virtual = opts["clock"] == "virtual"
        self._speed = opts["speed"]
        self._buf.clear()
        self._stop = False
        self.is_open = True
        if not self.virtual:
            self._start_clock(self._run, "tcs2emu-clock")

    def close(self):
        if self.is_open:
            self.is_open = False
            self._stop_clock(self._lock)
        super().close()

    def _check(self):
        self._check_open()
        if self.device.disconnected:
            raise SerialException("tcs2emu: the device is disconnected (injected fault)")

    def device_clock(self):
        """Device seconds in virtual-clock mode (a callable), else None."""
        if not self.virtual:
            return None
        return lambda: self.device.time_s

    # ------------------------------------------------------------------ clock
    def _run(self):
        next_t = time.monotonic()
        while True:
            with self._lock:
                if self._stop:
                    return
                self.device.tick()
                out = self.device.take()
                if out:
                    self._buf += out
                    self._lock.notify_all()
            next_t += TICK_S / self._speed
            delay = next_t - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            elif delay < -0.5:
                next_t = time.monotonic()      # starved: do not race to catch up

    # ------------------------------------------------------------------ I/O
    @property
    def in_waiting(self):
        self._check()
        with self._lock:
            return len(self._buf)

    def read(self, size=1):
        self._check()
        timeout = 1.0 if self._timeout is None else self._timeout
        with self._lock:
            if self.virtual:
                budget = max(1, int(round(timeout / TICK_S)))
                while not self._buf and budget > 0 and not self.device.disconnected:
                    self.device.tick()
                    self._buf += self.device.take()
                    budget -= 1
            elif not self._buf and timeout > 0:
                self._lock.wait_for(lambda: self._buf or self._stop or self.device.disconnected,
                                    timeout)
            if self.device.disconnected:
                raise SerialException("tcs2emu: the device is disconnected (injected fault)")
            data = bytes(self._buf[:size])
            del self._buf[:size]
        return data

    def write(self, data):
        self._check()
        with self._lock:
            self.device.feed(bytes(data))
            self._buf += self.device.take()
            self._lock.notify_all()
        return len(data)

    def reset_input_buffer(self):
        self._check()
        with self._lock:
            self._buf.clear()
