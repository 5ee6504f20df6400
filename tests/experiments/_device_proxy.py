"""A hostile device for attacks: the real emulator behind a real pty that rewrites its frames.

:class:`FrameProxy` opens a new pty (the "device" the host opens) and forwards every byte the
host writes to the emulator's pty unchanged; each frame the emulator sends back passes through
``rewrite(frame) -> list of (seq, type, payload)`` and is re-encoded (header CRC and all), so the
host reads well-formed frames a real device could send: none at all, a short reply, an unknown
enum value. Used by the attack tests of the display's safety (delivery evidence, reply checks).
"""
from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import threading
import tty

import pytest

from experiments.display.thermocue.framing import FrameParser, encode_frame


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


def start_emulator(tmp_path, *args):
    """``thermocue emulator`` in its own process on a pty; return (process, pty path)."""
    proc = subprocess.Popen([sys.executable, "-m", "experiments.emulators.pty_server",
                             "--log", str(tmp_path / "emulator.jsonl"), *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    r, _, _ = select.select([proc.stdout], [], [], 30)
    if not r:
        proc.kill()
        pytest.fail("the emulator printed no pty path within 30 s")
    return proc, proc.stdout.readline().strip()


def stop(proc):
    proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
