"""A heartbeat that no Python thread of the host can delay: a tiny helper process.

A thread of the host process needs the GIL to send anything; a main thread inside a long C call
(a PsychoPy window, a big sort, a numpy routine that keeps the GIL) or a machine loaded to a load
average of 4-6 on 2 cores can then hold every heartbeat back for 100 ms and more, and the device's
90 ms watchdog ends the trial. So on a port with a file descriptor (a serial device, a pty) the
driver starts this helper: a second interpreter (``python -I -S``, no imports beyond the
standard library's built-ins) that shares the port's descriptor and writes one silent heartbeat
frame every ``period_s``. Each ``write`` of a tty is atomic with respect to other writers, so its
10-byte frames never split the host's own frames (silent heartbeats are never cached by the device,
so their sequence number does not matter).

Priority: the helper asks for the lowest real-time priority (``SCHED_RR`` 1), else nice −10,
else stays an ordinary process (a user without the right: ``ulimit -r`` or ``CAP_SYS_NICE``). It
blocks in ``select`` between writes, so it never takes a core from anyone for long; with it, a
machine loaded with CPU-bound processes delays its heartbeat by the kernel's wake-up latency,
not by a share of the CPU.

Start: the helper writes one byte to its stdout once it runs; :meth:`HeartbeatProcess.wait_ready`
waits for it (a Python started on a loaded machine may take longer than the watchdog's 90 ms to
write its first frame), and until then the driver's own thread heartbeats.

Liveness: the host process pings the helper (a byte on its stdin pipe) while its I/O thread makes
progress; the helper sends nothing while the last ping is older than ``stall_s`` (a hung host
program lets the device's watchdog act), and exits when the pipe closes (the host closed the
display, or died).
"""
from __future__ import annotations

import os
import select
import subprocess
import sys
import time

from ..children import popen_tied

__all__ = ["HeartbeatProcess"]

_HELPER = r"""
import os, select, sys, time
fd, period, stall, frame = int(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3]), bytes.fromhex(sys.argv[4])
try:                                                # ahead of CPU-bound work when allowed: the
    os.sched_setscheduler(0, os.SCHED_RR, os.sched_param(1))   # lowest real-time priority
except (AttributeError, OSError):                   # (it sleeps between 10-byte writes)
    try:
        os.setpriority(os.PRIO_PROCESS, 0, -10)
    except (AttributeError, OSError):
        pass                                        # an ordinary process, as before
os.write(1, b"r")                                   # ready: the host's thread may stand down
last_ping = nxt = time.monotonic()
while True:
    r, _, _ = select.select([0], [], [], max(0.0, nxt - time.monotonic()))
    if r:
        if not os.read(0, 4096):
            break                                   # the host closed the pipe or died
        last_ping = time.monotonic()
    now = time.monotonic()
    if now >= nxt:
        if now - last_ping <= stall:
            try:
                os.write(fd, frame)
            except BlockingIOError:
                pass                                # the device does not read: nothing to feed
            except OSError:
                break                               # the port is gone
        nxt = max(nxt + period, now + period / 2)
"""


class HeartbeatProcess:
    """The helper process (see module docstring).

    Parameters
    ----------
    fd : int
        The port's file descriptor (shared with the helper).
    frame : bytes
        The silent heartbeat frame to write.
    period_s : float, s
    stall_s : float, s
        No heartbeat while the host has not pinged for this long.
    """

    def __init__(self, fd: int, frame: bytes, period_s: float = 0.01, stall_s: float = 2.0):
        self.stall_s = float(stall_s)
        self._last_ping = time.monotonic()
        self.proc = popen_tied(                     # dies with the host, however it dies
            [sys.executable, "-I", "-S", "-c", _HELPER, str(fd), repr(float(period_s)),
             repr(self.stall_s), frame.hex()],
            pass_fds=(fd,), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL, close_fds=True)
        os.set_blocking(self.proc.stdin.fileno(), False)
        self.ready = False

    def wait_ready(self, timeout_s: float) -> bool:
        """Wait up to ``timeout_s`` for the helper to run (its first byte); whether it does.

        Sets :attr:`ready`, which the driver's thread reads to stand down.
        """
        if not self.ready and self.running:
            r, _, _ = select.select([self.proc.stdout], [], [], max(0.0, timeout_s))
            self.ready = bool(r) and os.read(self.proc.stdout.fileno(), 1) == b"r"
        return self.ready

    def ping(self) -> None:
        """Tell the helper the host is alive (cheap: at most one byte every ``stall_s / 8``)."""
        now = time.monotonic()
        if now - self._last_ping >= self.stall_s / 8:
            self._last_ping = now
            try:
                os.write(self.proc.stdin.fileno(), b".")
            except (BlockingIOError, BrokenPipeError, OSError, ValueError):
                pass

    @property
    def running(self) -> bool:
        return self.proc.poll() is None

    def stop(self, wait_s: float = 2.0) -> None:
        """Close the pipe (the helper exits) and reap it (killed after ``wait_s``)."""
        for pipe in (self.proc.stdin, self.proc.stdout):
            try:
                pipe.close()
            except OSError:
                pass
        try:
            self.proc.wait(timeout=wait_s)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
