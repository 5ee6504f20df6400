"""thermocue check on the other backends: the TCS II emulator (its subset passes, the checks its
declared capabilities rule out are listed as not applicable), a plain serial port (a pty served by ``thermocue emulator --link``), the
firmware under QEMU (the sim image passes, the board image fails on its sensors), and the
command line's exit codes."""
from __future__ import annotations

import shutil
import subprocess
import sys
import time

import pytest

from experiments.qualification.qualify import qualify
from experiments.qualification.runner import CHECKS
from experiments.qualification.safety_checks import check_overtemp, check_watchdog
from experiments.qualification.sensors import check_sensors

THERMOCUE = [sys.executable, "-m", "experiments"]
QEMU = pytest.mark.skipif(shutil.which("qemu-system-arm") is None,
                          reason="qemu-system-arm is not installed here (scripts/setup installs it)")


def _by_name(results):
    return {r.name: r for r in results}


@pytest.mark.slow
def test_the_tcs2_emulator_passes_its_subset_and_lists_the_rest_as_not_applicable(tmp_path):
    from experiments.protocol import load_protocol
    proto = load_protocol("roughness_recognition_tcs2")
    results, path = qualify("tcs2://emulator", tmp_path, protocol=proto,
                            limits=proto.display.safety_limits())
    r = _by_name(results)
    assert {n for n, x in r.items() if x.passed} == {"sensors", "neutral", "step", "tracking"}
    assert not [n for n, x in r.items() if x.failed]
    lacking = {"force": "force_sensing", "limits": "raw_setpoint", "overtemp": "trip_test",
               "watchdog": "host_watchdog", "clock": "device_clock"}
    assert {n: x.not_applicable for n, x in r.items() if x.not_applicable} == lacking
    for name, capability in lacking.items():
        assert r[name].reason.startswith(f"not applicable to this backend: it lacks {capability}")
    assert "finger_thermometer" in r["sensors"].reason and "stuck_sensor_rule" in r["sensors"].reason
    text = path.read_text()
    assert "result: **PASS** (4 of 4 checks passed; 5 not applicable to this backend, not run)" in text
    assert "## Not run on this backend" in text and "## What to look at" not in text
    for name, capability in lacking.items():
        assert f"| {name} | not applicable ({capability}) |" in text


def test_the_tcs2_emulator_on_its_virtual_clock_finishes_the_check(tmp_path):
    # its clock moves only while the host waits for bytes: a pause that slept left the device's
    # time where it was, and the sensors check never ended (stopped after 10 minutes)
    t0 = time.monotonic()
    results, path = qualify("tcs2://emulator?clock=virtual", tmp_path)
    assert time.monotonic() - t0 < 120
    r = _by_name(results)
    assert {n for n, x in r.items() if x.passed} == {"sensors", "neutral", "step", "tracking"}
    assert "result: **PASS** (4 of 4 checks passed" in path.read_text()


@pytest.mark.slow
def test_safety_checks_pass_on_a_plain_serial_port(tmp_path):
    """A pty from `thermocue emulator --link`: the driver's heartbeat helper, a real tty."""
    from experiments.display import open_display
    from experiments.qualification.bench import Bench
    link = tmp_path / "display"
    proc = subprocess.Popen(THERMOCUE + ["emulator", "--link", str(link)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 30
        while not link.exists():
            assert proc.poll() is None and time.monotonic() < deadline, "emulator did not start"
            time.sleep(0.05)
        d = open_display(str(link))
        try:
            b = Bench(d, str(link), tmp_path)
            results = [check_sensors(b), check_overtemp(b), check_watchdog(b)]
        finally:
            d.close()
    finally:
        proc.terminate()
        proc.wait(timeout=10)
    assert [(r.name, r.passed, r.reason) for r in results] == [
        ("sensors", True, ""), ("overtemp", True, ""), ("watchdog", True, "")]


@QEMU
@pytest.mark.slow
def test_the_sim_image_passes_every_check(tmp_path):
    results, path = qualify("qemu-firmware://", tmp_path, profile_s=1.0)
    assert [(r.name, r.reason) for r in results if not r.passed] == []
    assert len(results) == len(CHECKS)


@QEMU
@pytest.mark.slow
def test_the_sim_images_clock_check_holds_its_promise_while_qemu_is_held_off(tmp_path):
    """A loaded host holds QEMU off: the sim image's clock pauses meanwhile (here for 1.85 s of
    the check's 2 s, so it advances less than a fifth of wall time). The check asks what the
    image promises -- monotonic, advancing, never ahead of wall time -- and passes; the old
    limit (at least 20 % of wall time) failed it."""
    import signal
    import threading
    from experiments.display import open_display
    from experiments.qualification.bench import Bench
    from experiments.qualification.clock import check_clock
    d = open_display("qemu-firmware://")
    held = []
    try:
        def hold_off():
            time.sleep(0.05)
            d.qemu.send_signal(signal.SIGSTOP)
            t0 = time.monotonic()
            time.sleep(1.85)     # of the check's ≥ 2 s: well under a fifth left to run
            held.append(time.monotonic() - t0)
            d.qemu.send_signal(signal.SIGCONT)
        t = threading.Thread(target=hold_off)
        t.start()
        w0 = time.monotonic()
        r = check_clock(Bench(d, "qemu-firmware://", tmp_path))
        wall = time.monotonic() - w0
        t.join()
    finally:
        d.qemu.send_signal(signal.SIGCONT)
        d.close()
    share = float(r.measured.split("advanced ")[1].split("%")[0]) / 100
    # QEMU was held off: the clock paused, advancing at most in the check's time not held
    # (a loaded host stretches the check past the hold; 2 % for the stamps' own round trips)
    assert 0.0 < share <= (wall - held[0]) / wall + 0.02, (r.measured, wall, held)
    assert r.passed, (r.measured, r.reason)


@QEMU
@pytest.mark.slow
def test_the_board_image_fails_clearly_on_its_sensors(tmp_path):
    from experiments.display.thermocue.qemu_firmware import BOARD_IMAGE
    results, path = qualify(f"qemu-firmware://?image={BOARD_IMAGE}", tmp_path)
    r = _by_name(results)
    assert not any(x.passed for x in results)
    assert "SENSOR_FAILURE" in r["sensors"].reason
    assert "thermistor's wiring" in r["sensors"].look_at
    text = path.read_text()
    assert "result: **FAIL** (0 of 9 checks passed)" in text and "SENSOR_FAILURE" in text


def test_a_bad_url_is_one_line_and_exit_2(tmp_path):
    p = subprocess.run(THERMOCUE + ["check", "emulator://?faults=nonsense", "--out",
                                    str(tmp_path / "o"), "--no-prompt"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2
    assert "Traceback" not in p.stderr and len(p.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "o" / "check.md").exists()


@pytest.mark.slow
def test_a_failing_check_exits_1_with_what_to_look_at(tmp_path):
    p = subprocess.run(THERMOCUE + ["check", "emulator://?clock=virtual&faults=stuck_sensor@0.5",
                                    "--out", str(tmp_path), "--no-prompt", "--profile-s", "0.5"],
                       capture_output=True, text=True, timeout=280)
    assert p.returncode == 1, p.stderr[-2000:]
    assert "FAIL sensors: the device latched SENSOR_STUCK" in p.stdout
    assert "look at the contact thermistor's wiring" in p.stdout
    assert "left)" in p.stderr                      # progress with the time remaining
    assert "## What to look at" in (tmp_path / "check.md").read_text()
