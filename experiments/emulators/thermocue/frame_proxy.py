"""A device that lies on purpose: the real emulator behind a pty that rewrites its frames.

:class:`FrameProxy` opens a new pty (the "device" the host opens) and forwards every byte the
host writes to the emulator's pty unchanged; each frame the emulator sends back passes through
``rewrite(frame) -> list of (seq, type, payload)`` and is re-encoded (header CRC and all), so the
host reads well-formed frames a real device could send: none at all, a short reply, an unknown
enum value, telemetry of an impossible temperature. The display's attack tests and the
fault-injection benchmark (``benchmarks/fault_injection.py``) put it between the host and
``thermocue emulator``. Standard library and the thermocue protocol's framing only.
"""
from __future__ import annotations

import os
import select
import threading
import tty

from experiments.display.thermocue.framing import FrameParser, encode_frame

__all__ = ["FrameProxy"]


class FrameProxy:
    """Serve ``device_path`` (a pty of the emulator) on a new pty, rewriting the device's frames."""

    def __init__(self, device_path: str, rewrite):
        self.rewrite = rewrite
        self.dev = os.open(device_path, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self.dev)
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.path = os.ttyname(self._slave)
        self.host_bytes = bytearray()             # everything the host wrote
        self._parser = FrameParser()
        self._stop = threading.Event()
        self._th = threading.Thread(target=self._run, daemon=True)
        self._th.start()

    def _run(self):
        while not self._stop.is_set():
            r, _, _ = select.select([self.master, self.dev], [], [], 0.02)
            try:
                if self.master in r:
                    data = os.read(self.master, 65536)
                    self.host_bytes += data
                    os.write(self.dev, data)
                if self.dev in r:
                    for fr in self._parser.feed(os.read(self.dev, 65536)):
                        for seq, typ, payload in self.rewrite(fr):
                            os.write(self.master, encode_frame(seq, typ, payload))
            except OSError:
                if self._stop.is_set():
                    return
                continue

    def close(self):
        self._stop.set()
        self._th.join(2)
        for fd in (self.master, self._slave, self.dev):
            try:
                os.close(fd)
            except OSError:
                pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
