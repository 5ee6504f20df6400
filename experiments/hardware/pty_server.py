"""Serve the emulated display on a real pseudo-terminal (``os.openpty``), in this process.

``serve()`` opens a pty pair, puts the slave side in raw mode, prints the slave's path (and makes
``link`` a symbolic link to it), then runs the device until SIGINT or SIGTERM. Any program can
open the path with pyserial (``serial.serial_for_url(path)``) as if it were a USB serial adapter.
The server keeps its own descriptor of the slave open, so a host may close the port and another
connect later: the device (and its watchdog) keeps running in between.

A pty loses no bytes, and neither does this server: output that does not fit in the pty's buffer
is kept and written as soon as the host reads (up to :data:`MAX_PENDING` bytes, beyond which the
oldest bytes are dropped and counted -- a host that stopped reading for minutes). When the server
itself is starved of CPU it catches up on up to 20 ticks at once; host bytes read at that moment
feed the watchdog as of the caught-up device time (they arrived by then), so the emulator's own
lateness never trips the watchdog. The stop record of the log gives ``max_late_ms``, the worst
lateness of a tick, ``max_pending_bytes`` and ``dropped_output_bytes``.

Run it with ``thermocue emulator`` or ``python -m experiments.hardware.pty_server``.
"""
from __future__ import annotations

import collections
import fcntl
import os
import select
import signal
import struct
import sys
import termios
import time
import tty

from .device import TICK_US, Device
from .faults import LinkFaults, parse_faults
from .protocol_emulator import JsonLog

__all__ = ["serve", "main", "MAX_PENDING"]

#: Output bytes held for a host that does not read (≈ 4 min of telemetry at 100 Hz).
MAX_PENDING = 1 << 20


def _queued(fd: int) -> int:
    """Bytes waiting in the input queue of tty ``fd``."""
    return struct.unpack("i", fcntl.ioctl(fd, termios.FIONREAD, b"\0\0\0\0"))[0]


def serve(*, faults=None, clock: str = "real", seed: int = 0, link: str | None = None,
          log: str | None = None, sim: bool = True, announce=None, stop=None) -> int:
    """Run the emulator on a new pty until a signal (or ``stop()`` returns True).

    Parameters
    ----------
    faults : str or list, optional
        Fault SPEC (see :mod:`experiments.hardware.faults`).
    clock : {"real", "virtual"}
        ``virtual``: while a trial runs, the next 10 ms tick is computed as soon as the host has
        read everything sent so far, so device time runs as fast as the host consumes it -- and
        never slower than wall time (a host that stops reading, or dies, meets the real-time
        watchdog). Idle, the device ticks in real time.
    seed : int
    link : str, optional
        Path of a symbolic link to create to the pty (replaced if it is a link already).
    log : str, optional
        JSON-lines log of state changes, faults and watchdog trips.
    sim : bool
        Offer the emulator-only "sim" commands.
    announce : callable, optional
        Called with the pty path once it is ready (default: print it and flush).

    Returns
    -------
    int
        0.
    """
    specs = parse_faults(faults) if isinstance(faults, (str, type(None))) else list(faults)
    jlog = JsonLog(log)
    dev = Device(seed=seed, faults=specs, sim=sim, log=jlog)
    lf = LinkFaults(specs, seed=seed)
    dev.fault_listeners.append(lf.add)
    master, slave = os.openpty()
    tty.setraw(slave)
    os.set_blocking(master, False)
    path = os.ttyname(slave)
    made_link = False
    if link:
        if os.path.islink(link):
            os.unlink(link)
        os.symlink(path, link)
        made_link = True
    stopping = []

    def _stop(signum, frame):
        stopping.append(signum)

    old = {s: signal.signal(s, _stop) for s in (signal.SIGINT, signal.SIGTERM)}
    jlog(dict(t_s=0.0, event="serve", path=path, clock=clock, pid=os.getpid()))
    (announce or (lambda p: (print(p), sys.stdout.flush())))(path)
    tick = TICK_US * 1e-6
    delayed = collections.deque()
    dropped_out = 0
    pending = bytearray()                 # output the pty could not take yet
    max_late = 0.0
    max_pending = 0
    connected = True
    last_write, seen_queued = 0.0, False
    nxt = time.monotonic() + tick
    try:
        while not stopping and not (stop is not None and stop()):
            now = time.monotonic()
            virtual_go = False
            if clock == "virtual" and connected and dev.state != 0 and not dev.out and not pending:
                # the host has read everything sent (a just-written frame may not have reached
                # the slave's queue yet: it counts as read only once seen there, or after 2 ms)
                q = _queued(slave)
                if q > 0:
                    seen_queued = True
                virtual_go = q == 0 and (seen_queued or now - last_write > 0.002)
            wait = 0.0 if virtual_go else max(0.0, nxt - now)
            if clock == "virtual" and dev.state != 0:
                wait = min(wait, 0.0002)          # poll the host's progress
            if connected:
                r, _, _ = select.select([master], [master] if pending else [], [],
                                        min(wait, 0.05) if not virtual_go else 0)
            else:
                time.sleep(min(wait, 0.05)); r = []
            now = time.monotonic()
            if not virtual_go and now >= nxt:
                max_late = max(max_late, now - nxt)
            due = 1 if virtual_go else min(20, int((now - nxt) / tick) + 1 if now >= nxt else 0)
            if r:
                try:
                    data = os.read(master, 65536)
                except (BlockingIOError, InterruptedError):
                    data = b""
                except OSError:          # EIO: no host has the slave open (we hold it, so rare)
                    data = b""
                if data:
                    if lf.specs:
                        data = lf.mangle(data, dev.time_us * 1e-6)
                    # the bytes arrived by now: stamp them with the device time we catch up to
                    dev.receive(data, at_us=dev.time_us + max(0, due - 1) * TICK_US)
            n = 0
            if virtual_go:
                dev.step(); n = 1
                nxt = now + tick
            else:
                while now >= nxt and n < 20:
                    dev.step(); n += 1; nxt += tick
                if now >= nxt:
                    nxt = now + tick
            out = dev.take_output()
            if lf.specs:
                t = dev.time_us * 1e-6
                if connected and lf.disconnected(t):
                    jlog(dict(t_s=t, event="disconnect"))
                    os.close(master)
                    connected = False
                out = lf.mangle(out, t) + (lf.garbage(t) if n else b"")
                d = lf.delay_s(t)
                if d > 0 or delayed:
                    if out:
                        delayed.append((t + d, out))
                    out = b""
                    while delayed and delayed[0][0] <= t:
                        out += delayed.popleft()[1]
            if out and connected:
                pending += out
                if len(pending) > MAX_PENDING:          # nobody reads: drop the oldest bytes
                    dropped_out += len(pending) - MAX_PENDING
                    del pending[:len(pending) - MAX_PENDING]
            if pending and connected:
                try:
                    k = os.write(master, pending)
                    max_pending = max(max_pending, len(pending))
                    del pending[:k]
                    last_write, seen_queued = time.monotonic(), False
                except (BlockingIOError, InterruptedError):
                    pass                                # the pty is full: retry when writable
                except OSError:
                    dropped_out += len(pending)
                    pending.clear()
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        jlog(dict(t_s=round(dev.time_us * 1e-6, 6), event="stop", dropped_output_bytes=dropped_out + len(pending),
                  max_late_ms=round(max_late * 1e3, 1), max_pending_bytes=max_pending,
                  state=dev.state.name, last_fault=dev.last_fault, setpoint_C=round(dev.sp, 3),
                  pad_C=round(dev.plant.pad, 3)))
        jlog.close()
        if connected:
            os.close(master)
        os.close(slave)
        if made_link and os.path.islink(link):
            os.unlink(link)
    return 0


def main(argv=None) -> int:
    """``python -m experiments.hardware.pty_server [thermocue emulator options]``."""
    import argparse

    from experiments.cli import emulator
    from experiments.errors import UserInputError
    parser = argparse.ArgumentParser(prog="python -m experiments.hardware.pty_server")
    emulator.register(parser.add_subparsers(dest="command", required=True))
    ns = parser.parse_args(["emulator", *(sys.argv[1:] if argv is None else argv)])
    try:
        return ns.func(ns)
    except UserInputError as exc:          # same contract as thermocue: one line, status 2
        print(f"thermocue emulator: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
