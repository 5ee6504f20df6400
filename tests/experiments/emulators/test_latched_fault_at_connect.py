"""A display latched in FAULT before the host connects: refused at the handshake with what to do,
and reset only by the operator's `thermocue clear-fault` (the emulator on a real pty)."""
import subprocess
import sys
import time

import pytest

from experiments.errors import DisplayFaultLatched
from experiments.display import open_display

from test_pty_server import read_log, start_emulator, stop


def _wait_for_fault(log, within_s=30.0):
    deadline = time.monotonic() + within_s
    while time.monotonic() < deadline:
        if log.exists() and any(r.get("event") == "fault" for r in read_log(log)):
            return
        time.sleep(0.05)
    pytest.fail(f"the emulator logged no fault within {within_s} s")


def _thermocue(*args, stdin=subprocess.DEVNULL):
    return subprocess.run([sys.executable, "-m", "experiments", *args], capture_output=True,
                          text=True, stdin=stdin, timeout=60)


def test_a_latched_fault_is_refused_at_the_handshake_and_cleared_only_by_the_operator(tmp_path):
    # the Peltier driver sticks at full heating 0.2 s after power-up, with no host connected
    proc, path, log = start_emulator(tmp_path, "--faults", "overtemp@0.2+1")
    try:
        _wait_for_fault(log)
        with pytest.raises(DisplayFaultLatched) as exc:
            open_display(path)
        msg = str(exc.value)
        assert exc.value.code == "OVER_TEMPERATURE"
        assert path in msg and "OVER_TEMPERATURE" in msg and f"thermocue clear-fault {path}" in msg
        # the handshake stopped after HELLO and STATUS: no limits, no neutral reached the device
        events = [r["event"] for r in read_log(log)]
        assert "hello" in events
        assert "limits" not in events and "neutral" not in events

        # no confirmation, no terminal: refused (exit 2), the fault stays
        r = _thermocue("clear-fault", path)
        assert r.returncode == 2, r.stderr
        assert "--yes" in r.stderr
        with pytest.raises(DisplayFaultLatched):
            open_display(path)

        r = _thermocue("clear-fault", path, "--yes")
        assert r.returncode == 0, r.stderr
        assert "was FAULT (OVER_TEMPERATURE), now IDLE" in r.stdout

        events = [r["event"] for r in read_log(log)]
        assert events.count("fault_cleared") == 1 and "limits" not in events
        with open_display(path) as disp:
            assert disp.status().state == "IDLE"
        assert "limits" in [r["event"] for r in read_log(log)]

        r = _thermocue("clear-fault", path, "--yes")
        assert r.returncode == 0 and "not in FAULT" in r.stdout
    finally:
        stop(proc)


def test_clear_fault_speaks_only_the_thermocue_protocol():
    r = _thermocue("clear-fault", "tcs2:///dev/ttyACM0", "--yes")
    assert r.returncode == 2
    assert "tcs2://" in r.stderr and "thermocue display protocol" in r.stderr


def test_clear_fault_cancelled_at_the_prompt_with_ctrl_d_is_one_line_not_a_traceback():
    import os
    master, slave = os.openpty()
    try:
        proc = subprocess.Popen([sys.executable, "-m", "experiments", "clear-fault",
                                 "/dev/thermocue-no-such-port"], stdin=slave,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        os.close(slave)
        slave = None
        os.write(master, b"\x04")                 # Ctrl-D at the confirmation prompt
        out, err = proc.communicate(timeout=60)
    finally:
        if slave is not None:
            os.close(slave)
        os.close(master)
    assert proc.returncode == 1, err
    assert "Traceback" not in err and "not reset" in err
    assert len(err.strip().splitlines()) == 1


def test_clear_fault_on_a_display_not_in_fault_leaves_it_as_it_is(tmp_path):
    """STATUS only (allowed before HELLO): no HELLO, which would make the device drop a running
    host's half-done profile upload and the replies it keeps for that host's retries."""
    from test_pty_server import start_emulator as start, stop as stop_emulator
    proc, path, log = start(tmp_path)
    try:
        r = _thermocue("clear-fault", path, "--yes")
        assert r.returncode == 0, r.stderr
        assert "not in FAULT (state IDLE)" in r.stdout
        events = [rec["event"] for rec in read_log(log)]
        assert "hello" not in events and "fault_cleared" not in events
    finally:
        stop_emulator(proc)


def test_a_port_in_use_is_refused_not_shared(tmp_path):
    """Two programs on one port read each other's replies and telemetry: the second is refused
    with one line, and the first keeps working."""
    from experiments.errors import DisplayError
    proc, path, log = start_emulator(tmp_path)
    try:
        with open_display(path) as first:
            with pytest.raises(DisplayError) as exc:
                open_display(path)
            assert "in use by another program" in str(exc.value) and path in str(exc.value)
            r = _thermocue("clear-fault", path, "--yes")
            assert r.returncode == 1 and "in use by another program" in r.stderr, r.stderr
            assert first.status().state == "IDLE"
        with open_display(path) as again:             # free once the first has closed it
            assert again.status().state == "IDLE"
    finally:
        stop(proc)


def test_a_fault_whose_cause_remains_is_said_so_after_the_reset(tmp_path):
    # the contact thermometer reads out of range (an open wire) from 0.2 s on and stays so:
    # the device trips again at once after the operator's reset
    proc, path, log = start_emulator(tmp_path, "--faults", "sensor_range@0.2")
    try:
        _wait_for_fault(log)
        r = _thermocue("clear-fault", path, "--yes")
        assert r.returncode == 1, (r.stdout, r.stderr)
        assert "the cause is still there" in r.stderr and "SENSOR_FAILURE" in r.stderr
        assert "Traceback" not in r.stderr
        assert [e["event"] for e in read_log(log)].count("fault_cleared") == 1
    finally:
        stop(proc)
