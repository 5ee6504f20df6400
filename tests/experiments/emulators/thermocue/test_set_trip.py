"""SET_TRIP (docs/display-protocol.md §3, §6): a test lowers the over-temperature trip; the
device never raises it above its own and restores its own at HELLO and after host silence."""
import pytest

from experiments.display import open_display
from experiments.errors import DisplayRefused


@pytest.fixture
def display():
    d = open_display("emulator://?clock=virtual&seed=11")
    yield d
    d.close()


def test_a_lowered_trip_latches_over_temperature_below_45_C(display):
    assert display.set_trip(34.0) == 34.0
    display.set_neutral(36.0)                 # slewed past the lowered trip
    display.wait(1.0)
    st = display.status()
    assert st.state == "FAULT" and st.fault == "OVER_TEMPERATURE"
    assert st.contact_C < 34.5                # cut as it crossed, the pad relaxing


def test_the_trip_is_never_raised_and_never_below_20_C(display):
    assert display.set_trip(60.0) == 44.8
    assert display.set_trip(5.0) == 20.0


def test_lowering_is_refused_outside_idle_and_restoring_is_not(display):
    display.set_trip(34.0)
    display.set_neutral(36.0)
    display.wait(1.0)
    assert display.status().state == "FAULT"
    with pytest.raises(DisplayRefused, match="BAD_STATE"):
        display.set_trip(33.0)
    assert display.set_trip(45.0) == 44.8


def test_hello_restores_the_devices_own_trip(display):
    display.set_trip(34.0)
    display.handshake()                       # a new host
    display.set_neutral(36.0)
    display.wait(1.0)
    assert display.status().state == "IDLE"   # 36 °C is below the restored 44.8 °C trip


def test_host_silence_restores_the_devices_own_trip(display):
    display.set_trip(34.0)
    port = display.port
    port.read(10_000_000)                     # no host frame: the device's time runs on
    for _ in range(30):                       # virtual clock: each read advances device time
        port.read(1)
    display.set_neutral(36.0)
    display.wait(1.0)
    assert display.status().state == "IDLE"
