"""The ``qemu-firmware://`` backend: its URL, its availability, QEMU's lifetime.

The protocol behaviour of the firmware it runs is the conformance suite's
(``tests/conformance``); these tests check the backend's own promises.
"""
from __future__ import annotations

import os
import shutil

import pytest

from experiments.errors import DisplayError, UserInputError
from experiments.display.thermocue.qemu_firmware import QemuFirmwareDisplay, parse_url
from experiments.display.registry import backend_for

NO_QEMU = shutil.which("qemu-system-arm") is None


def test_registered_for_its_scheme():
    assert backend_for("qemu-firmware://") is QemuFirmwareDisplay


@pytest.mark.parametrize("url, field", [
    ("qemu-firmware://?bogus=1", "bogus"),
    ("qemu-firmware://?build=2", "build"),
    ("qemu-firmware://?image=", "image"),
    ("qemu-firmware://host/x", "nothing before"),
])
def test_bad_url_names_the_option(url, field):
    with pytest.raises(UserInputError, match=field):
        QemuFirmwareDisplay.check_url(url)


def test_url_options():
    assert parse_url("qemu-firmware://") == {"image": None, "build": True}
    opts = parse_url("qemu-firmware://?image=/tmp/x.elf&build=0")
    assert str(opts["image"]) == "/tmp/x.elf" and opts["build"] is False


def test_unavailable_without_qemu_says_why(monkeypatch, tmp_path):
    monkeypatch.setenv("PATH", str(tmp_path))          # an empty folder: no QEMU on the path
    ok, reason = QemuFirmwareDisplay.availability()
    assert not ok and "qemu-system-arm" in reason


def test_missing_image_is_one_line_naming_it(tmp_path):
    path = tmp_path / "none.elf"
    with pytest.raises(DisplayError, match="none.elf"):
        QemuFirmwareDisplay.open(f"qemu-firmware://?image={path}")


@pytest.mark.skipif(NO_QEMU, reason="qemu-system-arm is not installed here (CI installs it with "
                                    "scripts/setup)")
def test_close_ends_qemu():
    from experiments.display import open_display
    disp = open_display("qemu-firmware://")
    proc = disp.qemu
    assert proc.poll() is None and disp.info.firmware.startswith("thermocue-fw")
    disp.close()
    assert proc.poll() is not None


def _may_raise_priority() -> bool:
    """Whether this user may set nice −10 (CAP_SYS_NICE): tried on a child of its own."""
    import subprocess
    import sys
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        os.setpriority(os.PRIO_PROCESS, child.pid, -10)
        return True
    except OSError:
        return False
    finally:
        child.kill()
        child.wait()


@pytest.mark.skipif(NO_QEMU, reason="qemu-system-arm is not installed here (CI installs it with "
                                    "scripts/setup)")
def test_only_qemus_event_loop_is_raised():
    """QEMU's event loop (its main thread) carries the pty's bytes into the USART: it gets
    nice −10 where allowed; the vCPU thread (the guest's busy loop) keeps the default."""
    from experiments.display import open_display
    disp = open_display("qemu-firmware://")
    try:
        pid = disp.qemu.pid
        nice = {int(tid): os.getpriority(os.PRIO_PROCESS, int(tid))
                for tid in os.listdir(f"/proc/{pid}/task")}
    finally:
        disp.close()
    assert disp.io_raised == _may_raise_priority()
    others = [n for tid, n in nice.items() if tid != pid]
    assert others and all(n == os.getpriority(os.PRIO_PROCESS, 0) for n in others), nice
    if disp.io_raised:
        assert nice[pid] == -10, nice
    else:
        assert nice[pid] == os.getpriority(os.PRIO_PROCESS, 0), nice


@pytest.mark.skipif(NO_QEMU, reason="qemu-system-arm is not installed here (CI installs it with "
                                    "scripts/setup)")
@pytest.mark.parametrize("content", [b"", b"hello, not an image\n", bytes(range(256)) * 12],
                         ids=["empty", "text", "binary junk"])
def test_an_image_qemu_cannot_run_is_one_line_naming_it(tmp_path, content):
    """QEMU names its pty, then exits on a file it cannot load: the pty vanished under the
    reader and pyserial raised SerialException (a traceback for the user)."""
    path = tmp_path / "bad.elf"
    path.write_bytes(content)
    with pytest.raises(DisplayError) as exc:
        QemuFirmwareDisplay.open(f"qemu-firmware://?image={path}")
    msg = str(exc.value)
    assert str(path) in msg and "\n" not in msg and len(msg) < 400
