"""The emulated display and its link, one core for every transport.

An :class:`EmulatorCore` owns the :class:`~experiments.emulators.thermocue.device.Device` (the firmware), the
:class:`~experiments.emulators.thermocue.faults.LinkFaults` between it and the host (drop, corrupt, garbage,
delay, disconnect) and the clock rules the transports share: what one tick sends to the host, how
host bytes are stamped when the emulator itself runs late, and how a starved real-time clock
catches up. The two transports only move bytes:

- :mod:`~experiments.emulators.thermocue.protocol_emulator`, the in-process ``emulator://`` pyserial URL
  handler (real clock in a thread, or a virtual clock driven by the host's reads);
- :mod:`~experiments.emulators.pty_server`, the same device on a real pseudo-terminal.

Link faults act identically in both: host bytes are mangled (drop, corrupt) as they arrive;
device bytes are mangled, joined by garbage once per tick, and held back by ``delay`` until their
device time comes; ``disconnect`` is asked of :meth:`EmulatorCore.disconnected`, and each
transport shows it the way its medium would (a failing call, a closed pty).
"""
from __future__ import annotations

import collections
import json

from .device import TICK_US, Device
from .faults import LinkFaults, parse_faults

__all__ = ["EmulatorCore", "JsonLog", "MAX_CATCH_UP_TICKS"]

#: Ticks a starved real-time clock computes at once before it gives up the lost time.
MAX_CATCH_UP_TICKS = 20


class JsonLog:
    """Append dicts as JSON lines (flushed at once) and keep the last 2,000 in memory."""

    def __init__(self, path=None):
        self.records = collections.deque(maxlen=2000)
        self._fh = open(path, "a", encoding="utf-8") if path else None

    def __call__(self, rec: dict) -> None:
        self.records.append(rec)
        if self._fh is not None:
            self._fh.write(json.dumps(rec, sort_keys=True) + "\n")
            self._fh.flush()

    def close(self):
        if self._fh is not None:
            self._fh.close()
            self._fh = None


class EmulatorCore:
    """One emulated display behind one link (see the module docstring).

    Parameters
    ----------
    seed : int
        Seeds sensor noise and link faults.
    faults : str or list of FaultSpec, optional
        Device and link faults (:mod:`experiments.emulators.thermocue.faults`).
    sim : bool
        Offer the emulator-only "sim" commands.
    log : callable, optional
        Called with a dict for every state change, fault and watchdog trip.
    device_id : str
    core : {"py", "c"}
        The firmware: the Python twin (:mod:`.device`) or the firmware's own C core built for
        this machine (:mod:`.native_device`).
    """

    def __init__(self, *, seed: int = 0, faults=None, sim: bool = True, log=None,
                 device_id: str = "EMU-0001", core: str = "py"):
        specs = (parse_faults(faults) if isinstance(faults, (str, type(None))) else list(faults))
        if core == "c":
            from .native_device import NativeDevice
            make = NativeDevice
        else:
            make = Device
        self.device = make(seed=seed, faults=specs, sim=sim, log=log, device_id=device_id)
        self.link = LinkFaults(specs, seed=seed)
        self.device.fault_listeners.append(self.link.add)
        self._delayed = collections.deque()      # (device time due, bytes) held by ``delay``
        self.next_tick = None                     # real clock: monotonic time of the next tick
        self.max_late_s = 0.0                     # real clock: worst lateness of a tick

    # ------------------------------------------------------------------ the device clock
    @property
    def time_s(self) -> float:
        """Device time, s (from the emulator's start, not the last power-up)."""
        return self.device.time_us * 1e-6

    def disconnected(self) -> bool:
        """Whether an injected ``disconnect`` holds the link dead now."""
        link = self.link
        return bool(link.specs) and link.disconnected(self.device.time_us * 1e-6)

    # ------------------------------------------------------------------ bytes both ways
    def to_device(self, data: bytes, at_us: int | None = None) -> None:
        """Bytes from the host, through the link's faults, into the device.

        ``at_us``: device time the bytes are known to have arrived by (see :meth:`late_stamp_us`).
        """
        if self.link.specs:
            data = self.link.mangle(data, self.device.time_us * 1e-6)
        self.device.receive(data, at_us=at_us)

    def to_host(self, ticked: bool = True) -> bytes:
        """What reaches the host now: the device's output through the link's faults.

        Parameters
        ----------
        ticked : bool
            Whether the device has just ticked (``garbage`` is drawn once per tick); False after
            handling host bytes, when only the replies (and delayed bytes now due) go out.
        """
        data = self.device.take_output()
        link = self.link
        if not link.specs:
            return data
        t = self.device.time_us * 1e-6
        data = link.mangle(data, t)
        if ticked:
            data += link.garbage(t)
        delay = link.delay_s(t)
        delayed = self._delayed
        if delay > 0 or delayed:
            if data:
                delayed.append((t + delay, data))
            data = b""
            while delayed and delayed[0][0] <= t:
                data += delayed.popleft()[1]
        return data

    def tick(self) -> bytes:
        """Advance the device 10 ms; return what reaches the host."""
        self.device.step()
        return self.to_host(True)

    # ------------------------------------------------------------------ real-time clock
    def start_real_time(self, now: float) -> None:
        """Start the real-time clock at monotonic time ``now`` (first tick one tick later)."""
        self.next_tick = now + TICK_US * 1e-6

    def catch_up(self, now: float) -> tuple[int, bytes]:
        """Compute the ticks due by monotonic time ``now`` (at most :data:`MAX_CATCH_UP_TICKS`).

        Returns
        -------
        n : int
            Ticks computed.
        data : bytes
            What reaches the host meanwhile.
        """
        tick = TICK_US * 1e-6
        nxt = self.next_tick
        if now >= nxt:
            self.max_late_s = max(self.max_late_s, now - nxt)
        n, out = 0, b""
        while now >= nxt and n < MAX_CATCH_UP_TICKS:
            out += self.tick()
            nxt += tick
            n += 1
        if now >= nxt:                   # too far behind: the lost time is not made up
            nxt = now + tick
        self.next_tick = nxt
        return n, out

    def late_stamp_us(self, now: float) -> int | None:
        """Device time host bytes arriving at monotonic ``now`` are stamped with (None: now).

        A starved real-time clock is about to catch up on the ticks it owes: the bytes arrived
        by then, so they feed the watchdog as of that device time and the emulator's own
        lateness never trips it.
        """
        if self.next_tick is None:
            return None
        late = now - self.next_tick
        if late < 0:
            return None
        ticks = min(MAX_CATCH_UP_TICKS - 1, int(late / (TICK_US * 1e-6)))
        return self.device.time_us + ticks * TICK_US
