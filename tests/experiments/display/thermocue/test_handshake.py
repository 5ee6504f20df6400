"""The handshake refuses a device it cannot trust: one line naming the port and the field.

The HELLO replies are built here with ``struct`` from the layout written in
``docs/display-protocol.md`` §3 (``<BHhhHhHIII`` then three length-prefixed strings), not with
the code under test. Over a real pty a scripted device answers HELLO with them; the host must
refuse before it writes anything else (no SET_LIMITS, no SET_NEUTRAL, no heartbeat).
"""
from __future__ import annotations

import os
import struct
import threading
import tty

import pytest

from experiments.errors import DisplayError
from experiments.display import open_display
from experiments.display.thermocue.framing import FrameParser, encode_frame
from experiments.display.thermocue.handshake import HandshakeRefused, decode_hello

LAYOUT = struct.Struct("<BHhhHhHIII")
GOOD = dict(version=2, hz=100, hmin=1000, hmax=4450, rate=10000, neutral=3200, wd=90,
            npts=65536, mindt=1000, boot=7)


def hello(strings=(b"DEV-1", b"fw 1.0", b"playback,record"), **over) -> bytes:
    v = dict(GOOD, **over)
    head = LAYOUT.pack(v["version"], v["hz"], v["hmin"], v["hmax"], v["rate"], v["neutral"],
                       v["wd"], v["npts"], v["mindt"], v["boot"])
    return head + b"".join(bytes([len(s)]) + s for s in strings)


def test_a_good_reply_is_decoded_field_by_field():
    info = decode_hello(hello(), "/dev/ttyX")
    assert (info.device_id, info.firmware, info.capabilities) == ("DEV-1", "fw 1.0",
                                                                   ("playback", "record"))
    assert (info.protocol, info.telemetry_hz, info.watchdog_ms, info.max_points) == (2, 100, 90, 65536)
    assert (info.hard_min_C, info.hard_max_C, info.max_rate_C_per_s, info.neutral_C) == (
        10.0, 44.5, 100.0, 32.0)
    assert info.min_dt_s == 1e-3 and info.boot_id == 7



def test_the_fourth_string_is_the_image_id_and_an_old_three_string_reply_reads_without_one():
    new = decode_hello(hello(strings=(b"DEV-1", b"fw 1.0", b"playback", b"cfd5fa07")), "/dev/ttyX")
    assert (new.device_id, new.capabilities, new.image_id) == ("DEV-1", ("playback",), "cfd5fa07")
    old = decode_hello(hello(), "/dev/ttyX")
    assert old.image_id == "" and old.capabilities == ("playback", "record")


def test_a_cut_short_image_id_is_refused_naming_it():
    payload = hello(strings=(b"DEV-1", b"fw 1.0", b"playback")) + b"\x28abc"
    with pytest.raises(HandshakeRefused, match="image_id"):
        decode_hello(payload, "/dev/ttyX")


def test_the_emulator_states_its_version_as_its_image_id():
    with open_display("emulator://") as disp:
        assert disp.info.image_id == "emulator-1.0.0"


BAD = [
    ("version", hello(version=3)),
    ("version", hello(version=1)),
    ("watchdog_ms", hello(wd=200)),       # neutral later than 100 ms after host silence
    ("watchdog_ms", hello(wd=20)),        # fewer than 5 heartbeats fit
    ("telemetry_hz", hello(hz=10)),
    ("telemetry_hz", hello(hz=1000)),     # more than 115200 baud carries
    ("hard_max_C", hello(hmax=4600)),     # wider than the protocol's range
    ("hard_min_C", hello(hmin=0)),
    ("max_rate_C_per_s", hello(rate=20000)),
    ("max_rate_C_per_s", hello(rate=0)),
    ("neutral_C", hello(neutral=5000)),
    ("max_points", hello(npts=1)),
    ("min_dt_s", hello(mindt=10)),
    ("length", hello()[:5]),
    ("length", b""),
    ("device_id", hello()[:LAYOUT.size] + b"\x09abc"),              # string cut short
    ("capabilities", hello()[:LAYOUT.size] + b"\x01a\x01b"),        # third string missing
    ("firmware", hello(strings=(b"ok", b"\xff\xfe", b"playback"))),  # not UTF-8
]


@pytest.mark.parametrize("field,payload", BAD, ids=[f"{f}-{i}" for i, (f, _) in enumerate(BAD)])
def test_a_bad_reply_is_refused_naming_the_port_and_the_field(field, payload):
    with pytest.raises(HandshakeRefused) as exc:
        decode_hello(payload, "/dev/ttyX")
    msg = str(exc.value)
    assert msg.startswith("display /dev/ttyX: HELLO reply: ") and f" {field}: expected " in msg
    assert "\n" not in msg
    assert isinstance(exc.value, DisplayError)       # the CLI reports it as a device refusal


class ScriptedHelloDevice:
    """A device on a real pty that answers HELLO with ``payload`` and records every frame."""

    def __init__(self, payload: bytes):
        self.payload = payload
        self.master, slave = os.openpty()
        tty.setraw(slave)
        self.path = os.ttyname(slave)
        self._slave = slave
        self.received = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self):
        import select
        parser = FrameParser()
        while not self._stop.is_set():
            r, _, _ = select.select([self.master], [], [], 0.05)
            if not r:
                continue
            try:
                data = os.read(self.master, 4096)
            except OSError:
                return
            for fr in parser.feed(data):
                self.received.append(fr.type)
                if fr.type == 0x01:      # HELLO
                    os.write(self.master, encode_frame(fr.seq, 0x81, self.payload))

    def close(self):
        self._stop.set()
        self._thread.join(2)
        os.close(self.master)
        os.close(self._slave)


@pytest.mark.parametrize("field,payload", [("watchdog_ms", hello(wd=500)),
                                           ("version", hello(version=9)),
                                           ("length", b"\x02\x64")])
def test_over_a_pty_the_host_refuses_and_writes_nothing_after_hello(field, payload):
    dev = ScriptedHelloDevice(payload)
    try:
        with pytest.raises(HandshakeRefused) as exc:
            open_display(dev.path)
        assert f"display {dev.path}: HELLO reply: {field}: expected" in str(exc.value)
        assert dev.received and set(dev.received) == {0x01}   # HELLO only, nothing else sent
    finally:
        dev.close()


def test_the_emulator_passes_the_handshake_checks():
    with open_display("emulator://?clock=virtual") as d:
        assert d.hello.watchdog_ms == 90 and d.hello.protocol == 2       # the wire reply
        assert d.info.watchdog_s == pytest.approx(0.090) and d.info.protocol == 2   # neutral
