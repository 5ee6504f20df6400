"""Lines over a serial port, for the TCS II's ASCII protocol: send a command, read replies.

:class:`LineLink` keeps what has arrived, hands out complete lines (``\\r``, ``\\n`` or both end
one), says when a line was left half-written, and runs on the port's clock: device seconds
when the port offers ``device_clock()`` (the emulator on a virtual clock), else wall time.
Every I/O failure becomes a :class:`~experiments.errors.DisplayError`; a line that is not
ASCII text becomes a :class:`~.commands.ReplyError` quoting it.
"""
from __future__ import annotations

import time

import serial

from experiments.errors import DisplayError, DisplayTimeout

from .commands import ReplyError

__all__ = ["LineLink"]


class LineLink:
    """A line-oriented view of a pyserial port (see the module docstring).

    Parameters
    ----------
    port : serial.SerialBase
        Opened with a short read timeout (10 ms).
    name : str
        The port's name, for messages.
    """

    def __init__(self, port, name: str):
        self.port = port
        self.name = name
        clock = getattr(port, "device_clock", None)
        clock = clock() if callable(clock) else None
        self.virtual = clock is not None
        self.clock = clock if self.virtual else time.monotonic
        self._buf = bytearray()
        self.lost = False

    # ------------------------------------------------------------------ out
    def send(self, command: str) -> None:
        """Write one command line (``command`` + ``\\r``)."""
        try:
            self.port.write(command.encode("ascii") + b"\r")
        except (serial.SerialException, OSError) as exc:
            self.lost = True
            raise DisplayError(f"display {self.name}: link lost while sending {command[:12]!r}: "
                               f"{exc}") from None

    # ------------------------------------------------------------------ in
    def _fill(self) -> bool:
        try:
            n = self.port.in_waiting
            data = self.port.read(n if n > 0 else 1)
        except (serial.SerialException, OSError) as exc:
            self.lost = True
            raise DisplayError(f"display {self.name}: link lost while reading: {exc}") from None
        if data:
            self._buf += data
        return bool(data)

    def _pop_line(self):
        for i, b in enumerate(self._buf):
            if b in (10, 13):
                raw = bytes(self._buf[:i])
                del self._buf[:i + 1]
                if not raw:
                    return ""            # the other half of a CR LF: an empty line
                try:
                    text = raw.decode("ascii")
                except UnicodeDecodeError:
                    raise ReplyError(f"display {self.name}: expected a line of ASCII text, got "
                                     f"{raw[:40]!r}") from None
                if not text.isprintable():
                    raise ReplyError(f"display {self.name}: expected a line of printable text, "
                                     f"got {raw[:40]!r}")
                return text
        return None

    @property
    def partial(self) -> bytes:
        """Bytes of a line not yet ended."""
        return bytes(self._buf)

    def line(self, timeout_s: float):
        """The next non-empty line, or None if none is complete within ``timeout_s``."""
        end = self.clock() + timeout_s
        while True:
            line = self._pop_line()
            while line == "":
                line = self._pop_line()
            if line is not None:
                return line
            if self.clock() >= end:
                return None
            self._fill()

    def poll_lines(self) -> list:
        """The complete lines that have arrived, without waiting (one read)."""
        if self.virtual or self.port.in_waiting:
            self._fill()
        out = []
        while True:
            line = self._pop_line()
            if line is None:
                return out
            if line:
                out.append(line)

    def drain(self, quiet_s: float = 0.05) -> None:
        """Forget everything until the port has been quiet for ``quiet_s``."""
        end = self.clock() + 2.0
        last = self.clock()
        while self.clock() < end:
            if self._fill():
                last = self.clock()
            elif self.clock() - last >= quiet_s:
                break
        self._buf.clear()

    def ask(self, command: str, n: int = 1, timeout_s: float = 0.5, skip=None) -> list:
        """Send ``command`` and return its ``n`` reply lines.

        Lines for which ``skip(line)`` is true (the temperature display between
        stimulations) are passed over.

        Raises
        ------
        DisplayTimeout
            Fewer than ``n`` lines within ``timeout_s``.
        """
        self.send(command)
        got = []
        end = self.clock() + timeout_s
        while len(got) < n:
            line = self.line(max(0.0, end - self.clock()))
            if line is None:
                raise DisplayTimeout(f"display {self.name}: no reply to {command[:12]!r} within "
                                     f"{timeout_s:g} s (got {len(got)} of {n} lines"
                                     + (f", then a half line {self.partial[:20]!r}" if self.partial else "")
                                     + ")")
            if skip is not None and skip(line):
                continue
            got.append(line)
        return got

    def ask_until_quiet(self, command: str, quiet_s: float = 0.15, timeout_s: float = 1.0,
                        skip=None) -> list:
        """Send ``command`` and return the lines that follow until ``quiet_s`` without one."""
        self.send(command)
        got = []
        end = self.clock() + timeout_s
        while self.clock() < end:
            line = self.line(quiet_s)
            if line is None:
                break
            if skip is None or not skip(line):
                got.append(line)
        return got

    def expect(self, command: str, want: str, timeout_s: float) -> bool:
        """Send ``command``; whether a line equal to ``want`` comes back within ``timeout_s``
        (other lines, junk included, are passed over). Never raises for what it reads."""
        self._buf.clear()
        self.send(command)
        end = self.clock() + timeout_s
        while self.clock() < end:
            try:
                line = self.line(max(0.0, end - self.clock()))
            except ReplyError:
                continue
            if line is None:
                return False
            if line.strip() == want:
                return True
        return False
