import pytest

from experiments.errors import UserInputError
from experiments.emulators.thermocue.faults import FaultSpec, LinkFaults, parse_faults


def test_grammar():
    assert parse_faults("drop=0.01, stall@2+0.5 ,overtemp@3") == [
        FaultSpec("drop", 0.01), FaultSpec("stall", None, 2.0, 0.5, once=True),
        FaultSpec("overtemp", None, 3.0, once=True)]
    assert parse_faults("") == [] and parse_faults(None) == []
    # "@T*": an event of every opening of the URL, not once
    assert parse_faults("disconnect@1.5*+2") == [FaultSpec("disconnect", None, 1.5, 2.0, once=False)]


def test_a_once_event_is_left_out_of_the_next_opening_of_its_url_an_every_event_is_not():
    import serial
    url = "emulator://?clock=virtual&faults=drop=0.5,stall@0.05,overtemp@0.05*,reboot@9"
    port = serial.serial_for_url(url, timeout=0.2)
    port.read(64)                                  # 0.2 s of device time: the events at 0.05 s fire
    port.close()
    port = serial.serial_for_url(url, timeout=0.2)
    try:                                           # stall (once) fired; reboot@9 did not yet
        assert [f.name for f in port.device.faults] == ["drop", "overtemp", "reboot"]
    finally:
        port.close()
    other = serial.serial_for_url(url.replace("seed", "x") + "&seed=1", timeout=0.2)
    try:                                           # another URL: its own events
        assert [f.name for f in other.device.faults] == ["drop", "stall", "overtemp", "reboot"]
    finally:
        other.close()


@pytest.mark.parametrize("spec, words", [
    ("melt", "expected a fault name, got 'melt'"),
    ("drop", "expected drop=VALUE"),
    ("drop=2", "expected 0.0 ≤ VALUE ≤ 1.0"),
    ("overtemp=1", "expected no value"),
    ("stall@soon", "AT_s to be a number"),
])
def test_errors_name_the_item_and_quote_the_grammar(spec, words):
    with pytest.raises(UserInputError, match="SPEC :=") as e:
        parse_faults(spec)
    assert words in str(e.value) and repr(spec) in str(e.value)


def test_active_window():
    f = FaultSpec("stall", None, 2.0, 0.5)
    assert [f.active(t) for t in (1.99, 2.0, 2.49, 2.5)] == [False, True, True, False]


def test_drop_rate_is_about_right():
    lf = LinkFaults(parse_faults("drop=0.1"), seed=3)
    out = lf.mangle(bytes(20000), 0.0)
    assert 1700 < 20000 - len(out) < 2300 and lf.dropped == 20000 - len(out)
