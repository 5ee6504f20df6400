"""Child processes that die with their host: QEMU, the heartbeat helper, pty servers.

A host killed with SIGKILL (or by a SIGHUP it does not handle) runs no ``finally``, no
``atexit`` and no finalizer, so a child it started -- ``qemu-system-arm`` using most of a core,
a pty server -- used to live on, reparented to PID 1. :func:`popen_tied` starts a child that the
kernel signals when its host dies: Linux's ``prctl(PR_SET_PDEATHSIG)``, set in the child between
``fork`` and ``exec`` (it survives ``exec`` of an ordinary program).

The kernel sends that signal when the *thread* that forked the child exits, not the process. So
every tied child is forked by one long-lived daemon thread of this module (a daemon thread lives
until the process ends): a display opened in a short-lived worker thread still keeps its QEMU.
A host that dies between ``fork`` and ``prctl`` would be missed; the child checks its parent's
PID after ``prctl`` and exits at once if it has already changed.

On a system without ``prctl`` (not Linux) the child is an ordinary one.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import os
import queue
import signal
import subprocess
import sys
import threading

__all__ = ["popen_tied", "PR_SET_PDEATHSIG"]

PR_SET_PDEATHSIG = 1

_LIBC = None
if sys.platform.startswith("linux"):
    try:
        _LIBC = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
    except OSError:                                   # pragma: no cover (every Linux has one)
        _LIBC = None

_requests: "queue.Queue" = queue.Queue()
_spawner: threading.Thread | None = None
_spawner_lock = threading.Lock()


def _tie(parent_pid: int, sig: int):
    def preexec() -> None:                            # runs in the child, before exec
        if _LIBC is not None:
            _LIBC.prctl(PR_SET_PDEATHSIG, int(sig), 0, 0, 0)
        if os.getppid() != parent_pid:                # the host died before prctl took hold
            os._exit(1)
    return preexec


def _serve() -> None:
    while True:
        args, kwargs, box, done = _requests.get()
        try:
            box.append(subprocess.Popen(args, **kwargs))
        except BaseException as exc:                  # handed back to the caller
            box.append(exc)
        done.set()


def _spawner_thread() -> None:
    global _spawner
    with _spawner_lock:
        if _spawner is None or not _spawner.is_alive():
            _spawner = threading.Thread(target=_serve, name="tied-child-spawner", daemon=True)
            _spawner.start()


def popen_tied(args, *, death_signal: int = signal.SIGKILL, **kwargs) -> subprocess.Popen:
    """``subprocess.Popen(args, **kwargs)`` whose child gets ``death_signal`` when this
    process dies (any way, SIGKILL included).

    Parameters
    ----------
    args, **kwargs
        As :class:`subprocess.Popen` (``preexec_fn`` is this function's own).
    death_signal : int
        SIGKILL by default; SIGTERM for a child that must clean up (it can still be ignored).

    Raises
    ------
    OSError, ValueError
        As :class:`subprocess.Popen`.
    """
    if "preexec_fn" in kwargs:
        raise ValueError("popen_tied sets preexec_fn itself")
    kwargs["preexec_fn"] = _tie(os.getpid(), death_signal)
    _spawner_thread()
    box: list = []
    done = threading.Event()
    _requests.put((args, kwargs, box, done))
    done.wait()
    if isinstance(box[0], BaseException):
        raise box[0]
    return box[0]
