"""A whole short session on the reference firmware under QEMU.

``thermocue run`` (a real subprocess) with the console responder answered from a pipe, on
``qemu-firmware://`` (the firmware's sim image: the emulated finger presses through SIM_FINGER,
the emulated sample through SIM_SAMPLE), a protocol of four trials: two real (record mode), two
simulated (playback). Every trial must be delivered (``ok``), the simulated ones within the
protocol's tracking limit, and the log must name the firmware it ran on.
"""
from __future__ import annotations

import csv
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PROTOCOL = Path(__file__).with_name("data") / "qemu_session.toml"
P01 = ROOT / "participants" / "examples" / "P01.json"

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(shutil.which("qemu-system-arm") is None,
                       reason="qemu-system-arm is not installed here (CI installs it with "
                              "scripts/setup); the session on the firmware is not run"),
]


def test_four_trial_session_on_the_firmware_under_qemu(tmp_path):
    from experiments.display.thermocue.qemu_firmware import build_image
    build_image()                      # once, outside the session's own time
    data = tmp_path / "data"
    res = subprocess.run(
        [sys.executable, "-m", "experiments", "run", str(PROTOCOL), "--participant", str(P01),
         "--display", "qemu-firmware://", "--responder", "console", "--data", str(data),
         "--seed", "5", "--session", "S01", "--quiet"],
        input="1\n" * 100, capture_output=True, text=True, timeout=240, cwd=ROOT)
    assert res.returncode == 0, res.stderr[-3000:]
    assert "Traceback" not in res.stderr
    session = data / "P01" / "S01"
    with open(session / "trials.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    completed = [r for r in rows if r["status"] == "ok"]
    why = [(r["trial_index"], r["status"], r.get("fault_code")) for r in rows], res.stderr[-2000:]
    assert sorted(int(r["trial_index"]) for r in completed) == [1, 2, 3, 4], why
    assert sorted(r["mode"] for r in completed) == ["real", "real", "simulated", "simulated"]
    for r in completed:
        assert int(r["frames_lost"]) == 0 and int(r["frames"]) > 50, (r, why)
        assert float(r["contact_force_N"]) >= 2.0 - 0.05
        if r["mode"] == "simulated":
            assert float(r["tracking_max_C"]) < 1.0          # [simulation] default limit
    events = [json.loads(line) for line in (session / "events.jsonl").read_text().splitlines()]
    opened = next(e for e in events if e["event"] == "display_opened")
    assert opened["firmware"].startswith("thermocue-fw")
    assert opened["device_id"] == "THERMOCUE-SIM-F405"
    assert events[-1]["event"] == "session_finished"
    # session.json names the device and the image it ran: the sim image's build id
    built = json.loads((ROOT / "firmware" / "out" / "build.json").read_text())
    (shown,) = json.loads((session / "session.json").read_text())["displays"]
    assert shown["device_id"] == "THERMOCUE-SIM-F405" and shown["url"] == "qemu-firmware://"
    assert shown["image_id"] == built["thermocue-sim"]["image_id"] == opened["image_id"]
