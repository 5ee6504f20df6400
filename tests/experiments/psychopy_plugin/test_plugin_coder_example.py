"""The Coder example (docs/examples/thermal_cue_coder.py) under Xvfb against the pty emulator.

Run as a user would (``--display <pty> --dry-run``); xdotool answers after each contact the
emulator logs. PsychoPy's data file must hold the answers and the thermal columns, and the
emulator's log must show each profile started at contact and stopped by the example.
"""
from __future__ import annotations

import csv
import shutil
import subprocess
import sys
import time

import pytest

from _plugin_helpers import REPO, gui_env, read_log, serve_stamped, unexplained_refusal, xdotool_key

pytestmark = [pytest.mark.gui, pytest.mark.slow]


@pytest.mark.skipif(shutil.which("xdotool") is None, reason="xdotool is not installed")
def test_coder_example_runs_against_the_emulator_on_a_pty(tmp_path, xvfb):
    env = gui_env(xvfb)
    out = tmp_path / "data" / "coder"
    with serve_stamped(tmp_path) as (link, log):
        run = subprocess.Popen([sys.executable, str(REPO / "docs" / "examples" / "thermal_cue_coder.py"),
                                "--display", link, "--dry-run", "--samples", "2", "4",
                                "--data", str(out)],
                               cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True)
        try:
            for i, key in enumerate(["2", "4"]):
                deadline = time.monotonic() + 60
                while (sum(r.get("why") == "contact" for r in read_log(log)) <= i
                       and run.poll() is None and time.monotonic() < deadline):
                    time.sleep(0.05)
                time.sleep(0.3)
                for attempt in range(2):
                    xdotool_key(env, key)
                    t0 = time.monotonic()
                    while (sum(r.get("why") == "abort" for r in read_log(log)) <= i
                           and time.monotonic() - t0 < 4 and run.poll() is None):
                        time.sleep(0.05)
                    if sum(r.get("why") == "abort" for r in read_log(log)) > i or run.poll() is not None:
                        break
            _, err = run.communicate(timeout=60)
        finally:
            if run.poll() is None:
                run.kill()
                run.communicate()
        time.sleep(1.5)
    assert run.returncode == 0, err[-3000:]
    with open(str(out) + ".csv", newline="", encoding="utf-8-sig") as fh:
        rows = list(csv.DictReader(fh))
    assert [(r["sample"], r["answer.keys"]) for r in rows] == [("2", "2"), ("4", "4")]
    max_late_ms = read_log(log)[-1]["max_late_ms"]
    for r in rows:
        assert r["thermal.status"] == "aborted"          # answered while the profile played
        assert float(r["thermal.tracking_rms_C"]) < 0.1
        assert float(r["thermal.contact_force_N"]) >= 2.0
        # a map refuses only what a starved emulator's stale replies explain (test_plugin_builder)
        status = r["thermal.clock_status"]
        if status != "mapped":
            assert status.startswith("unmapped: ") and unexplained_refusal(
                status.removeprefix("unmapped: "), max_late_ms) is None, (status, max_late_ms)
            assert r["thermal.contact_trial_s"] == ""
            continue
        assert 0 < float(r["thermal.contact_trial_s"]) < 10
        assert 0 <= float(r["thermal.clock_uncertainty_s"]) < 0.01   # 1 ms: test_plugin_timing
    states = [r["why"] for r in read_log(log) if r.get("event") == "state"]
    assert states == ["arm playback", "contact", "abort"] * 2
    stop = read_log(log)[-1]
    assert stop["event"] == "stop" and stop["state"] == "IDLE" and stop["setpoint_C"] == 32.0
