"""Backends of the protocol conformance suite: the Python emulator, the emulator on the
firmware's own C core (``core=c``) and the C firmware under QEMU.

Every test of ``test_conformance.py`` runs once per backend (``backend`` parameter). The
firmware's parametrisation is skipped only when ``qemu-system-arm`` is not installed (CI
installs it with ``scripts/setup``); a missing ARM toolchain with no built image is an error,
not a skip. Both backends run on a real clock: the emulator as ``emulator://?clock=real``, the
firmware on QEMU's emulated real time.

Fixtures: ``backend`` (name), ``display`` (a display opened through the registry, shared by a
module's tests of one backend), ``fresh_display`` (its own device, for tests that end the
session) and ``raw`` (a :class:`RawLink` to a just powered-up device: frames by hand, no
driver).
"""
from __future__ import annotations

import contextlib
import shutil
import time

import pytest
import serial

QEMU_MISSING = shutil.which("qemu-system-arm") is None
URLS = {"emulator": "emulator://?clock=real&seed=7", "qemu-firmware": "qemu-firmware://",
        "emulator-c": "emulator://?clock=real&seed=7&core=c"}
BACKENDS = [
    "emulator",
    # the firmware's C core in the emulator's loop: the same suite again, with the slow tests
    pytest.param("emulator-c", marks=pytest.mark.slow),
    pytest.param("qemu-firmware", marks=pytest.mark.skipif(
        QEMU_MISSING, reason="qemu-system-arm is not installed here (CI installs it with "
                             "scripts/setup); the firmware's conformance is not tested")),
]


@pytest.fixture(scope="module", params=BACKENDS)
def backend(request) -> str:
    return request.param


def open_backend(name: str):
    from experiments.display import open_display
    return open_display(URLS[name])


@pytest.fixture(scope="module")
def shared_display(backend):
    disp = open_backend(backend)
    yield disp
    disp.close()


@pytest.fixture
def display(shared_display):
    """The module's display of this backend, idle at 32 °C (a latched fault cleared)."""
    d = shared_display
    st = d.status()
    if st.state == "FAULT":
        d.clear_fault()
    d.abort()
    d.set_neutral(32.0)
    return d


@pytest.fixture
def fresh_display(backend):
    disp = open_backend(backend)
    yield disp
    disp.close()


class RawLink:
    """Frames by hand to a device that has just powered up (no HELLO yet).

    ``command`` writes one frame and returns the reply with its ``seq`` (ACK or NAK), keeping
    every other frame (telemetry, events) in :attr:`others`.
    """

    def __init__(self, port, close):
        from experiments.display.thermocue.framing import FrameParser
        self.port = port
        self._close = close
        self.parser = FrameParser()
        self.others: list = []
        self._helper = None          # the heartbeat helper of a :meth:`heartbeating` block

    def send(self, seq: int, mtype: int, payload: bytes = b"") -> None:
        from experiments.display.thermocue.framing import encode_frame
        self.port.write(encode_frame(seq, mtype, payload))

    def command(self, seq: int, mtype: int, payload: bytes = b"", timeout_s: float = 1.0):
        self.send(seq, mtype, payload)
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            for fr in self.parser.feed(self.port.read(4096)):
                if fr.seq == seq and fr.type in (mtype | 0x80, 0xFF) and not (
                        fr.type in (0xA0, 0xA1) and len(fr.payload) not in (0, 4)):
                    return fr
                self.others.append(fr)
        return None

    def _start_helper(self):
        from experiments.display.thermocue.framing import encode_frame
        from experiments.display.thermocue.heartbeat import HeartbeatProcess
        fd = getattr(self.port, "fd", None)
        if isinstance(fd, int) and fd >= 0:
            return HeartbeatProcess(fd, encode_frame(0, 0x02, b"\x00"), 0.01, 3600.0)
        return None

    @contextlib.contextmanager
    def heartbeating(self, ready_s: float = 10.0):
        """A silent heartbeat every 10 ms from the driver's helper process for the whole block,
        commands included, as the host's driver keeps one for the whole session.

        Enter it before a command that makes the device active (ARM): the helper is started and
        running (its ready byte read, up to ``ready_s``; this loop heartbeats meanwhile) before
        the block begins, so the start of a process on a loaded machine -- a fork of the suite's
        heap, tens to hundreds of ms -- never falls in the device's 90 ms watchdog. A port with
        no descriptor (the in-process emulator) gets its heartbeat from :meth:`pump`.
        """
        helper = self._start_helper()
        try:
            if helper is not None:
                end = time.monotonic() + ready_s
                while not helper.wait_ready(0.01):
                    if time.monotonic() > end or not helper.running:
                        raise RuntimeError("the heartbeat helper did not start")
                    self.send(0, 0x02, b"\x00")
            self._helper = helper
            yield self
        finally:
            self._helper = None
            if helper is not None:
                helper.stop()

    def pump(self, seconds: float, heartbeat: bool = True, until=None) -> None:
        """Read for ``seconds`` (or until a frame satisfies ``until``), a silent heartbeat
        going out every 10 ms if ``heartbeat``: from the driver's helper process on a port with
        a descriptor, as the host's driver does (a pause of this process -- a garbage
        collection of the suite's heap, another thread -- must not look like a lost host),
        else from this loop. Inside :meth:`heartbeating` its helper already heartbeats."""
        own = None
        if heartbeat and self._helper is None:
            self.send(0, 0x02, b"\x00")      # before the helper's start, which takes a while
            own = self._start_helper()
        helper = own or self._helper
        try:
            end = time.monotonic() + seconds
            nxt = 0.0
            while time.monotonic() < end:
                # this loop heartbeats until the helper runs (its start takes tens of ms)
                if (heartbeat and (helper is None or not helper.wait_ready(0.0))
                        and time.monotonic() >= nxt):
                    self.send(0, 0x02, b"\x00")
                    nxt = time.monotonic() + 0.01
                new = self.parser.feed(self.port.read(4096))
                self.others.extend(new)
                if until is not None and any(until(f) for f in new):
                    return
        finally:
            if own is not None:
                own.stop()

    def close(self) -> None:
        self._close()


def open_raw(backend: str) -> RawLink:
    """A :class:`RawLink` to a just powered-up device of ``backend`` (close it)."""
    if backend in ("emulator", "emulator-c"):
        import experiments.emulators.thermocue  # noqa: F401  (registers emulator:// with pyserial)
        port = serial.serial_for_url(URLS[backend], timeout=0.01)
        link = RawLink(port, port.close)
    else:
        from experiments.display.thermocue.qemu_firmware import (await_link, build_image,
                                                                 raise_io_thread, start_qemu,
                                                                 stop_qemu)
        proc, pty = start_qemu(build_image())
        port = serial.Serial(pty, 115200, timeout=0.01)

        def close():
            port.close()
            stop_qemu(proc)
        try:
            await_link(port, pty)
        except BaseException:
            close()
            raise
        # as the display's runner does once the firmware answers (QemuFirmwareDisplay.open):
        # QEMU's event loop raised, so that a loaded machine does not hold the pty's bytes
        # back from the guest while its clock runs on (a spurious watchdog trip)
        raise_io_thread(proc.pid)
        link = RawLink(port, close)
    return link


@pytest.fixture
def raw(backend):
    link = open_raw(backend)
    yield link
    link.close()


@pytest.fixture
def open_raw_link():
    """:func:`open_raw` for a test that opens both backends itself (the fuzz)."""
    return open_raw
