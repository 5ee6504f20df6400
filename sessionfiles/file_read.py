"""Reading one file of a session folder safely (standard library only).

Part of the one reader (:mod:`sessionfiles.session_reader`, which re-exports every name here):
**regular files only** (each file ``stat``-ed through a symbolic link and opened with
``O_NONBLOCK``; a FIFO, a device, a socket or a folder in a file's place refused by name, with no
read that could block or never end), **size bounds** (:data:`MAX_BYTES`, refused before the read)
and the **encoding** (UTF-8 with or without a byte-order mark; UTF-16/32 and 8-bit encodings
refused naming the file and the byte offset; a torn last line or trailing NUL bytes stay damage,
read up to). A refusal is a :class:`SessionFileError`: one line naming the file and the field.
"""
from __future__ import annotations

import os
import stat
from pathlib import Path

from sessionfiles.errors import UserInputError

__all__ = ["SessionFileError", "MAX_BYTES", "read_regular_bytes", "check_text", "read_text_file",
           "refuse_special"]


class SessionFileError(UserInputError):
    """A session file that cannot be read as one: ``"<file>: <field>: expected ..., got ..."``."""


#: Largest file accepted, bytes, by name (``trace``: a ``traces/*.csv``). A 32-trial session
#: writes ~0.2 MB of events and ~20 kB of trials.csv; a 20 s trace at 100 Hz ~0.2 MB.
MAX_BYTES = {"session.json": 16 << 20, "events.jsonl": 256 << 20, "trials.csv": 64 << 20,
             "trace": 64 << 20, "other": 64 << 20}

_UTF8_BOM = b"\xef\xbb\xbf"


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"),
                       (stat.S_ISDIR, "a folder")):
        if test(mode):
            return name
    return "a special file"


def refuse_special(path: Path, mode: int) -> None:
    link = ""
    if os.path.islink(path):
        try:
            link = f" (a symbolic link to {os.readlink(path)})"
        except OSError:
            link = " (a symbolic link)"
    raise SessionFileError(f"{path}: expected a regular file, got {_kind(mode)}{link}")


def read_regular_bytes(path, limit: int | None = None) -> bytes:
    """The content of ``path`` if it is a regular file of at most ``limit`` bytes.

    Parameters
    ----------
    path : path-like
    limit : int, optional
        Default: :data:`MAX_BYTES` for the file's name (``"other"`` if unlisted).

    Raises
    ------
    SessionFileError
        A FIFO, device, socket or folder (refused before it is opened; opened with
        ``O_NONBLOCK`` and checked again on the open descriptor), or a file over ``limit``.
    OSError
        No such file, permission denied (naming the file).
    """
    path = Path(path)
    if limit is None:
        limit = MAX_BYTES.get(path.name, MAX_BYTES["other"])
    st = os.stat(path)                      # through a link: /dev/zero linked in is a device
    if not stat.S_ISREG(st.st_mode):
        refuse_special(path, st.st_mode)
    if st.st_size > limit:
        raise SessionFileError(f"{path}: size: expected at most {limit} bytes, got {st.st_size}")
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0)
                 | getattr(os, "O_CLOEXEC", 0))
    try:
        st = os.fstat(fd)                   # the file opened is the file checked
        if not stat.S_ISREG(st.st_mode):
            refuse_special(path, st.st_mode)
        chunks, total = [], 0
        while True:
            chunk = os.read(fd, min(1 << 20, limit + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > limit:
                raise SessionFileError(f"{path}: size: expected at most {limit} bytes, got more "
                                       f"(the file grew while read)")
    finally:
        os.close(fd)
    return b"".join(chunks)


def check_text(raw: bytes, path) -> bytes:
    """``raw`` (a file's bytes) without a UTF-8 byte-order mark, if it is UTF-8 text.

    Damage a crash can leave is let through for the tolerant readers: the bytes after the last
    newline (a torn last line) and a run of NUL bytes at the end (a power cut).

    Raises
    ------
    SessionFileError
        UTF-16/32 (byte-order mark or NUL-interleaved text), a NUL byte or a byte that is not
        UTF-8 inside a complete line; the message names the file and the byte offset.
    """
    path = Path(path)
    offset = 0
    if raw.startswith(_UTF8_BOM):
        raw, offset = raw[len(_UTF8_BOM):], len(_UTF8_BOM)
    for bom, name in ((b"\xff\xfe\x00\x00", "UTF-32"), (b"\x00\x00\xfe\xff", "UTF-32"),
                      (b"\xff\xfe", "UTF-16"), (b"\xfe\xff", "UTF-16")):
        if raw.startswith(bom):
            raise SessionFileError(f"{path}: encoding: expected UTF-8 text, got {name} (byte-order "
                                   f"mark at byte 0); save it as UTF-8")
    head = raw.rstrip(b"\x00")[:256]        # (a power cut's zero fill is not text)
    if len(head) >= 4 and head.count(0) * 3 >= len(head):
        at = head.index(0)
        raise SessionFileError(f"{path}: encoding: expected UTF-8 text, got UTF-16 or UTF-32 "
                               f"without a byte-order mark (NUL byte at byte {at + offset}); "
                               f"save it as UTF-8")
    body = raw.rstrip(b"\x00")                       # a power cut's zero fill
    body = body[: body.rfind(b"\n") + 1]             # whole lines only (a torn tail is damage)
    nul = body.find(b"\x00")
    if nul >= 0:
        raise SessionFileError(f"{path}: byte {nul + offset}: expected text, got a NUL byte "
                               f"inside a line")
    try:
        body.decode("utf-8")
    except UnicodeDecodeError as exc:
        bad = body[exc.start]
        raise SessionFileError(f"{path}: byte {exc.start + offset}: expected UTF-8 text, got "
                               f"0x{bad:02x} (Latin-1 or another 8-bit encoding?); save it as "
                               f"UTF-8") from None
    return raw


def read_text_file(path, limit: int | None = None) -> str:
    """A whole UTF-8 text file (regular, bounded, BOM allowed) as a string; no damage allowed.

    For files written whole (``session.json``, a profile table): a torn tail or NUL fill is
    refused as well.
    """
    path = Path(path)
    raw = check_text(read_regular_bytes(path, limit), path)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SessionFileError(f"{path}: byte {exc.start}: expected UTF-8 text, got "
                               f"0x{raw[exc.start]:02x}") from None
    nul = text.find("\x00")
    if nul >= 0:
        raise SessionFileError(f"{path}: byte {len(text[:nul].encode())}: expected text, got a "
                               f"NUL byte")
    return text
