"""``firmware/build``: an interrupted build leaves a whole set, a mixed set is caught, and a gcc
error is quoted by its own ``error:`` line.

Each test builds a copy of ``firmware/`` (its sources and the script) in a temporary folder, so
the tree's own ``firmware/out`` is never touched.
"""
from __future__ import annotations

import hashlib
import json
import os
import random
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
FIRMWARE = ROOT / "firmware"

pytestmark = pytest.mark.skipif(shutil.which("arm-none-eabi-gcc") is None,
                                reason="gcc-arm-none-eabi is not installed here (scripts/setup "
                                       "installs it; CI runs these)")


def copy_firmware(dest: Path) -> Path:
    fw = dest / "firmware"
    shutil.copytree(FIRMWARE / "src", fw / "src")
    shutil.copy2(FIRMWARE / "build", fw / "build")
    return fw


def build(fw: Path, *args, timeout=300) -> subprocess.CompletedProcess:
    return subprocess.run([str(fw / "build"), *args], capture_output=True, text=True,
                          timeout=timeout, env={**os.environ, "THERMOCUE_FW_OUT": "out"})


def sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def build_id(elf: Path) -> str:
    out = subprocess.run(["arm-none-eabi-readelf", "-n", str(elf)], capture_output=True,
                         text=True, check=True).stdout
    return out.split("Build ID:")[1].split()[0]


def assert_whole_set(out: Path) -> str:
    """The set out/ points at agrees with itself; returns the board image's version string."""
    meta = json.loads((out / "build.json").read_text())
    for img in ("board", "sim"):
        elf, binf = out / f"thermocue-{img}.elf", out / f"thermocue-{img}.bin"
        again = out.parent / f"again-{img}.bin"
        subprocess.run(["arm-none-eabi-objcopy", "-O", "binary", str(elf), str(again)], check=True)
        assert again.read_bytes() == binf.read_bytes(), f"{img}: .bin is not its .elf"
        again.unlink()
        for ext in ("elf", "bin", "hex", "map"):
            f = out / f"thermocue-{img}.{ext}"
            assert sha(f) == meta[f"thermocue-{img}.{ext}"]["sha256"], f
        assert meta[f"thermocue-{img}"]["image_id"] == build_id(elf)
    data = (out / "thermocue-board.bin").read_bytes()
    return "new" if b"thermocue-fw 9.9.9" in data else "old"


@pytest.mark.slow
def test_an_interrupted_build_leaves_the_old_set_or_the_new_set_whole(tmp_path):
    fw = copy_firmware(tmp_path)
    t0 = time.monotonic()
    res = build(fw)
    full_s = time.monotonic() - t0          # a full build's time here, to spread the interruptions
    assert res.returncode == 0, res.stderr
    out = fw / "out"
    assert assert_whole_set(out) == "old"
    assert build(fw, "--verify").returncode == 0
    config = fw / "src" / "core" / "config.h"
    config.write_text(config.read_text().replace('"thermocue-fw 1.0.0"', '"thermocue-fw 9.9.9"'))
    rng = random.Random(33)
    for run in range(8):
        proc = subprocess.Popen([str(fw / "build")], stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL, start_new_session=True,
                                env={**os.environ, "THERMOCUE_FW_OUT": "out"})
        time.sleep(rng.uniform(0.0, full_s * 1.1))
        sig = signal.SIGKILL if run % 2 else signal.SIGINT
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            pass
        proc.wait(timeout=60)
        assert assert_whole_set(out) in ("old", "new"), run
        res = build(fw, "--verify")
        assert res.returncode == 0, (run, res.stderr)
    # leftovers of the interrupted builds go at the next build; at most the set before stays
    assert build(fw).returncode == 0 and assert_whole_set(out) == "new"
    assert len(list(out.glob(".build-*"))) <= 2


@pytest.mark.slow
@pytest.mark.parametrize("sig", ["INT", "TERM"])
def test_an_interruption_just_after_the_switch_keeps_the_new_set(tmp_path, sig):
    """The random interruptions above once landed between the rename of out/current and the
    clearing of the trap; the trap then deleted the set that had just become current. Here a
    ``mv`` earlier on PATH does the switch's rename with the real mv and then signals the
    build's process group, so the interruption lands at exactly that point every time."""
    fw = copy_firmware(tmp_path)
    assert build(fw).returncode == 0
    out = fw / "out"
    config = fw / "src" / "core" / "config.h"
    config.write_text(config.read_text().replace('"thermocue-fw 1.0.0"', '"thermocue-fw 9.9.9"'))
    shim = tmp_path / "shim"
    shim.mkdir()
    real_mv = shutil.which("mv")
    (shim / "mv").write_text(
        "#!/bin/sh\n"
        f'"{real_mv}" "$@" || exit $?\n'
        'case "$*" in *.current.tmp*) kill -' + sig + ' 0; sleep 5;; esac\n')
    (shim / "mv").chmod(0o755)
    res = subprocess.run([str(fw / "build")], capture_output=True, text=True, timeout=300,
                         env={**os.environ, "THERMOCUE_FW_OUT": "out",
                              "PATH": f"{shim}:{os.environ['PATH']}"},
                         start_new_session=True)
    assert res.returncode != 0                      # it was interrupted
    assert (out / "current").resolve().is_dir(), "the set out/current names was deleted"
    assert assert_whole_set(out) == "new"
    assert build(fw, "--verify").returncode == 0


@pytest.mark.slow
def test_verify_catches_a_mixed_set(tmp_path):
    fw = copy_firmware(tmp_path)
    assert build(fw).returncode == 0
    out = fw / "out"
    current = out / "current"
    target = current.resolve() / "thermocue-board.bin"
    data = bytearray(target.read_bytes())
    data[100] ^= 0xFF                           # an old .bin beside a new .elf looks like this
    target.write_bytes(bytes(data))
    res = build(fw, "--verify")
    assert res.returncode == 1
    assert "thermocue-board.bin does not match build.json" in res.stderr
    (current.resolve() / "build.json").unlink()
    res = build(fw, "--verify")
    assert res.returncode == 1 and "build.json is missing" in res.stderr


@pytest.mark.slow
def test_a_gcc_error_is_quoted_by_its_error_line(tmp_path):
    fw = copy_firmware(tmp_path)
    proto = fw / "src" / "core" / "proto.c"
    proto.write_text(proto.read_text() + "\nint thermocue_broken(void) { return undeclared_name; }\n")
    res = build(fw)
    assert res.returncode != 0
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith("firmware/build: board image failed: "), res.stderr[-2000:]
    assert "src/core/proto.c:" in last and "error:" in last and "undeclared_name" in last
    assert not (fw / "out" / "current").exists()            # nothing switched
    assert not list((fw / "out").glob(".build-*"))          # and nothing left behind
