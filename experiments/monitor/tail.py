"""Follow a file that another process appends to: its complete lines, as they arrive.

A session appends whole lines (``events.jsonl`` one event per write, a trace a few frames per
flush), but a reader may catch a line half-written: only the bytes up to the last newline are
taken, the rest waits for the next read. The file is opened once, with ``O_NONBLOCK`` (a FIFO or
a device put in a file's place never blocks the monitor) and checked to be a regular file; the
open descriptor follows the file when it is renamed (a faulted attempt's trace is moved to its
``attempt-K.fault`` name once the attempt ends).
"""
from __future__ import annotations

import os
import stat
from pathlib import Path

__all__ = ["LineTail", "NotRegular", "Restarted", "open_regular"]

#: Bytes read per call at most (a whole session's log is ~0.2 MB; a trace ~0.2 MB).
_CHUNK = 4 << 20


class NotRegular(OSError):
    """A FIFO, a device, a socket or a folder where a file was expected."""


def open_regular(path) -> int:
    """A read-only descriptor of ``path``, a regular file (NotRegular, OSError)."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
                 | getattr(os, "O_NOCTTY", 0))
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise NotRegular(f"{path}: expected a regular file, got something else "
                         f"(a FIFO, a device or a folder)")
    return fd


class Restarted(Exception):
    """The file was cut shorter (a resume repairing a torn last line) or replaced by another
    file: what was read of it no longer holds; read it again from the start."""


class LineTail:
    """The complete lines appended to ``path`` since the last :meth:`read`.

    :meth:`read` returns ``[]`` while the file does not exist (it may be created later) and
    raises ``OSError`` (:class:`NotRegular`, permission denied) for a file it cannot follow.
    With ``same_name`` it raises :class:`Restarted` when the file was cut shorter than what was
    read or another file took its name (a trace is followed across its rename instead).
    """

    def __init__(self, path, same_name: bool = False):
        self.path = Path(path)
        self.same_name = same_name
        self.fd: int | None = None
        self.pending = b""
        self.lines_read = 0
        self.offset = 0

    def read(self) -> list[bytes]:
        if self.fd is None:
            try:
                self.fd = open_regular(self.path)
            except FileNotFoundError:
                return []
        if self.same_name:
            st = os.fstat(self.fd)
            try:
                replaced = os.stat(self.path).st_ino != st.st_ino
            except FileNotFoundError:
                replaced = True
            if replaced or st.st_size < self.offset:
                self.close()
                raise Restarted(self.path)
        chunks = []
        while True:
            chunk = os.read(self.fd, _CHUNK)
            if not chunk:
                break
            chunks.append(chunk)
            if len(chunk) < _CHUNK:
                break
        if not chunks:
            return []
        self.offset += sum(len(c) for c in chunks)
        data = self.pending + b"".join(chunks)
        head, sep, self.pending = data.rpartition(b"\n")
        if not sep:
            self.pending = data
            return []
        lines = head.split(b"\n")
        self.lines_read += len(lines)
        return lines

    def close(self) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None

    def __del__(self):
        self.close()
