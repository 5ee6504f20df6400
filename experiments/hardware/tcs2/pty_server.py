"""Serve the TCS II emulator on a real pseudo-terminal (``thermocue emulator --model tcs2``).

Like :mod:`experiments.hardware.pty_server` for the thermocue display: a pty pair in raw mode,
the slave's path printed (and ``--link PATH`` made a symbolic link to it, held with the same
lock), the device ticked every 10 ms of wall time -- or ``speed`` times faster -- until SIGINT
or SIGTERM. A host opens the path as ``tcs2://PATH``.
"""
from __future__ import annotations

import os
import select
import signal
import sys
import threading
import time
import tty

from experiments.errors import UserInputError

from ..pty_server import hold_link
from .device import TICK_S, Tcs2Device

__all__ = ["serve", "run"]


def serve(*, faults: str | None = None, seed: int = 0, speed: float = 1.0, link: str | None = None,
          sim: bool = True, announce=None, stop=None) -> int:
    """Run the emulated TCS II on a new pty until a signal (or ``stop()`` is true); return 0."""
    dev = Tcs2Device(faults, seed=seed, firmware=None if sim else "012")
    master, slave = os.openpty()
    tty.setraw(slave)
    os.set_blocking(master, False)
    path = os.ttyname(slave)
    if link:
        if os.path.islink(link):
            os.unlink(link)
        os.symlink(path, link)
    stopping = []
    # signals stop it when it runs as the program (a thread, e.g. a test's, uses ``stop``)
    main = threading.current_thread() is threading.main_thread()
    old = ({s: signal.signal(s, lambda n, f: stopping.append(n)) for s in (signal.SIGINT, signal.SIGTERM)}
           if main else {})
    (announce or (lambda p: (print(p), sys.stdout.flush())))(path)
    step = TICK_S / speed
    next_t = time.monotonic()
    pending = bytearray()
    try:
        while not stopping and not (stop is not None and stop()):
            wait = max(0.0, next_t - time.monotonic())
            r, _, _ = select.select([master], [master] if pending else [], [], min(wait, 0.05))
            if r:
                try:
                    data = os.read(master, 65536)
                except (BlockingIOError, InterruptedError, OSError):
                    data = b""
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
            if not dev.disconnected:
                pending += dev.take()
            else:
                dev.take()
            if pending:
                try:
                    k = os.write(master, pending)
                    del pending[:k]
                except (BlockingIOError, InterruptedError):
                    pass
                except OSError:
                    pending.clear()
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        os.close(master)
        os.close(slave)
        if link and os.path.islink(link):
            os.unlink(link)
    return 0


def run(ns) -> int:
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
        return serve(**kw)
    with hold_link(ns.link):
        return serve(link=ns.link, **kw)
