"""``firmware/flash``: picks a flasher or says none is here; builds, verifies, flashes, reads
back, then runs ``thermocue check PORT``.

No ST-Link or DFU device is attached here, so the flashing runs use a stand-in ``st-flash`` on
``PATH`` that keeps the "flash" in a file (and one that corrupts the read-back); the script's
own steps around it (tool choice, build, manifest check, read-back comparison, the hand-over to
``thermocue check``) are the real ones, on a copy of ``firmware/``.
"""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
FIRMWARE = ROOT / "firmware"

FAKE_ST_FLASH = """#!/bin/sh
# stand-in st-flash: the board's flash is the file $FLASH_STATE
echo "st-flash $*" >>"$FLASH_LOG"
case $1 in
  write) cp "$2" "$FLASH_STATE" ;;
  read) cp "$FLASH_STATE" "$2"; [ -n "${FLASH_CORRUPT:-}" ] && printf 'X' | dd of="$2" bs=1 seek=64 conv=notrunc 2>/dev/null ;;
  reset) ;;
esac
exit 0
"""
FAKE_THERMOCUE = """#!/bin/sh
echo "thermocue $*" >>"$FLASH_LOG"
exit 0
"""


def tools_dir(tmp_path: Path, *names) -> Path:
    """A PATH folder with only the basic tools the script needs (no flasher)."""
    d = tmp_path / "bin"
    d.mkdir(exist_ok=True)
    for name in names:
        os.symlink(shutil.which(name), d / name)
    return d


def run_flash(script: Path, *args, path: str, env=None) -> subprocess.CompletedProcess:
    return subprocess.run(["/bin/sh", str(script), *args], capture_output=True, text=True,
                          timeout=300, env={**os.environ, "PATH": path, **(env or {})})


def test_no_flasher_is_one_line_and_a_failure(tmp_path):
    bin_ = tools_dir(tmp_path, "dirname")
    res = run_flash(FIRMWARE / "flash", "/dev/ttyUSB0", path=str(bin_))
    assert res.returncode == 1
    assert res.stderr == ("firmware/flash: no flasher found: install st-flash (Debian: "
                          "stlink-tools), openocd or dfu-util\n")


@pytest.mark.parametrize("args,why", [
    ((), "expected the host link's PORT"),
    (("/dev/ttyUSB0", "--tool", "avrdude"), "expected st-flash, openocd or dfu-util, got avrdude"),
    (("/dev/ttyUSB0", "--tool", "dfu-util"), "dfu-util is not installed"),
])
def test_bad_arguments_are_one_line(tmp_path, args, why):
    bin_ = tools_dir(tmp_path, "dirname")
    res = run_flash(FIRMWARE / "flash", *args, path=str(bin_))
    assert res.returncode in (1, 2) and why in res.stderr and res.stderr.count("\n") == 1


@pytest.fixture
def firmware_copy(tmp_path):
    if shutil.which("arm-none-eabi-gcc") is None:
        pytest.skip("gcc-arm-none-eabi is not installed here (scripts/setup installs it)")
    fw = tmp_path / "firmware"
    shutil.copytree(FIRMWARE / "src", fw / "src")
    for f in ("build", "flash"):
        shutil.copy2(FIRMWARE / f, fw / f)
    fake = tmp_path / "fake"
    fake.mkdir()
    for name, text in (("st-flash", FAKE_ST_FLASH), ("thermocue", FAKE_THERMOCUE)):
        (fake / name).write_text(text)
        (fake / name).chmod(0o755)
    env = {"FLASH_STATE": str(tmp_path / "flash.img"), "FLASH_LOG": str(tmp_path / "log"),
           "THERMOCUE_FW_OUT": "out"}
    return fw, f"{fake}:{os.environ['PATH']}", env


@pytest.mark.slow
def test_flash_builds_verifies_flashes_reads_back_then_runs_check(firmware_copy, tmp_path):
    fw, path, env = firmware_copy
    res = run_flash(fw / "flash", "/dev/ttyUSB7", path=path, env=env)
    assert res.returncode == 0, res.stderr
    log = (tmp_path / "log").read_text().splitlines()
    assert log == ["st-flash write out/thermocue-board.bin 0x08000000",
                   f"st-flash read {log[1].split()[2]} 0x08000000 "
                   f"{(fw / 'out' / 'thermocue-board.bin').stat().st_size}",
                   "st-flash reset", "thermocue check --help", "thermocue check /dev/ttyUSB7"]
    assert (tmp_path / "flash.img").read_bytes() == (fw / "out" / "thermocue-board.bin").read_bytes()
    assert "verified (build.json" in res.stdout and "flashed and verified image" in res.stdout


@pytest.mark.slow
def test_a_read_back_that_differs_stops_before_check(firmware_copy, tmp_path):
    fw, path, env = firmware_copy
    res = run_flash(fw / "flash", "/dev/ttyUSB7", path=path, env={**env, "FLASH_CORRUPT": "1"})
    assert res.returncode == 1
    assert "read back differs from out/thermocue-board.bin" in res.stderr
    assert "thermocue check" not in (tmp_path / "log").read_text()
