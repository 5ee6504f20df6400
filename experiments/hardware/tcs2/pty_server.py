"""Serve the TCS II emulator on a real pseudo-terminal (``thermocue emulator --model tcs2``).

Like :mod:`experiments.hardware.pty_server` for the thermocue display: a pty pair in raw mode,
the slave's path printed (and ``--link PATH`` made a symbolic link to it, held with the same
lock), the device ticked every 10 ms of wall time -- or ``speed`` times faster -- until SIGINT
or SIGTERM. A host opens the path as ``tcs2://PATH``.
"""
from __future__ import annotations

import sys
import time

from experiments.errors import UserInputError

from ..pty_server import PtyEndpoint, hold_link, stop_signals
from .device import TICK_S, Tcs2Device

__all__ = ["serve", "run"]


def serve(*, faults: str | None = None, seed: int = 0, speed: float = 1.0, link: str | None = None,
          sim: bool = True, announce=None, stop=None) -> int:
    """Run the emulated TCS II on a new pty until a signal (or ``stop()`` is true); return 0."""
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
