import pytest
import serial

import experiments.emulators.thermocue  # noqa: F401  (registers emulator:// with pyserial)
from experiments.emulators.thermocue.protocol_emulator import URL_GRAMMAR, parse_url


def test_registered_once():
    import importlib
    importlib.reload(experiments.emulators.thermocue)
    assert serial.protocol_handler_packages.count("experiments.emulators.thermocue") == 1


def test_serial_for_url_opens_the_emulator():
    port = serial.serial_for_url("emulator://?clock=virtual&seed=3", timeout=0.05)
    try:
        assert port.is_open and port.virtual_time_s == 0.0
        assert port.read(10) == b""                 # idle: nothing to say
        assert port.virtual_time_s == pytest.approx(0.05)   # the timeout was spent in device time
    finally:
        port.close()
    with pytest.raises(serial.PortNotOpenError):
        port.read(1)


@pytest.mark.parametrize("url, words", [
    ("emulator://?colour=red", "unknown option 'colour'"),
    ("emulator://?clock=fast", "clock: expected real or virtual"),
    ("emulator://?faults=melt", "expected a fault name"),
    ("loop://", "not starting with emulator://"),
])
def test_bad_urls_quote_the_grammar(url, words):
    with pytest.raises(serial.SerialException) as e:
        parse_url(url)
    assert words in str(e.value) and URL_GRAMMAR in str(e.value)


def test_real_clock_ticks_in_wall_time():
    import time
    # never ahead of the wall clock, and it keeps up with it (its clock thread, starved on a
    # loaded machine, catches up on the ticks it owes once it runs)
    port = serial.serial_for_url("emulator://", timeout=0.05)
    try:
        t0, w0 = port.device.time_us, time.monotonic()
        time.sleep(0.2)
        deadline = time.monotonic() + 5.0
        while port.device.time_us - t0 < 0.19e6 and time.monotonic() < deadline:
            time.sleep(0.01)
        ran_us, wall_us = port.device.time_us - t0, (time.monotonic() - w0) * 1e6
        assert 0.19e6 <= ran_us <= wall_us + 10_000, (ran_us, wall_us)
    finally:
        port.close()


def test_a_plus_in_the_url_is_the_faults_duration():
    # audit 34: parse_qs read "+" as a space, so the documented NAME@AT+FOR was refused
    from experiments.emulators.thermocue.faults import FaultSpec
    want = [FaultSpec("stall", None, 100.0, 5.0, once=True), FaultSpec("drop", 0.01, 1.0, 2.5, once=True)]
    assert parse_url("emulator://?faults=stall@100+5,drop=0.01@1+2.5&seed=2")["faults"] == want
    assert parse_url("emulator://?faults=stall@100%2B5,drop=0.01@1%2B2.5")["faults"] == want
    assert parse_url("emulator://?log=/tmp/a+b.jsonl")["log"] == "/tmp/a+b.jsonl"
    port = serial.serial_for_url("emulator://?clock=virtual&faults=stall@0.1+0.2", timeout=0.01)
    try:
        assert port.device.faults == [FaultSpec("stall", None, 0.1, 0.2, once=True)]
    finally:
        port.close()


def test_a_timed_disconnect_ends_and_the_link_comes_back():
    # Regression: on a virtual clock the device advanced only in reads, and reads
    # failed while disconnected: the clock stopped and disconnect@T+D never ended.
    from experiments.errors import DisplayError
    from experiments.display import open_display
    with open_display("emulator://?clock=virtual&seed=3&faults=disconnect@1+0.5") as d:
        with pytest.raises(DisplayError):
            d.wait(1.2)
        for _ in range(200):                       # each failed read lets device time pass
            try:
                t = d.heartbeat()
                break
            except DisplayError:
                pass
        else:
            pytest.fail("the link never came back")
        assert t >= 1.5 and d.port.device.time_us * 1e-6 < 3.0
        assert d.status().state == "IDLE"
