"""A TCS II that replays a capture (``thermocue tcs2 probe PORT --capture FILE``) on a real pty.

A lab's capture holds its device's replies; :class:`ReplayDevice` plays the device's side of it
to a host that sends the same commands: for each ``out`` record it waits for that many bytes from
the host and compares them with the record (a different command ends the replay: the device's
reply to it is unknown), for each ``in`` record it writes the bytes (after the recorded gap,
capped at ``max_gap_s``). So the host's parsers run on the real device's bytes, here.
"""
from __future__ import annotations

import threading
import time

from .pty_server import PtyEndpoint

__all__ = ["ReplayDevice"]


class ReplayDevice:
    """Serve ``records`` (``(t_s, "in"|"out", bytes)``, as ``read_capture`` gives) on a pty.

    Attributes
    ----------
    path : str
        The pty's path (or ``link``), for the host.
    mismatch : str or None
        What the host sent instead of the recorded command, if it did.
    done : threading.Event
        Set when every record was played (or a mismatch ended the replay).
    """

    def __init__(self, records, link: str | None = None, max_gap_s: float = 0.2,
                 wait_s: float = 10.0):
        self.records = list(records)
        self.end = PtyEndpoint(link)
        self.path = link or self.end.path
        self.max_gap_s, self.wait_s = max_gap_s, wait_s
        self.mismatch: str | None = None
        self.played = 0
        self.done = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True, name="tcs2-replay")

    def __enter__(self) -> "ReplayDevice":
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self.end.close()

    def _expect(self, want: bytes, got: bytearray) -> bool:
        deadline = time.monotonic() + self.wait_s
        while len(got) < len(want):
            if self._stop.is_set() or time.monotonic() > deadline:
                self.mismatch = f"waited for {want!r}, the host sent {bytes(got)!r}"
                return False
            if self.end.wait(0.05):
                got += self.end.read()
        if bytes(got[:len(want)]) != want:
            self.mismatch = f"expected {want!r}, the host sent {bytes(got[:len(want)])!r}"
            return False
        del got[:len(want)]
        return True

    def _run(self) -> None:
        got = bytearray()
        last_t = None
        try:
            for t, direction, data in self.records:
                if direction == "out":
                    if not self._expect(data, got):
                        return
                else:
                    if last_t is not None and t > last_t:
                        time.sleep(min(t - last_t, self.max_gap_s))
                    self.end.send(data)
                    while self.end.pending and not self._stop.is_set():
                        self.end.wait(0.01)
                        self.end.send(b"")
                last_t = t
                self.played += 1
        finally:
            self.done.set()
