"""The reference C firmware (``firmware/``) run as its real binary under ``qemu-system-arm``.

``qemu-firmware://[?image=PATH][&build=1|0]`` starts QEMU's ``netduinoplus2`` machine (an
STM32F405, the firmware's MCU) with the firmware image, its USART1 on a pseudo-terminal, and
talks to it with the thermocue protocol's own driver (:class:`~.driver.ThermalDisplay`): the
handshake, the heartbeat, trials, everything as on a board. QEMU has no Peltier, so the default
image is the firmware's *simulation* build (``firmware/out/thermocue-sim.elf``: the same core
with a pad plant and a scripted finger behind its hardware layer, capability ``"sim"``);
``image=firmware/out/thermocue-board.elf`` runs the board's image, whose sensors read what
QEMU's ADC model gives (it trips a sensor fault, as a board with nothing wired would).

The image is built with ``firmware/build`` when it is missing or older than the firmware's
sources (``build=0``: never). QEMU is killed when the display closes. The firmware's clock is
a hardware timer that QEMU runs at host real time: trials take their real duration.
"""
from __future__ import annotations

import contextlib
import os
import re
import shutil
import subprocess
import sys
import threading
import time
import urllib.parse
import weakref
from pathlib import Path

import serial

from experiments.errors import DisplayError, UserInputError

from ..base import Capabilities, handshake_or_close, open_serial_port
from ..children import popen_tied
from .driver import ThermalDisplay
from .firmware_image import check_image, image_id_warning

__all__ = ["QemuFirmwareDisplay", "FIRMWARE_DIR", "SIM_IMAGE", "BOARD_IMAGE", "build_image",
           "start_qemu", "await_link", "raise_io_thread", "stop_qemu", "parse_url"]

FIRMWARE_DIR = Path(__file__).resolve().parents[3] / "firmware"
SIM_IMAGE = FIRMWARE_DIR / "out" / "thermocue-sim.elf"
BOARD_IMAGE = FIRMWARE_DIR / "out" / "thermocue-board.elf"
QEMU = "qemu-system-arm"
ARM_CC = "arm-none-eabi-gcc"
URL_GRAMMAR = "qemu-firmware://[?image=PATH][&build=1|0]"
#: How long QEMU may take to say which pseudo-terminal it opened, s.
START_TIMEOUT_S = 20.0
#: The driver's wait for a reply under QEMU, s (the driver's default, 0.25 s, suits a board).
QEMU_REPLY_TIMEOUT_S = 3.0
#: The host's heartbeat period under QEMU, s (the driver's default, 10 ms, suits a board).
QEMU_HEARTBEAT_S = 0.02
_PTY_LINE = re.compile(r"char device redirected to (\S+)")


def parse_url(url: str) -> dict:
    """Options of a ``qemu-firmware://`` URL: ``image`` (Path or None), ``build`` (bool).

    Raises
    ------
    UserInputError
        Another scheme, an unknown option or a bad value (names the option).
    """
    parts = urllib.parse.urlsplit(str(url))
    if parts.scheme != "qemu-firmware":
        raise UserInputError(f"display: {url!r}: expected {URL_GRAMMAR}")
    if parts.netloc or parts.path not in ("", "/"):
        raise UserInputError(f"display: {url!r}: expected {URL_GRAMMAR} (nothing before '?')")
    opts = {"image": None, "build": True}
    for key, values in urllib.parse.parse_qs(parts.query, keep_blank_values=True).items():
        value = values[-1]
        if key == "image":
            if not value:
                raise UserInputError(f"display: {url!r}: option image: expected a path")
            opts["image"] = Path(value)
        elif key == "build":
            if value not in ("0", "1"):
                raise UserInputError(f"display: {url!r}: option build: expected 0 or 1, "
                                     f"got {value!r}")
            opts["build"] = value == "1"
        else:
            raise UserInputError(f"display: {url!r}: unknown option {key!r}; expected "
                                 f"{URL_GRAMMAR}")
    return opts


def _sources_newer(image: Path) -> bool:
    t = image.stat().st_mtime
    for p in (FIRMWARE_DIR / "src").rglob("*"):
        if p.is_file() and p.stat().st_mtime > t:
            return True
    return (FIRMWARE_DIR / "build").stat().st_mtime > t


def _lock_file(fh) -> None:
    """An exclusive lock on ``fh`` where the system has ``fcntl`` (POSIX); else none."""
    with contextlib.suppress(ImportError):
        import fcntl
        fcntl.flock(fh, fcntl.LOCK_EX)


def build_image(image: Path = SIM_IMAGE, force: bool = False) -> Path:
    """Build the firmware images with ``firmware/build`` if ``image`` is missing or stale.

    A lock file serialises concurrent builds (two test processes, two sessions).

    Raises
    ------
    DisplayError
        The toolchain is missing or the build failed (gcc's error line quoted).
    """
    image = Path(image)
    if image.exists() and not force and not _sources_newer(image):
        return image
    if shutil.which(ARM_CC) is None:
        raise DisplayError(f"display: qemu-firmware: {image} is missing or stale and {ARM_CC} is "
                           f"not installed (scripts/setup installs gcc-arm-none-eabi)")
    out = FIRMWARE_DIR / "out"
    out.mkdir(exist_ok=True)
    with open(out / ".build.lock", "w") as lock:
        _lock_file(lock)
        if image.exists() and not force and not _sources_newer(image):
            return image
        res = subprocess.run([str(FIRMWARE_DIR / "build")], capture_output=True, text=True)
    if res.returncode != 0 or not image.exists():
        # firmware/build ends a failure with one line that quotes gcc's first ``error:`` line
        lines = (res.stderr or res.stdout).strip().splitlines() or ["(no output)"]
        raise DisplayError(f"display: qemu-firmware: {lines[-1]}")
    return image


def start_qemu(image: Path) -> tuple:
    """Start QEMU's netduinoplus2 with ``image``, USART1 on a pty; return ``(process, pty)``.

    Raises
    ------
    DisplayError
        QEMU is missing, exits, or names no pty within :data:`START_TIMEOUT_S`.
    """
    exe = shutil.which(QEMU)
    if exe is None:
        raise DisplayError(f"display: qemu-firmware: {QEMU} is not installed "
                           f"(scripts/setup installs qemu-system-arm)")
    # tied to this process: a host killed with SIGKILL or SIGHUP takes QEMU with it
    proc = popen_tied([exe, "-M", "netduinoplus2", "-nographic", "-kernel", str(image),
                       "-serial", "pty", "-monitor", "none"],
                      stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                      stderr=subprocess.STDOUT, text=True, start_new_session=True)
    found: list = []
    lines: list = []

    def read():
        for line in proc.stdout:            # QEMU's own messages; the pty line comes first
            lines.append(line.strip())
            m = _PTY_LINE.search(line)
            if m and not found:
                found.append(m.group(1))
        proc.stdout.close()

    threading.Thread(target=read, name="qemu-output", daemon=True).start()
    deadline = time.monotonic() + START_TIMEOUT_S
    while not found and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    proc.output_lines = lines               # what QEMU said (a refused image's reason)
    if not found:
        stop_qemu(proc)
        said = " | ".join(lines[-3:]) or "nothing"
        raise DisplayError(f"display: qemu-firmware: {QEMU} named no pseudo-terminal "
                           f"(it said: {said})")
    return proc, found[0]


def raise_io_thread(pid: int) -> bool:
    """Give QEMU's main thread -- its event loop, which carries the pty's bytes into the
    USART -- nice −10 (when the user has the right; else it stays as it is). Return whether
    it did.

    Why: the guest's clock (QEMU's timer) runs while QEMU's vCPU thread runs; the sim image
    pauses it only while that thread is held off. QEMU's model of the USART takes one byte
    per turn of the event loop, so a heartbeat frame needs ten turns; on a loaded machine the
    event loop waited for a core while the vCPU thread ran on, and the guest saw host silence
    that was only bytes waiting in the pty (a spurious watchdog trip). Not real-time
    priority: the event loop also runs QEMU's timers (the guest's 1 kHz SysTick) and, given
    a core of its own, used about half of it (measured); under ``SCHED_RR`` it starved the
    host itself. Call this once the firmware answers (the vCPU thread exists): Linux applies
    it to the one thread (the main thread's TID is the PID), not to the vCPU thread.
    """
    try:
        if os.getpriority(os.PRIO_PROCESS, pid) > -10:
            os.setpriority(os.PRIO_PROCESS, pid, -10)
        return True
    except (AttributeError, OSError):
        return False


#: How long QEMU may take to notice that the pty has a reader, s.
LINK_TIMEOUT_S = 10.0


def await_link(port, pty: str) -> None:
    """Wait until the firmware's answers come through the pty.

    QEMU polls a pty for a reader about once a second and drops what the guest sends until it
    has seen one, so the first commands after opening may go unanswered. STATUS (carried out
    before any HELLO, no side effects) is asked every 50 ms until a reply arrives.

    Raises
    ------
    DisplayError
        No reply within :data:`LINK_TIMEOUT_S`.
    """
    from .framing import FrameParser, encode_frame
    from .messages import Cmd
    parser = FrameParser()
    deadline = time.monotonic() + LINK_TIMEOUT_S
    seq = 0
    while time.monotonic() < deadline:
        seq = (seq + 1) & 0xFF
        port.write(encode_frame(seq, Cmd.STATUS))
        end = time.monotonic() + 0.05
        while time.monotonic() < end:
            for fr in parser.feed(port.read(4096)):
                if fr.type == Cmd.STATUS | 0x80:
                    return
    raise DisplayError(f"display: qemu-firmware: {pty}: the firmware did not answer STATUS "
                       f"within {LINK_TIMEOUT_S:g} s")


def stop_qemu(proc) -> None:
    """End a QEMU process started by :func:`start_qemu` (SIGTERM, then SIGKILL after 3 s)."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=3)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=3)


class QemuFirmwareDisplay(ThermalDisplay, scheme="qemu-firmware"):
    """The C firmware under QEMU, through the thermocue protocol's driver.

    Open it with ``open_display("qemu-firmware://")`` (or :meth:`open`); ``close()`` ends QEMU.
    Everything else is :class:`~.driver.ThermalDisplay`'s: this class adds only the process.

    Attributes
    ----------
    qemu : subprocess.Popen
        The QEMU process (ended by :meth:`close`, or when the display is garbage-collected).
    image : Path
        The firmware image QEMU runs.
    pty : str
        The pseudo-terminal of the firmware's USART1.
    """

    description = "the reference C firmware (firmware/) as its real binary under qemu-system-arm"
    _probe_text = False    # the firmware this class started, never a TCS II
    url_grammar = URL_GRAMMAR
    example_urls = (("qemu-firmware://", "Thermal display firmware under QEMU"),)
    #: Whether QEMU's event loop got nice −10 (:func:`raise_io_thread`).
    io_raised = False

    @classmethod
    def check_url(cls, url: str) -> None:
        parse_url(url)

    @classmethod
    def open(cls, url: str = "qemu-firmware://", limits=None, **options) -> "QemuFirmwareDisplay":
        """Build the image if needed, start QEMU, shake hands, start the heartbeat.

        Parameters
        ----------
        url : str
            ``qemu-firmware://[?image=PATH][&build=1|0]``.
        limits : SafetyLimits, optional
        **options
            The keyword arguments of :class:`~.driver.ThermalDisplay`.

        Raises
        ------
        UserInputError
            A malformed URL.
        DisplayError
            QEMU or the toolchain is missing, the build failed, or the handshake failed.
        """
        opts = parse_url(url)
        image = opts["image"] or SIM_IMAGE
        if opts["build"] and opts["image"] is None:
            image = build_image(image)
        check_image(image)        # one line naming an empty, garbage or changed image
        options.pop("baudrate", None)
        # QEMU hands the USART one byte per turn of its event loop: about 2.6 kB/s measured
        # here (a 512-sample chunk frame, 1042 bytes, is answered after ~0.4 s, more on a
        # loaded machine), slower than the board's 115200 baud; nothing is lost on the pty
        options.setdefault("reply_timeout_s", QEMU_REPLY_TIMEOUT_S)
        # ... and on a loaded host that rate falls to that of the heartbeats (1.3 kB/s measured
        # at a load average of 19 on 2 cores, against 1 kB/s of heartbeats every 10 ms), after
        # which commands queue behind heartbeats (replies seen 1.4 s late); every 20 ms is four
        # heartbeats within the device's 90 ms watchdog and leaves the link 60 % of that rate
        options.setdefault("heartbeat_s", QEMU_HEARTBEAT_S)
        proc, pty = start_qemu(Path(image))
        try:
            # exclusive, as every serial port: a second program on the firmware's pty (another
            # session, `thermocue clear-fault PTY`) could set its neutral or limits under ours
            port = open_serial_port(pty, 115200)
        except DisplayError as exc:
            stop_qemu(proc)
            raise DisplayError(f"display: qemu-firmware: {str(exc).removeprefix('display: ')}") from exc
        disp = cls(port, limits, **options)
        disp.qemu, disp.image, disp.pty = proc, Path(image), pty
        disp._finalizer = weakref.finalize(disp, stop_qemu, proc)
        try:
            try:
                await_link(port, pty)
            except (serial.SerialException, OSError, DisplayError) as exc:
                if proc.poll() is None and isinstance(exc, DisplayError):
                    raise
                # QEMU named its pty, then exited: an image it cannot load (the pty vanished
                # under pyserial's read)
                with contextlib.suppress(subprocess.TimeoutExpired):
                    proc.wait(timeout=3)
                said = next((ln for ln in proc.output_lines if "qemu" in ln.lower()
                             and "redirected" not in ln), f"exit status {proc.returncode}")[:200]
                raise DisplayError(f"display: qemu-firmware: {image}: QEMU could not run it "
                                   f"(not a firmware image?): {said}") from None
        except BaseException:
            disp._finalizer()
            try:
                port.close()
            except Exception:
                pass
            raise
        # the firmware answered: QEMU's threads exist; only its event loop is raised
        disp.io_raised = raise_io_thread(proc.pid)
        # never a boot banner: bytes sent before we opened are lost
        handshake_or_close(disp, port, on_failure=disp._finalizer)
        disp.start_heartbeat()
        warning = image_id_warning(FIRMWARE_DIR / "out" / "build.json", disp.info.image_id,
                                   f"qemu-firmware ({Path(image).name})")
        if warning:
            print(warning, file=sys.stderr)
        return disp

    @classmethod
    def availability(cls) -> tuple:
        """Whether QEMU and the toolchain (or a built image) are here; else why not."""
        if shutil.which(QEMU) is None:
            return False, f"{QEMU} is not installed (scripts/setup installs qemu-system-arm)"
        if not SIM_IMAGE.exists() and shutil.which(ARM_CC) is None:
            return False, (f"no firmware image at {SIM_IMAGE} and no {ARM_CC} to build it "
                           f"(scripts/setup installs gcc-arm-none-eabi)")
        return True, ""

    @classmethod
    def declared_capabilities(cls):
        """The firmware's compile-time limits (``firmware/src/core/config.h``)."""
        return Capabilities(contact_detection="force", force_sensing=True, telemetry_hz=100.0,
                            max_profile_points=32768, min_profile_step_s=0.001,
                            safe_range_C=(10.0, 44.5), max_rate_C_per_s=100.0,
                            modes=("playback", "record"), scripted_bench=True,
                            notes="the firmware's sim image (pad plant, scripted finger) under "
                                  "QEMU, emulated real time; faults: overtemp, stuck_sensor, "
                                  "sensor_range, reboot")

    def close(self) -> None:
        """Return to neutral (best effort), close the port, end QEMU."""
        try:
            super().close()
        finally:
            fin = getattr(self, "_finalizer", None)
            if fin is not None:
                fin()

