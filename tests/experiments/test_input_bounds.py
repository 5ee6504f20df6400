"""Every input bounded and finite: one line naming file and field, exit 2.

Regressions from a fuzzing campaign: ``epidermis_um: NaN`` accepted (JSON Schema's
``exclusiveMinimum`` lets NaN through, and the session could then never be resumed),
``initial_skin_temperature_C: NaN``, ``rewarm_s = 1e308`` (OverflowError on a real clock),
``repetitions = 100000`` (hung), a non-UTF-8 byte in a protocol (``UnicodeDecodeError``), and
``max_consecutive_faults: "many"`` in session.json accepted.
"""
from __future__ import annotations

import json
import time

import pytest

from _session_helpers import P01, write_protocol
from experiments.cli import main
from experiments.session import create_session

EMU = "emulator://?clock=virtual&seed=2"


def _run(proto, participant, data):
    return main(["run", str(proto), "--participant", str(participant), "--display", EMU,
                 "--responder", "simulated", "--data", str(data), "--seed", "1", "--quiet"])


def _one_line(capsys):
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("field, value", [
    (("skin_thickness", "epidermis_um"), "NaN"),
    (("skin_thickness", "dermis_um"), "Infinity"),
    (("initial_skin_temperature_C",), "NaN"),
    (("age",), "-Infinity"),
])
def test_non_finite_participant_values_are_refused(tmp_path, capsys, field, value):
    record = json.loads(P01.read_text())
    target = record
    for k in field[:-1]:
        target = target[k]
    target[field[-1]] = "@@"
    path = tmp_path / "P.json"
    path.write_text(json.dumps(record).replace('"@@"', value))
    assert _run(write_protocol(tmp_path), path, tmp_path / "data") == 2
    err = _one_line(capsys)
    assert f"{path}: {'.'.join(field)}: expected a finite number, got" in err
    assert not (tmp_path / "data").exists()


@pytest.mark.parametrize("old, new, message", [
    ("rewarm_s = 0.0", "rewarm_s = 1e308",
     "contact.rewarm_s: expected a number ≥ 0 and ≤ 3600 (at most an hour"),
    ("rewarm_s = 0.0", "rewarm_s = nan", "contact.rewarm_s: expected a number ≥ 0, got nan"),
    ("trial_timeout_s = 5.0", "trial_timeout_s = inf",
     "contact.trial_timeout_s: expected a number > 0, got inf"),
    ("trial_timeout_s = 5.0", "trial_timeout_s = 1e9",
     "contact.trial_timeout_s: expected a number > 0 and ≤ 3600 (at most an hour"),
    ("repetitions = 1\nsamples = [1, 2, 3, 4]", "repetitions = 100000\nsamples = [1, 2, 3, 4]",
     "blocks[0].repetitions: expected an integer ≥ 1 and ≤ 1000 (a session is at most"),
    ("roughness_um = 1.6", "roughness_um = 1e300", "samples[0].roughness_um: expected a number > 0 "
                                                  "and ≤ 10000 (Ra beyond 1 cm"),
])
def test_protocol_values_are_finite_and_bounded_with_the_reason(tmp_path, capsys, old, new, message):
    proto = write_protocol(tmp_path, rewarm_s=0.0)
    text = proto.read_text()
    assert old in text
    proto.write_text(text.replace(old, new, 1))
    t0 = time.monotonic()
    assert _run(proto, P01, tmp_path / "data") == 2
    assert time.monotonic() - t0 < 30                            # refused, not hung
    err = _one_line(capsys)
    assert f"{proto}: {message}" in err, err


def test_too_many_trials_in_all_are_refused(tmp_path, capsys):
    proto = write_protocol(tmp_path)
    proto.write_text(proto.read_text().replace("repetitions = 1", "repetitions = 700"))
    assert _run(proto, P01, tmp_path / "data") == 2
    assert f"{proto}: blocks: expected at most 5000 trials in all" in _one_line(capsys)


def test_a_non_utf8_byte_is_named_with_its_offset(tmp_path, capsys):
    proto = write_protocol(tmp_path)
    data = proto.read_bytes()
    at = data.index(b"A short session")
    proto.write_bytes(data[:at] + b"\xff" + data[at:])
    assert _run(proto, P01, tmp_path / "data") == 2
    assert f"{proto}: expected UTF-8 text, got byte 0xff at offset {at}" in _one_line(capsys)
    bad = tmp_path / "P.json"
    raw = P01.read_bytes()
    at = raw.index(b"student")
    bad.write_bytes(raw[:at] + b"\xc3\x28" + raw[at:])
    assert _run(write_protocol(tmp_path), bad, tmp_path / "data") == 2
    assert f"{bad}: expected UTF-8 text, got byte 0xc3 at offset {at}" in _one_line(capsys)


@pytest.mark.parametrize("value, message", [
    ('"many"', "max_consecutive_faults: expected an integer ≥ 1, got 'many'"),
    ("0", "max_consecutive_faults: expected an integer ≥ 1, got 0"),
    ("100000", "max_consecutive_faults: expected an integer ≥ 1 and ≤ 1000"),
    ("NaN", "max_consecutive_faults: expected an integer ≥ 1, got nan"),
])
def test_session_json_is_checked_by_the_one_validation_stack(tmp_path, capsys, value, message):
    s = create_session(write_protocol(tmp_path), P01, tmp_path / "data", EMU, seed=7,
                       responder_name="simulated")
    path = s.directory / "session.json"
    meta = json.loads(path.read_text())
    meta["max_consecutive_faults"] = "@@"
    path.write_text(json.dumps(meta).replace('"@@"', value))
    capsys.readouterr()
    assert main(["resume", str(s.directory)]) == 2
    assert f"{path}: {message}" in _one_line(capsys)
