"""File-system checks shared by the subcommands: one line naming the path, before any work.

Each check raises :class:`PathError` (a :class:`~experiments.errors.UserInputError`: exit 2,
one line) naming the option and the path, so that a bad ``--data`` or ``--out`` is refused
before a display or a window is opened and before anything is written.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

from experiments.errors import UserInputError

__all__ = ["PathError", "check_writable_dir", "os_error_line"]


class PathError(UserInputError):
    """A path given on the command line cannot be used (named in the message)."""


def _first_existing(path: Path) -> Path:
    p = path
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def check_writable_dir(path, option: str) -> Path:
    """Refuse ``path`` unless it is, or can become, a folder this process can write in.

    Nothing is created: the deepest existing ancestor must be a folder in which a temporary
    file can really be made (this also holds for root, for whom permission bits say little,
    and for read-only file systems).

    Raises
    ------
    PathError
        ``"<option> <path>: expected a folder, got a file"`` and the like.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise PathError(f"{option} {path}: expected a folder (or a new name), got an existing file")
    base = _first_existing(path)
    if not base.is_dir():
        raise PathError(f"{option} {path}: expected a folder, got a path through the file {base}")
    try:
        fd, probe = tempfile.mkstemp(prefix=".thermocue-probe-", dir=base)
    except OSError as exc:
        raise PathError(f"{option} {path}: expected a folder it can write in, got "
                        f"{exc.strerror or exc} ({base})") from None
    os.close(fd)
    os.unlink(probe)
    return path


def os_error_line(exc: OSError) -> str:
    """``"<path>: <reason>"`` for a file-system error (its path first, as the README says)."""
    where = exc.filename if exc.filename is not None else ""
    if exc.filename2 is not None:
        where = f"{where} -> {exc.filename2}"
    reason = exc.strerror or str(exc)
    return f"{where}: {reason}" if where else reason
