"""A port wrapper for the display tests: the same emulator port with some attributes hidden."""
from __future__ import annotations


class HidingPort:
    """``port`` as the driver sees it, minus the attributes named in ``hide``.

    It shows the driver only what a port documents (``device_clock()``, ``read_frames()``, the
    pyserial calls), to check the driver uses no more than that.
    """

    def __init__(self, port, hide):
        self._port = port
        self._hide = frozenset(hide)

    def __getattr__(self, name):
        if name in self._hide:
            raise AttributeError(name)
        return getattr(self._port, name)
