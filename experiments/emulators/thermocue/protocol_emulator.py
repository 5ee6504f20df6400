"""The emulated display as a pyserial URL handler, in the manner of pyserial's ``loop://``.

URL grammar::

    emulator://[?faults=SPEC][&clock=real|virtual][&seed=N][&sim=1|0][&log=PATH][&id=DEVICE_ID]
                [&core=py|c]

    faults   fault injection, see experiments.emulators.thermocue.faults (default: none); a "+" is
             a plus (stall@100+5: from 100 s for 5 s), not a space as in HTML forms; an
             event at "@T" fires in one opening of the URL per process (a reconnection's
             device does not have it), "@T*" in every opening
    clock    real: the device ticks every 10 ms of wall time in its own thread (default);
             virtual: the device advances only while the host waits for bytes -- each read that
             finds nothing to return steps it by 10 ms ticks until there is something (and,
             during a trial, up to two ticks more while the read wants more bytes) or the
             read's timeout (counted in device time) is used up; while an injected
             disconnect lasts, each failing read (its timeout) and write (one tick) still
             advances it, so a timed disconnect@T+D ends
    seed     seeds sensor noise and link faults (default 0)
    sim      offer the emulator-only "sim" commands (default 1)
    log      append the device's state changes, faults and watchdog trips as JSON lines to PATH
    id       device id reported in the handshake (default EMU-0001)
    core     py: the firmware's Python twin (default); c: the firmware's own C core, built for
             this machine with cc and loaded with ctypes (native_device.py: the physics, the
             finger and the faults stay in Python)

pyserial finds this module because ``experiments.display`` adds itself to
``serial.protocol_handler_packages`` on import; open it with ``serial.serial_for_url``.
"""
from __future__ import annotations

import os
import threading
import time
import urllib.parse

from serial.serialutil import SerialException, to_bytes

from .device import TICK_US, Device
from ..port.emulated_port import EmulatedPort
from .emulator_core import EmulatorCore, JsonLog
from .faults import faults_for_opening, note_fired, parse_faults
from experiments.display.thermocue.framing import HEADER_SIZE

__all__ = ["Serial", "URL_GRAMMAR", "JsonLog"]

_FRAME_OVERHEAD = HEADER_SIZE + 2          # bytes of a frame besides its payload
#: A read of more bytes than this is never cut short by its size within three ticks (a tick's
#: output: one telemetry frame and a few events of at most 220 bytes each).
_NEVER_SHORT = 16384

URL_GRAMMAR = ("emulator://[?faults=SPEC][&clock=real|virtual][&seed=N][&sim=1|0][&log=PATH]"
               "[&id=DEVICE_ID][&core=py|c]")
_OPTIONS = ("faults", "clock", "seed", "sim", "log", "id", "core")


def parse_url(url: str) -> dict:
    """Options of an ``emulator://`` URL as a dict (``faults`` parsed).

    Raises
    ------
    SerialException
        Wrong scheme, unknown option or bad value; the message quotes the grammar.
    """
    parts = urllib.parse.urlsplit(url)
    if parts.scheme != "emulator":
        raise SerialException(f"expected a URL of the form {URL_GRAMMAR!r}: not starting with "
                              f"emulator:// ({url!r})")
    opts = dict(faults=[], clock="real", seed=0, sim=True, log=None, id="EMU-0001", core="py")
    try:
        # parse_qs decodes "+" as a space (HTML forms); here it is the fault SPEC's "+FOR_s"
        query = parts.query.replace("+", "%2B")
        for key, values in urllib.parse.parse_qs(query, keep_blank_values=True).items():
            value = values[-1]
            if key not in _OPTIONS:
                raise ValueError(f"unknown option {key!r}")
            if key == "faults":
                opts["faults"] = parse_faults(value, where="emulator:// faults")
            elif key == "clock":
                if value not in ("real", "virtual"):
                    raise ValueError(f"clock: expected real or virtual, got {value!r}")
                opts["clock"] = value
            elif key == "seed":
                opts["seed"] = int(value)
            elif key == "core":
                if value not in ("py", "c"):
                    raise ValueError(f"core: expected py or c, got {value!r}")
                opts["core"] = value
            elif key == "sim":
                if value not in ("0", "1"):
                    raise ValueError(f"sim: expected 0 or 1, got {value!r}")
                opts["sim"] = value == "1"
            else:
                opts[key] = value
    except ValueError as exc:
        raise SerialException(f"expected a URL of the form {URL_GRAMMAR!r}: {exc}") from None
    return opts


class Serial(EmulatedPort):
    """An emulated display behind the pyserial API (see the module docstring for the URL).

    A thin transport over :class:`~experiments.emulators.thermocue.emulator_core.EmulatorCore`: it keeps
    the host's receive buffer and runs the core's clock (a thread, or the host's reads).
    """

    parse_url = staticmethod(parse_url)

    def __init__(self, *args, **kwargs):
        self.core: EmulatorCore | None = None
        self.virtual = False
        self._lock = threading.RLock()   # the condition's lock: `with self._lock` costs a C call,
        #                                  `with self._cond` a Python one (the direct write)
        self._cond = threading.Condition(self._lock)
        self._rx = bytearray()
        self._thread = None
        self._stop = False
        self._log = None
        self._specs = []
        self._hb_pipe = None                   # real clock: (read end, write end) for the helper
        super().__init__(*args, **kwargs)

    @property
    def device(self) -> Device | None:
        """The emulated firmware (tests may put a modified one in its place before use)."""
        return self.core.device if self.core is not None else None

    @device.setter
    def device(self, dev: Device) -> None:
        self.core.device = dev

    @property
    def link(self):
        """The link's faults (:class:`~experiments.emulators.thermocue.faults.LinkFaults`)."""
        return self.core.link if self.core is not None else None

    # ------------------------------------------------------------------ pyserial plumbing
    def open(self):
        self._check_can_open()
        opts = parse_url(self.port)
        self._log = JsonLog(opts["log"])
        self._specs = opts["faults"]          # the URL's whole SPEC: its once-events are noted
        self.core = EmulatorCore(seed=opts["seed"], faults=faults_for_opening(self.port, self._specs),
                                 sim=opts["sim"], log=self._log, device_id=opts["id"],
                                 core=opts["core"])
        self.virtual = opts["clock"] == "virtual"
        self._rx.clear()
        self.is_open = True
        self._stop = False
        if not self.virtual:
            # a descriptor for the host's heartbeat helper process (its bytes are read by the
            # clock thread below, as a device reads its UART): the helper needs no GIL of ours
            r, w = os.pipe()
            os.set_blocking(r, False)
            self._hb_pipe = (r, w)
            self.core.start_real_time(time.monotonic())
            self._start_clock(self._run_real_time, "emulator-clock")

    def close(self):
        if self.is_open:
            self.is_open = False
            self._stop_clock(self._cond)
            note_fired(self.port, self._specs, self.core.time_s)
            if self._log is not None:
                dev = self.core.device
                dev.log("stop", max_host_gap_ms=round(dev.max_rx_gap_us * 1e-3, 1))
                self._log.close()
            if self._hb_pipe is not None:
                for end in self._hb_pipe:
                    try:
                        os.close(end)
                    except OSError:
                        pass
                self._hb_pipe = None
        super().close()

    @property
    def fd(self) -> int | None:
        """Real clock: a descriptor the host's heartbeat helper process may write frames to.

        The bytes reach the device as the clock thread finds them (stamped, when it runs late,
        with the caught-up time: :meth:`EmulatorCore.late_stamp_us`), like a device's UART
        that fills while its firmware is busy. None on a virtual clock (the host heartbeats in
        device time there).
        """
        return self._hb_pipe[1] if self._hb_pipe is not None else None

    # ------------------------------------------------------------------ the device clock
    @property
    def virtual_time_s(self) -> float | None:
        """Device time in virtual-clock mode (the driver's clock), else None."""
        return self.core.time_s if self.virtual and self.core else None

    def device_clock(self):
        """The device's clock as a function returning seconds, or None on a real clock.

        On a virtual clock the host must measure every timeout in device time (the device
        advances only while the host reads); a driver asks for this clock once, here, instead
        of reading the emulator's internals.
        """
        if not self.virtual:
            return None
        core = self.core
        return lambda: core.device.time_us * 1e-6

    def _tick(self) -> None:
        """Advance the device one tick and move its output to the host side (lock held)."""
        data = self.core.tick()
        if data:
            self._rx += data

    def _run_real_time(self) -> None:
        core = self.core
        while True:
            with self._cond:
                if self._stop:
                    return
                now = time.monotonic()
                if now < core.next_tick:
                    self._cond.wait(core.next_tick - now)
                    continue
                self._take_helper_bytes(now)
                _, data = core.catch_up(now)
                if data:
                    self._rx += data
                if self._rx:
                    self._cond.notify_all()

    def _take_helper_bytes(self, now: float) -> None:
        """What the heartbeat helper wrote since the last tick, into the device (lock held).

        Before the ticks owed are computed: bytes that waited while this process was starved
        (the GIL held by the host's main thread, the machine loaded) arrived by the caught-up
        time, and feed the watchdog as of then -- as on a pty (:mod:`.pty_server`)."""
        pipe = self._hb_pipe
        if pipe is None:
            return
        try:
            data = os.read(pipe[0], 65536)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            return
        if not data or self.core.disconnected():
            return
        core = self.core
        core.to_device(data, at_us=core.late_stamp_us(now))
        out = core.to_host(ticked=False)
        if out:
            self._rx += out

    # ------------------------------------------------------------------ I/O
    @property
    def in_waiting(self):
        self._check_open()
        return len(self._rx)

    def read(self, size=1):
        self._check_open()
        if size <= 0:
            return b""
        timeout = self._timeout
        core = self.core
        with self._cond:
            if core.disconnected():
                if self.virtual:
                    # time goes on while the link is dead (a read that waits its timeout for
                    # nothing), so a timed disconnect@T+D ends and the device's watchdog acts
                    budget = 1 if not timeout else max(1, int(timeout * 1e6 / TICK_US + 0.5))
                    for _ in range(budget):
                        self._tick()
                    self._rx.clear()           # what the device said meanwhile was lost
                raise SerialException("emulator: device disconnected (injected fault)")
            if self.virtual:
                if not self._rx and timeout != 0:
                    budget = 10**9 if timeout is None else max(1, int(timeout * 1e6 / TICK_US + 0.5))
                    rx = self._rx
                    for _ in range(budget):
                        self._tick()
                        if rx:
                            break
                    # a reader asking for more gets up to 3 ticks' worth per call (30 ms of device
                    # time: well inside the 90 ms watchdog, with a 10 ms heartbeat)
                    extra = 0
                    while rx and len(rx) < size and extra < 2 and core.device.state != 0:
                        self._tick()
                        extra += 1
                    if core.disconnected():
                        raise SerialException("emulator: device disconnected (injected fault)")
            elif not self._rx and timeout != 0:
                deadline = None if timeout is None else time.monotonic() + timeout
                while not self._rx and self.is_open:
                    left = None if deadline is None else deadline - time.monotonic()
                    if left is not None and left <= 0:
                        break
                    self._cond.wait(left)
            n = min(size, len(self._rx))
            data = bytes(self._rx[:n])
            del self._rx[:n]
            return data

    def read_frames(self, size=65536):
        """:meth:`read` as decoded frames, on a virtual clock with no fault injected; else None.

        The same ticks as ``read(size)`` (until the device has something to say, then up to two
        more while a trial runs and less than ``size`` bytes are due), the same frames in the
        same order, but the device hands them over without encoding them and the host takes
        them without parsing: with nothing on the line to drop, corrupt or delay, the bytes
        would only be built and taken apart again. The driver's I/O loop uses it when offered.

        Returns
        -------
        list of Frame or None
            None when the fast path does not apply (real clock, a fault spec, bytes or a partial
            frame waiting, a zero timeout): call :meth:`read`.
        """
        if not self.is_open:
            self._check_open()                 # (raises; the check inline: 100 reads a second)
        core = self.core
        dev = core.device
        timeout = self._timeout
        if (not self.virtual or self._rx or dev.out or core.link.specs or dev.faults
                or dev.stalled or timeout == 0 or size <= 0):
            return None
        budget = 10**9 if timeout is None else max(1, int(timeout * 1e6 / TICK_US + 0.5))
        with self._lock:                      # (the condition's lock; nobody to notify here)
            frames = dev.direct = []
            try:
                step = dev.step
                for _ in range(budget):
                    step()
                    if frames:
                        break
                if frames:
                    # read() stops short of ``size`` bytes; a tick says well under 1 kB, so
                    # only a small ``size`` needs the frames' lengths counted
                    n = 0 if size > _NEVER_SHORT else sum(_FRAME_OVERHEAD + len(f.payload)
                                                          for f in frames)
                    extra = 0
                    while n < size and extra < 2 and dev.state != 0:
                        k = len(frames)
                        step()
                        extra += 1
                        if size <= _NEVER_SHORT:
                            n += sum(_FRAME_OVERHEAD + len(f.payload) for f in frames[k:])
            finally:
                dev.direct = None
        return frames

    def write(self, data):
        if not self.is_open:
            self._check_open()                 # (raises)
        core = self.core
        if self.virtual and not core.link.specs:
            return self._write_direct(data if data.__class__ is bytes else to_bytes(data))
        return self._write_through_link(to_bytes(data))

    def _write_direct(self, data: bytes) -> int:
        """:meth:`write` on a virtual clock with no link fault: what the link would do, without
        its layers (nothing to mangle, garble or delay, no disconnect, no late stamp: the bytes
        reach the device as they are, and only its replies come back). A silent heartbeat, the
        host's commonest frame, ends in the device's own shortcut (``HostCommands.receive``)."""
        dev = self.core.device
        with self._lock:
            dev.receive(data)
            if dev.out:
                self._rx += dev.take_output()
            if self._rx:
                self._cond.notify_all()
        return len(data)

    def _write_through_link(self, data: bytes) -> int:
        """:meth:`write` through the link's faults and clock rules (any clock, any fault)."""
        core = self.core
        with self._cond:
            if core.disconnected():
                if self.virtual:
                    self._tick()                   # a write to a dead link takes time too
                    self._rx.clear()
                raise SerialException("emulator: device disconnected (injected fault)")
            at_us = None if self.virtual else core.late_stamp_us(time.monotonic())
            core.to_device(data, at_us=at_us)
            out = core.to_host(ticked=False)
            if out:
                self._rx += out
            if self._rx:
                self._cond.notify_all()
        return len(data)

    def reset_input_buffer(self):
        self._check_open()
        with self._cond:
            self._rx.clear()

    def cancel_read(self):
        with self._cond:
            self._cond.notify_all()
