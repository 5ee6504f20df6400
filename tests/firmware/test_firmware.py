"""The reference firmware (``firmware/``): its build, its core's unit checks, its board image.

The core's own checks (``firmware/tests/host_test.c``) run with this machine's C compiler; the
MCU images build with Debian's ``gcc-arm-none-eabi`` with every warning an error and must fit
the STM32F405 (1 MiB flash, 128 KiB SRAM); the board image, run under QEMU where no sensor is
wired, must shake hands and refuse to heat (a latched sensor fault). The protocol itself is
checked on the sim image by ``tests/conformance``.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import time
from pathlib import Path

import pytest
import serial

from experiments.display.thermocue import messages as m

FIRMWARE = Path(__file__).resolve().parents[2] / "firmware"
NO_ARM_GCC = shutil.which("arm-none-eabi-gcc") is None
NO_QEMU = shutil.which("qemu-system-arm") is None


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler (scripts/setup installs gcc)")
def test_core_unit_checks_pass_on_the_host():
    res = subprocess.run([str(FIRMWARE / "build"), "--host-test"], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stdout + res.stderr
    checks, failures = map(int, re.search(r"(\d+) checks, (\d+) failures", res.stdout).groups())
    assert checks >= 30 and failures == 0


@pytest.mark.skipif(NO_ARM_GCC, reason="arm-none-eabi-gcc is not installed here (CI installs "
                                       "gcc-arm-none-eabi with scripts/setup)")
def test_images_build_warning_free_and_fit_the_mcu(tmp_path):
    env = dict(os.environ, THERMOCUE_FW_OUT=str(tmp_path))
    res = subprocess.run([str(FIRMWARE / "build")], capture_output=True, text=True, env=env,
                         timeout=300)
    assert res.returncode == 0, res.stderr
    sizes = {}
    for line in res.stdout.splitlines():
        parts = line.split()
        if len(parts) == 6 and parts[5].endswith(".elf"):
            text, data, bss = map(int, parts[:3])
            sizes[Path(parts[5]).name] = (text + data, data + bss)
    assert set(sizes) == {"thermocue-board.elf", "thermocue-sim.elf"}
    for flash, ram in sizes.values():
        assert flash <= 1024 * 1024 and ram <= 128 * 1024
    for img in ("board", "sim"):
        assert (tmp_path / f"thermocue-{img}.bin").stat().st_size > 1000


@pytest.mark.skipif(NO_QEMU, reason="qemu-system-arm is not installed here (CI installs it "
                                    "with scripts/setup)")
def test_board_image_without_sensors_refuses_to_heat():
    """QEMU wires no thermistor: the board image must shake hands, latch a sensor fault with
    the relay open, and refuse ARM (FAULT_LATCHED)."""
    from experiments.display.thermocue.framing import FrameParser, encode_frame
    from experiments.display.thermocue.handshake import decode_hello
    from experiments.display.thermocue.qemu_firmware import (BOARD_IMAGE, await_link, stop_qemu, build_image,
                                                    start_qemu)
    build_image(BOARD_IMAGE)
    proc, pty = start_qemu(BOARD_IMAGE)
    port = serial.Serial(pty, 115200, timeout=0.01)
    try:
        await_link(port, pty)
        parser = FrameParser()

        def command(seq, cmd, payload=b""):
            port.write(encode_frame(seq, cmd, payload))
            deadline = time.monotonic() + 1.0
            while time.monotonic() < deadline:
                for fr in parser.feed(port.read(4096)):
                    if fr.seq == seq and fr.type in (cmd | 0x80, 0xFF) and not (
                            fr.type in (0xA0, 0xA1) and len(fr.payload) not in (0, 4)):
                        return fr
            raise AssertionError(f"no reply to {cmd!r}")

        hello = command(1, m.Cmd.HELLO, m.HELLO_REQ.pack(2))
        assert hello.type == 0x81
        info = decode_hello(hello.payload, pty)           # the host's checks of every field
        assert info.device_id == "THERMOCUE-F405" and "sim" not in info.capabilities
        # the image id in HELLO is the linker's build id that firmware/build put in build.json
        built = json.loads((BOARD_IMAGE.parent / "build.json").read_text())
        assert info.image_id == built["thermocue-board"]["image_id"] and len(info.image_id) == 40
        st = m.Status.decode(command(2, m.Cmd.STATUS).payload)
        assert st.state == "FAULT" and st.last_fault in ("SENSOR_FAILURE", "SENSOR_STUCK",
                                                         "OVER_TEMPERATURE")
        nak = command(3, m.Cmd.ARM, m.ARM.pack(1, 200, 5000))
        assert nak.type == 0xFF and m.NAK_HEAD.unpack_from(nak.payload)[1] == m.Err.FAULT_LATCHED
        nak = command(4, m.Cmd.SIM_FINGER, b"{}")
        assert nak.type == 0xFF and m.NAK_HEAD.unpack_from(nak.payload)[1] == m.Err.NOT_SUPPORTED
    finally:
        port.close()
        stop_qemu(proc)
