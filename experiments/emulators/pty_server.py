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

Run it with ``thermocue emulator`` or ``python -m experiments.emulators.pty_server``.

The one pty server of both emulators: :func:`serve`/:func:`run` serve the thermocue display
(:mod:`.thermocue`), :func:`serve_tcs2`/:func:`run_tcs2` the QST.Lab TCS II (:mod:`.tcs2`,
``thermocue emulator --model tcs2``; a host opens the path as ``tcs2://PATH``) on the same
:class:`PtyEndpoint`, :class:`hold_link` and :class:`stop_signals`.
"""
from __future__ import annotations

import argparse
import fcntl
import os
import select
import signal
import struct
import sys
import termios
import threading
import time
import tty

from experiments.errors import UserInputError

from .options import add_arguments
from .tcs2.device import TICK_S, Tcs2Device
from .thermocue.device import TICK_US
from .thermocue.emulator_core import EmulatorCore, JsonLog
from .thermocue.faults import parse_faults

__all__ = ["serve", "main", "add_arguments", "run", "serve_tcs2", "run_tcs2", "hold_link",
           "PtyEndpoint", "stop_signals",
           "MAX_PENDING"]

#: Output bytes held for a host that does not read (≈ 4 min of telemetry at 100 Hz).
MAX_PENDING = 1 << 20


def _queued(fd: int) -> int:
    """Bytes waiting in the input queue of tty ``fd``."""
    return struct.unpack("i", fcntl.ioctl(fd, termios.FIONREAD, b"\0\0\0\0"))[0]


class PtyEndpoint:
    """The device's end of a pty pair, for an emulator that serves on it.

    The slave side in raw mode, its path (and ``link``, a symbolic link to it, replaced in one
    step so the path is never missing), the master non-blocking; output the host has not read
    yet is kept (up to :data:`MAX_PENDING` bytes, beyond which the oldest are dropped and
    counted). The endpoint keeps the slave open, so a host may close the port and another
    connect later.

    Raises
    ------
    UserInputError
        ``link`` exists and is not a symbolic link (it is not replaced).
    """

    def __init__(self, link: str | None = None):
        if link and os.path.lexists(link) and not os.path.islink(link):
            raise UserInputError(f"--link {link}: expected a new path or a symbolic link, got "
                                 f"a path that is neither (not replaced)")
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        os.set_blocking(self.master, False)
        self.path = os.ttyname(self.slave)
        self.link = None
        if link:
            # a stale link (of an emulator that was killed) is replaced in one step: a new link
            # under a temporary name renamed over it
            tmp_link = f"{link}.{os.getpid()}.tmp"
            if os.path.lexists(tmp_link):
                os.unlink(tmp_link)
            os.symlink(self.path, tmp_link)
            os.replace(tmp_link, link)
            self.link = link
        self.pending = bytearray()            # output the pty could not take yet
        self.dropped = 0
        self.max_pending = 0
        self.connected = True

    def wait(self, timeout_s: float) -> bool:
        """Wait up to ``timeout_s`` for host bytes (or room for pending output); True if bytes."""
        if not self.connected:
            time.sleep(timeout_s)
            return False
        r, _, _ = select.select([self.master], [self.master] if self.pending else [], [],
                                timeout_s)
        return bool(r)

    def read(self) -> bytes:
        """What the host wrote (empty if nothing, or if no host has the slave open)."""
        try:
            return os.read(self.master, 65536)
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError:              # EIO: no host has the slave open (we hold it, so rare)
            return b""

    def send(self, out: bytes) -> bool:
        """Queue ``out`` and write what the pty takes; True if anything was written."""
        if not self.connected:
            return False
        if out:
            self.pending += out
            if len(self.pending) > MAX_PENDING:          # nobody reads: drop the oldest bytes
                self.dropped += len(self.pending) - MAX_PENDING
                del self.pending[:len(self.pending) - MAX_PENDING]
        if not self.pending:
            return False
        try:
            k = os.write(self.master, self.pending)
        except (BlockingIOError, InterruptedError):
            return False                                 # the pty is full: retry when writable
        except OSError:
            self.dropped += len(self.pending)
            self.pending.clear()
            return False
        self.max_pending = max(self.max_pending, len(self.pending))
        del self.pending[:k]
        return True

    def disconnect(self) -> None:
        """Close the master (an injected disconnect): the host's port fails from now on."""
        if self.connected:
            os.close(self.master)
            self.connected = False

    def close(self) -> None:
        """Close both ends and remove the link this endpoint made."""
        self.disconnect()
        os.close(self.slave)
        if self.link and os.path.islink(self.link):
            os.unlink(self.link)


class stop_signals:
    """SIGINT and SIGTERM append to the list this context gives, in the main thread (elsewhere,
    e.g. a test's thread, the handlers are left alone and the caller's ``stop`` decides)."""

    def __enter__(self) -> list:
        self.stopping = []
        self.old = {}
        if threading.current_thread() is threading.main_thread():
            self.old = {s: signal.signal(s, lambda n, f: self.stopping.append(n))
                        for s in (signal.SIGINT, signal.SIGTERM)}
        return self.stopping

    def __exit__(self, *exc):
        for s, h in self.old.items():
            signal.signal(s, h)
        return False


def serve(*, faults=None, clock: str = "real", seed: int = 0, link: str | None = None,
          log: str | None = None, sim: bool = True, announce=None, stop=None) -> int:
    """Run the emulator on a new pty until a signal (or ``stop()`` returns True).

    Parameters
    ----------
    faults : str or list, optional
        Fault SPEC (see :mod:`experiments.emulators.thermocue.faults`).
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
    jlog = JsonLog(log)               # before the pty and its link: a bad --log leaves nothing
    try:
        core = EmulatorCore(seed=seed, faults=faults, sim=sim, log=jlog)
        pty = PtyEndpoint(link)
    except BaseException:
        jlog.close()
        raise
    dev = core.device
    path = pty.path
    tick = TICK_US * 1e-6
    last_write, seen_queued = 0.0, False
    with stop_signals() as stopping:
        try:
            # inside the try: a path that cannot be announced (stdout gone) still removes the link
            jlog(dict(t_s=0.0, event="serve", path=path, clock=clock, pid=os.getpid()))
            (announce or (lambda p: (print(p), sys.stdout.flush())))(path)
            core.start_real_time(time.monotonic())
            while not stopping and not (stop is not None and stop()):
                now = time.monotonic()
                virtual_go = False
                if (clock == "virtual" and pty.connected and dev.state != 0 and not dev.out
                        and not pty.pending):
                    # the host has read everything sent (a just-written frame may not have
                    # reached the slave's queue yet: it counts as read only once seen there,
                    # or after 2 ms)
                    q = _queued(pty.slave)
                    if q > 0:
                        seen_queued = True
                    virtual_go = q == 0 and (seen_queued or now - last_write > 0.002)
                wait = 0.0 if virtual_go else max(0.0, core.next_tick - now)
                if clock == "virtual" and dev.state != 0:
                    wait = min(wait, 0.0002)          # poll the host's progress
                readable = pty.wait(min(wait, 0.05) if not virtual_go else 0)
                now = time.monotonic()
                if readable:
                    data = pty.read()
                    if data:
                        # the bytes arrived by now: stamp them with the device time we catch
                        # up to
                        core.to_device(data,
                                       at_us=None if virtual_go else core.late_stamp_us(now))
                if virtual_go:
                    out = core.tick()
                    core.next_tick = now + tick
                else:
                    _, out = core.catch_up(now)
                out += core.to_host(ticked=False)         # replies to the host bytes just read
                if pty.connected and core.disconnected():
                    jlog(dict(t_s=core.time_s, event="disconnect"))
                    pty.disconnect()
                if pty.send(out):
                    last_write, seen_queued = time.monotonic(), False
        finally:
            jlog(dict(t_s=round(dev.time_us * 1e-6, 6), event="stop",
                      dropped_output_bytes=pty.dropped + len(pty.pending),
                      max_late_ms=round(core.max_late_s * 1e3, 1),
                      max_host_gap_ms=round(dev.max_rx_gap_us * 1e-3, 1),
                      max_pending_bytes=pty.max_pending, state=dev.state.name,
                      last_fault=dev.last_fault, setpoint_C=round(dev.sp, 3),
                      pad_C=round(dev.plant.pad, 3)))
            jlog.close()
            pty.close()
    return 0


def run(ns) -> int:
    """Serve with the options :func:`~.emulator_options.add_arguments` parsed (holding ``--link``).

    Raises
    ------
    UserInputError
        A bad ``--faults`` SPEC, or a ``--link`` PATH another emulator holds.
    """
    specs = parse_faults(ns.faults, where="--faults")
    _device_priority()
    if not ns.link:
        return serve(faults=specs, clock=ns.clock, seed=ns.seed, link=None, log=ns.log,
                     sim=not ns.no_sim)
    with hold_link(ns.link):
        return serve(faults=specs, clock=ns.clock, seed=ns.seed, link=ns.link, log=ns.log,
                     sim=not ns.no_sim)


def _device_priority() -> None:
    """Nice −10 for ``thermocue emulator`` when allowed (else unchanged): the process stands in
    for a device, which has a processor of its own; on a machine loaded with CPU-bound work an
    ordinary-priority emulator fell behind by more than its 20 catch-up ticks (the time lost is
    not made up) and its watchdog judged the host by that starved clock."""
    try:
        os.setpriority(os.PRIO_PROCESS, 0, min(os.getpriority(os.PRIO_PROCESS, 0), -10))
    except (AttributeError, OSError):
        pass


def _lock_path(link: str) -> str:
    return f"{link}.lock"


class hold_link:
    """Claim ``--link PATH`` for this emulator's lifetime (``PATH.lock``, an exclusive flock).

    A second emulator given the same PATH while the first runs is refused (the old behaviour:
    it silently replaced the first one's link and deleted it on exit). The lock dies with its
    process, so a link left by a killed emulator is simply replaced.

    Raises
    ------
    UserInputError
        ``--link PATH: expected a path no running emulator holds, got the link of process N``;
        or a path that exists and is not a symbolic link.
    """

    def __init__(self, link: str):
        self.link = link
        self.fd = None

    def __enter__(self):
        if os.path.lexists(self.link) and not os.path.islink(self.link):
            raise UserInputError(f"--link {self.link}: expected a new path or a symbolic link, "
                                 f"got an existing file")
        fd = os.open(_lock_path(self.link), os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(fd, 32).decode(errors="replace").strip() or "?"
            os.close(fd)
            raise UserInputError(f"--link {self.link}: expected a path no running emulator holds, "
                                 f"got the link of emulator process {holder} (stop it, or choose "
                                 f"another --link)") from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self.fd = fd
        return self

    def __exit__(self, *exc):
        try:
            os.unlink(_lock_path(self.link))
        except OSError:
            pass
        os.close(self.fd)
        return False


def serve_tcs2(*, faults: str | None = None, seed: int = 0, speed: float = 1.0, link: str | None = None,
          sim: bool = True, announce=None, stop=None) -> int:
    """Run the emulated TCS II (:mod:`.tcs2.device`) on a new pty until a signal (or ``stop()`` is true); return 0."""
    dev = Tcs2Device(faults, seed=seed, firmware=None if sim else "012")
    pty = PtyEndpoint(link)
    step = TICK_S / speed
    with stop_signals() as stopping:
        try:
            # inside the try: a path that cannot be announced (stdout gone) still removes the link
            (announce or (lambda p: (print(p), sys.stdout.flush())))(pty.path)
            next_t = time.monotonic()
            while not stopping and not (stop is not None and stop()):
                wait = max(0.0, next_t - time.monotonic())
                if pty.wait(min(wait, 0.05)):
                    data = pty.read()
                    if data and not dev.disconnected:
                        dev.feed(data)
                now = time.monotonic()
                ticks = 0
                while now >= next_t and ticks < 20:
                    dev.tick()
                    next_t += step
                    ticks += 1
                if now - next_t > 0.5:
                    next_t = now                    # starved: do not race to catch up
                out = dev.take()                    # a disconnected device's output is lost
                pty.send(b"" if dev.disconnected else out)
        finally:
            pty.close()
    return 0


def run_tcs2(ns) -> int:
    """Serve with ``thermocue emulator``'s options (``--model tcs2``).

    Raises
    ------
    UserInputError
        A bad ``--faults`` for the TCS II, ``--clock virtual`` (a pty runs on wall time; use
        ``--speed``), or a ``--link`` PATH another emulator holds.
    """
    if getattr(ns, "clock", "real") != "real":
        raise UserInputError("--clock: expected real for --model tcs2 (a pty runs on wall time; "
                             f"--speed K runs it K times faster), got {ns.clock!r}")
    speed = float(getattr(ns, "speed", 1.0) or 1.0)
    if not 0 < speed <= 100:
        raise UserInputError(f"--speed: expected 0 < K ≤ 100, got {speed!r}")
    try:
        Tcs2Device(ns.faults)
    except ValueError as exc:
        raise UserInputError(f"--faults: {exc}") from None
    kw = dict(faults=ns.faults, seed=ns.seed, speed=speed, sim=not ns.no_sim)
    if not ns.link:
        return serve_tcs2(**kw)
    with hold_link(ns.link):
        return serve_tcs2(link=ns.link, **kw)


def main(argv=None) -> int:
    """``python -m experiments.emulators.pty_server [thermocue emulator options]``."""
    parser = argparse.ArgumentParser(prog="python -m experiments.emulators.pty_server",
                                     description="Serve the emulated thermal display on a pty.")
    add_arguments(parser)
    ns = parser.parse_args(sys.argv[1:] if argv is None else argv)
    try:
        return run(ns)
    except UserInputError as exc:          # same contract as thermocue: one line, status 2
        print(f"thermocue emulator: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
