"""Every byte between the host and a TCS II, both ways, with time stamps (JSON lines).

``thermocue tcs2 probe PORT --capture FILE`` wraps the open port in a :class:`CapturingPort`: each
write and each non-empty read becomes one line of ``FILE``::

    {"t_s": 0.0123, "dir": "out", "hex": "3f0d", "text": "?\\r"}
    {"t_s": 0.0301, "dir": "in", "hex": "5443530d0a", "text": "TCS\\r\\n"}

``t_s`` is seconds since the port was wrapped, ``dir`` is ``out`` (host → device) or ``in``
(device → host), ``hex`` the bytes exactly, ``text`` the same bytes readable (latin-1, for a
person; ``hex`` is what counts). A lab sends this file to have its own device's replies checked
against the formats the host assumes (``docs/tcs2.md``), and ``read_capture`` reads it back for
a replaying device (``experiments.emulators.tcs2_replay``).
"""
from __future__ import annotations

import json
import time
from pathlib import Path

from experiments.errors import UserInputError

__all__ = ["CapturingPort", "read_capture"]


class CapturingPort:
    """A pyserial port whose writes and reads are also written to ``path`` (JSON lines)."""

    def __init__(self, port, path):
        self._port = port
        self._path = Path(path)
        try:
            self._fh = open(self._path, "w", encoding="utf-8")
        except OSError as exc:
            raise UserInputError(f"{self._path}: cannot write the capture: "
                                 f"{exc.strerror or exc}") from None
        self._t0 = time.monotonic()

    def _record(self, direction: str, data: bytes) -> None:
        self._fh.write(json.dumps({"t_s": round(time.monotonic() - self._t0, 6), "dir": direction,
                                   "hex": data.hex(), "text": data.decode("latin-1")}) + "\n")
        self._fh.flush()

    def write(self, data: bytes):
        n = self._port.write(data)
        self._record("out", bytes(data))
        return n

    def read(self, size: int = 1) -> bytes:
        data = self._port.read(size)
        if data:
            self._record("in", bytes(data))
        return data

    def close(self) -> None:
        try:
            self._port.close()
        finally:
            self._fh.close()

    def __getattr__(self, name):           # in_waiting, timeout, is_open, ... of the real port
        return getattr(self._port, name)


def read_capture(path) -> list:
    """The capture's records as ``(t_s, "in"|"out", bytes)``, in order.

    Raises
    ------
    UserInputError
        One line naming the file, the line and the field.
    """
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except OSError as exc:
        raise UserInputError(f"{path}: cannot read the capture: {exc.strerror or exc}") from None
    out = []
    for i, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
            t, direction, data = float(rec["t_s"]), rec["dir"], bytes.fromhex(rec["hex"])
        except (ValueError, KeyError, TypeError) as exc:
            raise UserInputError(f"{path}: line {i}: expected a capture record "
                                 f"(t_s, dir, hex), got {exc}") from None
        if direction not in ("in", "out"):
            raise UserInputError(f"{path}: line {i}: dir: expected 'in' or 'out', got {direction!r}")
        out.append((t, direction, data))
    return out
