"""A firmware image is checked before QEMU or a flasher sees it; the device's image id against
the source tree's last build (``experiments/display/thermocue/firmware_image.py``)."""
from __future__ import annotations

import hashlib
import shutil
import json
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from experiments.display import open_display
from experiments.display.thermocue.firmware_image import BadImage, check_image, image_id_warning

ROOT = Path(__file__).resolve().parents[4]


def arm_elf(paddr=0x0800_0000, entry=0x0800_0101, machine=40, code=b"\x00" * 64) -> bytes:
    """A minimal 32-bit little-endian ARM executable: one PT_LOAD segment holding ``code``."""
    ehsize, phentsize = 52, 32
    ident = b"\x7fELF" + bytes([1, 1, 1]) + b"\x00" * 9
    head = struct.pack("<16sHHIIIIIHHHHHH", ident, 2, machine, 1, entry, ehsize, 0, 0x05000200,
                       ehsize, phentsize, 1, 0, 0, 0)
    phdr = struct.pack("<IIIIIIII", 1, ehsize + phentsize, paddr, paddr, len(code), len(code), 5, 4)
    return head + phdr + code


def test_a_minimal_arm_image_in_flash_is_accepted(tmp_path):
    img = tmp_path / "fw.elf"
    img.write_bytes(arm_elf())
    assert check_image(img) == img


BAD = {
    "empty": (b"", "the file is empty"),
    "garbage": (bytes(range(256)) * 4, "not an ELF file"),
    "raw-bin": (b"\x00\x00\x02\x20\x01\x01\x00\x08" * 32, "not an ELF file"),
    "x86": (arm_elf(machine=62), "not an ARM executable"),
    "not-in-flash": (arm_elf(paddr=0x2000_0000, entry=0x2000_0001), "no loadable segment"),
    "entry-outside": (arm_elf(entry=0x0000_0101), "entry point"),
    "cut-short": (arm_elf()[:70], "cut short"),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_a_bad_image_is_refused_in_one_line_naming_it(tmp_path, name):
    data, why = BAD[name]
    img = tmp_path / f"{name}.elf"
    img.write_bytes(data)
    with pytest.raises(BadImage) as exc:
        check_image(img)
    msg = str(exc.value)
    assert str(img) in msg and why in msg and "\n" not in msg


def test_a_missing_image_is_refused_naming_it(tmp_path):
    with pytest.raises(BadImage, match="no such file"):
        check_image(tmp_path / "nothing.elf")


def test_a_byte_changed_since_the_build_is_refused(tmp_path):
    data = arm_elf()
    img = tmp_path / "thermocue-sim.elf"
    img.write_bytes(data)
    (tmp_path / "build.json").write_text(json.dumps(
        {"thermocue-sim.elf": {"sha256": hashlib.sha256(data).hexdigest()}}))
    check_image(img)                                        # as built: accepted
    flipped = bytearray(data)
    flipped[-5] ^= 0x01
    img.write_bytes(bytes(flipped))
    with pytest.raises(BadImage, match="differs from its build.json"):
        check_image(img)


@pytest.mark.parametrize("name", ["empty", "garbage", "raw-bin"])
def test_qemu_firmware_refuses_a_bad_image_without_a_traceback(tmp_path, name):
    img = tmp_path / f"{name}.elf"
    img.write_bytes(BAD[name][0])
    with pytest.raises(BadImage, match=str(img)):
        open_display(f"qemu-firmware://?image={img}")


@pytest.mark.slow
def test_thermocue_run_names_a_garbage_image_in_one_line(tmp_path):
    img = tmp_path / "garbage.elf"
    img.write_bytes(BAD["garbage"][0])
    proto = ROOT / "tests" / "firmware" / "data" / "qemu_session.toml"
    res = subprocess.run(
        [sys.executable, "-m", "experiments", "run", str(proto), "--participant",
         str(ROOT / "participants" / "examples" / "P01.json"), "--display",
         f"qemu-firmware://?image={img}", "--data", str(tmp_path / "data"), "--quiet",
         "--responder", "console"], input="", capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert res.returncode != 0 and "Traceback" not in res.stderr
    assert f"firmware image {img}" in res.stderr, res.stderr[-2000:]


def test_the_device_image_id_is_compared_with_the_last_build(tmp_path):
    build = tmp_path / "build.json"
    assert image_id_warning(build, "abc", "/dev/ttyX") is None           # no build known
    build.write_text(json.dumps({"thermocue-board": {"image_id": "aa11"},
                                 "thermocue-sim": {"image_id": "bb22"},
                                 "thermocue-sim.elf": {"sha256": "00"}}))
    assert image_id_warning(build, "bb22", "/dev/ttyX") is None
    line = image_id_warning(build, "cc33", "/dev/ttyX")
    assert line.startswith("warning: display /dev/ttyX: the device runs image cc33")
    assert "aa11" in line and "bb22" in line and "\n" not in line


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("qemu-system-arm") is None or shutil.which("arm-none-eabi-gcc") is None,
                    reason="qemu-system-arm or gcc-arm-none-eabi is not installed here (scripts/setup "
                           "installs both; CI runs this)")
def test_qemu_firmware_warns_when_the_image_is_not_the_trees_last_build(tmp_path, capfd):
    from experiments.display.thermocue.qemu_firmware import FIRMWARE_DIR, build_image
    build_image()                                    # the tree's last build: firmware/out/build.json
    tree = json.loads((FIRMWARE_DIR / "out" / "build.json").read_text())
    other = tmp_path / "firmware"                    # another source tree: another version string
    shutil.copytree(FIRMWARE_DIR / "src", other / "src")
    shutil.copy2(FIRMWARE_DIR / "build", other / "build")
    config = other / "src" / "core" / "config.h"
    config.write_text(config.read_text().replace('"thermocue-fw 1.0.0"', '"thermocue-fw 0.9.9"'))
    subprocess.run([str(other / "build")], check=True, capture_output=True, timeout=300)
    image = other / "out" / "thermocue-sim.elf"
    capfd.readouterr()
    with open_display(f"qemu-firmware://?image={image}") as disp:
        assert disp.info.image_id not in {v["image_id"] for k, v in tree.items()
                                          if isinstance(v, dict) and "image_id" in v}
        err = capfd.readouterr().err
    (line,) = [x for x in err.splitlines() if x.startswith("warning:")]
    assert f"the device runs image {disp.info.image_id}" in line
    assert "not the source tree's last build" in line and tree["thermocue-sim"]["image_id"][:12] in line
    with open_display("qemu-firmware://") as disp:   # the tree's own image: no warning
        assert disp.info.image_id == tree["thermocue-sim"]["image_id"]
    assert "warning:" not in capfd.readouterr().err
