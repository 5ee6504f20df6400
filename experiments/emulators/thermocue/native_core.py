"""The firmware's C core built for this machine and loaded with ctypes (one copy per device).

``firmware/build --native OUT.so`` compiles ``firmware/src/core`` (commands, reply store, state
machine, limits, watchdog, controller) with the native HAL ``firmware/src/native/hal_native.c``
into a shared library, as Zephyr's ``native_sim`` builds an application for the host. This
module builds it once per version of the sources (the file name carries their hash, so a stale
library is never loaded and two processes building at once each rename a whole file into
place) and loads one private copy per device: the core keeps its state in C statics, so two
devices in one process need two copies of the library.

:class:`NativeCore` is the ctypes face of one loaded copy; :mod:`.native_device` puts the pad's
physics, the finger and the fault injection around it.
"""
from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from experiments.errors import DisplayError

__all__ = ["FIRMWARE_DIR", "library_path", "build_library", "NativeCore", "BOARD_FN",
           "RELAY", "READY", "ARMED", "RECORD"]

FIRMWARE_DIR = Path(__file__).resolve().parents[3] / "firmware"
#: What the library is made of: the build script and every source it compiles.
_SOURCES = ("build", "src/core", "src/native")

#: flags of native_control / native_send (hal_native.c)
RELAY, READY, ARMED, RECORD = 1, 2, 4, 8

#: the board-command callback: (type, payload, len, reply, cap, core state, ready) -> n or -code
BOARD_FN = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int, ctypes.POINTER(ctypes.c_uint8),
                            ctypes.c_int, ctypes.POINTER(ctypes.c_uint8), ctypes.c_int,
                            ctypes.c_int, ctypes.c_int)


def _source_hash() -> str:
    h = hashlib.sha256()
    for rel in _SOURCES:
        p = FIRMWARE_DIR / rel
        files = sorted(p.rglob("*")) if p.is_dir() else [p]
        for f in files:
            if f.is_file():
                h.update(str(f.relative_to(FIRMWARE_DIR)).encode() + b"\0" + f.read_bytes())
    return h.hexdigest()[:16]


def library_path() -> Path:
    """Where the library of the current sources lives (``firmware/out/native/``, or
    ``$THERMOCUE_FW_OUT/native/``)."""
    out = Path(os.environ.get("THERMOCUE_FW_OUT", FIRMWARE_DIR / "out"))
    if not out.is_absolute():
        out = FIRMWARE_DIR / out
    return out / "native" / f"thermocue-core-{_source_hash()}.so"


def build_library() -> Path:
    """The library of the current sources, built with this machine's ``cc`` if missing.

    Raises
    ------
    DisplayError
        No C compiler, or the build failed (its first error line).
    """
    so = library_path()
    if so.is_file():
        return so
    if shutil.which("cc") is None:
        raise DisplayError("emulator: core=c needs a C compiler (cc) to build the firmware's "
                           "core (scripts/setup installs gcc)")
    try:
        so.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DisplayError(f"emulator: cannot create {so.parent}: {exc.strerror}") from None
    res = subprocess.run(["sh", str(FIRMWARE_DIR / "build"), "--native", str(so)],
                         capture_output=True, text=True)
    if res.returncode != 0 or not so.is_file():
        lines = (res.stderr or res.stdout).strip().splitlines()
        first = next((ln for ln in lines if "error" in ln), lines[-1] if lines else "no output")
        raise DisplayError(f"emulator: building the firmware's core failed: {first}")
    return so


class NativeCore:
    """One private copy of the firmware's core (see the module docstring).

    Parameters
    ----------
    board : callable
        Answers the board's sim commands: ``board(type, payload_ptr, len, reply_ptr, cap,
        core_state, ready) -> int`` (hal.h's ``hal_board_command``).
    """

    def __init__(self, board):
        self.path = so = build_library()
        fd, copy = tempfile.mkstemp(prefix="thermocue-core-", suffix=".so")
        try:
            with os.fdopen(fd, "wb") as dst, open(so, "rb") as src:
                shutil.copyfileobj(src, dst)
            # PyDLL: the GIL stays held (the calls are microseconds; the board callback is
            # Python), and no other thread runs between a step's calls
            self.lib = lib = ctypes.PyDLL(copy, mode=os.RTLD_LOCAL)
        finally:
            os.unlink(copy)                       # mapped: the file is no longer needed
        self._board = BOARD_FN(board)             # kept alive as long as the core
        lib.native_power_up.argtypes = [ctypes.c_uint32, ctypes.c_uint64, ctypes.c_char_p,
                                        ctypes.c_char_p, ctypes.c_int, BOARD_FN]
        lib.native_power_up.restype = ctypes.c_int
        f = ctypes.c_float
        lib.native_control.argtypes = [ctypes.c_uint64] + [f] * 9 + [ctypes.c_uint32]
        lib.native_control.restype = ctypes.c_int
        lib.native_send.argtypes = [ctypes.c_char_p, ctypes.c_size_t]
        lib.native_send.restype = ctypes.c_int
        lib.native_take.argtypes = [ctypes.c_void_p, ctypes.c_size_t]
        lib.native_take.restype = ctypes.c_size_t
        lib.native_pending.restype = ctypes.c_size_t
        lib.native_state.restype = ctypes.c_int
        lib.native_boot_id.restype = ctypes.c_uint32
        self.control = lib.native_control
        self.send = lib.native_send
        self.pending = lib.native_pending
        self.state = lib.native_state
        self.boot_id = lib.native_boot_id
        self._drive = ctypes.c_float.in_dll(lib, "native_drive")
        self._buf = ctypes.create_string_buffer(1 << 17)
        self._take = lib.native_take

    def power_up(self, seed: int, t_us: int, device_id: str, image_id: str, sim: bool) -> bool:
        """Power-up (or a reboot): the core's state afresh; False if its self-check failed."""
        return bool(self.lib.native_power_up(seed & 0xFFFFFFFF, t_us, device_id.encode(),
                                             image_id.encode(), int(sim), self._board))

    @property
    def drive(self) -> float:
        """The H-bridge drive the core last commanded, -1 (cooling) .. +1 (heating)."""
        return self._drive.value

    def take(self) -> bytes:
        """The device's bytes since the last call."""
        n = self._take(self._buf, len(self._buf))
        return ctypes.string_at(self._buf, n) if n else b""
