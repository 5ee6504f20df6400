"""``thermocue tcs2 probe PORT --capture FILE`` on the TCS II emulator over a real pty, and the
capture replayed to the backend by a replaying device on another real pty."""
from __future__ import annotations

import json
import threading

import pytest

from experiments.cli import main
from experiments.display.tcs2.capture import read_capture
from experiments.display.tcs2.probe import probe
from experiments.emulators.pty_server import serve_tcs2
from experiments.emulators.tcs2_replay import ReplayDevice
from experiments.errors import UserInputError
from experiments.protocol import load_protocol

LIMITS = load_protocol("roughness_recognition_tcs2").display.safety_limits()


@pytest.fixture
def emulator(tmp_path):
    """The TCS II emulator served on a real pty by a thread of this process; yields its path."""
    stop, ready, paths = threading.Event(), threading.Event(), []

    def announce(path):
        paths.append(path)
        ready.set()

    t = threading.Thread(target=serve_tcs2, kwargs=dict(announce=announce, stop=stop.is_set),
                         daemon=True)
    t.start()
    assert ready.wait(10)
    yield paths[0]
    stop.set()
    t.join(timeout=10)


def run_probe(port, capture=None):
    lines = []
    ok = probe(port, LIMITS, capture=capture, say=lines.append)
    return ok, lines


def steps(lines):
    """The report without its first line (which names the port)."""
    return [line for line in lines[1:]]


def test_probe_reports_each_step_and_captures_every_byte(emulator, tmp_path):
    cap = tmp_path / "cap.jsonl"
    ok, lines = run_probe(emulator, capture=cap)
    assert ok, lines
    assert [line.split()[0] for line in lines] == ["open", "identify", "maximum", "neutral",
                                                    "temperatures", "errors", "stimulus"]
    assert "probe id 'EM 00 00 00 00 00 00 01', firmware '012 thermocue-emulator'" in lines[1]
    assert lines[2].startswith("maximum       42.0 °C") and "35.5 °C" in lines[3]
    records = read_capture(cap)
    sent = b"".join(d for _, k, d in records if k == "out")
    heard = b"".join(d for _, k, d in records if k == "in")
    for command in (b"?\r", b"A\r", b"F\r", b"H\r", b"P\r", b"Q\r", b"Oe\r"):
        assert command in sent
    assert b"Om420\r" in sent and b"N355\r" in sent          # the protocol's maximum, neutral
    assert b"Probe ID: EM 00 00 00 00 00 00 01" in heard and b"TCS" in heard
    times = [t for t, _, _ in records]
    assert times == sorted(times) and all(t >= 0 for t in times)
    first = json.loads(cap.read_text().splitlines()[0])
    assert set(first) == {"t_s", "dir", "hex", "text"} and first["dir"] == "out"


def test_a_capture_replayed_through_the_backend_gives_the_same_report(emulator, tmp_path):
    cap = tmp_path / "cap.jsonl"
    ok, original = run_probe(emulator, capture=cap)
    assert ok, original
    records = read_capture(cap)
    with ReplayDevice(records) as dev:
        ok, replayed = run_probe(dev.path)
        assert dev.done.wait(10)
    assert ok, (replayed, dev.mismatch)
    assert dev.mismatch is None and dev.played == len(records)
    assert steps(replayed) == steps(original)


def test_a_device_reply_in_another_format_fails_the_probe_naming_the_step(emulator, tmp_path):
    cap = tmp_path / "cap.jsonl"
    assert run_probe(emulator, capture=cap)[0]
    # the "lab's device" holds 40 °C whatever Om asks: its P replies say Om400
    records = [(t, k, d.replace(b"Om420", b"Om400") if k == "in" else d)
               for t, k, d in read_capture(cap)]
    with ReplayDevice(records, wait_s=2.0) as dev:
        ok, lines = run_probe(dev.path)
    assert not ok
    assert lines[-1].startswith("FAILED handshake: display tcs2://") and "maximum" in lines[-1]
    assert "40" in lines[-1]


def test_a_damaged_capture_is_one_line_naming_the_file_and_line(tmp_path):
    cap = tmp_path / "cap.jsonl"
    cap.write_text('{"t_s": 0.1, "dir": "out", "hex": "3f0d"}\n{"t_s": 0.2, "dir": "in"}\n')
    with pytest.raises(UserInputError, match=r"cap.jsonl: line 2: expected a capture record"):
        read_capture(cap)
    cap.write_text('{"t_s": 0.1, "dir": "sideways", "hex": "3f0d"}\n')
    with pytest.raises(UserInputError, match=r"line 1: dir: expected 'in' or 'out'"):
        read_capture(cap)


@pytest.mark.slow
def test_the_command_line_exits_0_on_the_emulator_and_1_with_nothing_there(emulator, tmp_path,
                                                                            capsys):
    assert main(["tcs2", "probe", emulator, "--capture", str(tmp_path / "c.jsonl")]) == 0
    out = capsys.readouterr().out
    assert "identify" in out and f"capture: {tmp_path / 'c.jsonl'}" in out
    assert main(["tcs2", "probe", str(tmp_path / "no-such-port")]) == 1
    out = capsys.readouterr().out
    assert out.strip().splitlines()[-1].startswith("FAILED open: ")
