"""Two audiences: the participant's channel never names the sample of a test trial;
the experimenter's channel says which sample to place; feedback only where a block asks for it.

A whole session on the in-process emulator (virtual clock) answered through the console
responder: its stdout is the participant's terminal, the session's ``out`` the experimenter's.
The PsychoPy window's texts are checked the same way, through PsychoPy's draw path, in
test_session_gui.py.
"""
from __future__ import annotations

import csv
import io
import json
import logging
import re

import pytest

from _session_helpers import P01, write_protocol
from experiments.responders import ConsoleResponder
from experiments.session import create_session

EXTRA_BLOCKS = '''
[[blocks]]
name = "familiarise"
mode = "real"
repetitions = 1
samples = [1, 2]
order = "fixed"
scored = false
feedback = true
response = false
instructions = "Each sample is named before you touch it."

[[blocks]]
name = "practice"
mode = "real"
repetitions = 1
samples = [3, 4]
order = "fixed"
scored = false
feedback = true
instructions = "Practice: you will be told the answer."
'''


def _protocol(tmp_path):
    path = write_protocol(tmp_path, contact_s=0.5, real_samples=(1, 2, 3, 4), sim_samples=(1, 2, 3, 4))
    text = path.read_text()
    head, sep, tail = text.partition("[[blocks]]")
    path.write_text(head + EXTRA_BLOCKS + sep + tail)
    return path


def test_participant_terminal_never_names_a_test_trials_sample(tmp_path, caplog):
    caplog.set_level(logging.INFO, logger="thermocue.session")   # progress is logged
    proto = _protocol(tmp_path)
    experimenter = io.StringIO()
    s = create_session(proto, P01, tmp_path / "data", "emulator://?clock=virtual&seed=3", seed=11,
                       responder_name="console", clock="virtual", out=experimenter)
    lines, answers = [], {}
    for spec in s.schedule:
        block = s.protocol.block(spec.block)
        if spec.mode == "real":
            lines.append("")                       # the experimenter's Enter
        if block.response:
            answer = 1 if spec.roughness_id != 1 else 2   # always wrong: "correct" never by luck
            answers[spec.trial_index] = answer
            lines.append(str(answer))
    participant = io.StringIO()
    responder = ConsoleResponder(stdin=io.StringIO("\n".join(lines) + "\n"), stdout=participant,
                                 bell=False)
    assert s.run(responder) == 0
    # (The question ends without a newline: a terminal echoes the typed answer after it.)
    seen = participant.getvalue().replace("Which roughness (1, 2, 3, 4)? ", "")
    told = experimenter.getvalue()
    blocks = [spec.block for spec in s.schedule]
    assert blocks == ["familiarise"] * 2 + ["practice"] * 2 + ["real"] * 4 + ["simulated"] * 4
    # What names a sample on the participant's terminal: the familiarisation labels (before the
    # touch) and the practice block's feedback (after the answer), nothing else.
    naming = [line for line in seen.splitlines() if re.search(r"[1-4]#|µm|\b(1\.6|12\.5|50|100)\b", line)]
    assert naming == ["This is sample 1#", "This is sample 2#",
                      "Not correct: it was sample 3#", "Not correct: it was sample 4#"]
    assert "orrect" not in seen.split("Not correct: it was sample 4#")[1]   # test blocks: none
    # The experimenter was told which sample to place on every real trial, and never whether an
    # answer was right (the console participant may read stderr too).
    for spec in s.schedule:
        if spec.mode == "real":
            sample = s.protocol.sample(spec.roughness_id)
            assert (f"trial {spec.trial_index}/12: place sample {sample.label} "
                    f"(Ra {sample.roughness_um:g} µm)") in told
    assert "correct" not in told and "wrong" not in told
    progress = "\n".join(r.getMessage() for r in caplog.records if r.name == "thermocue.session")
    assert re.search(r"trial 12 of 12 \| block simulated \| elapsed \d+:\d\d \| about \d+:\d\d left",
                     progress)
    assert "correct" not in progress and "wrong" not in progress
    meta = json.loads((s.directory / "session.json").read_text())
    assert meta["blocks"] == [
        {"name": "familiarise", "mode": "real", "scored": False, "response": False, "feedback": True},
        {"name": "practice", "mode": "real", "scored": False, "response": True, "feedback": True},
        {"name": "real", "mode": "real", "scored": True, "response": True, "feedback": False},
        {"name": "simulated", "mode": "simulated", "scored": True, "response": True, "feedback": False},
    ]
    events = [json.loads(line) for line in (s.directory / "events.jsonl").read_text().splitlines()]
    assert [e["trial_index"] for e in events if e["event"] == "feedback"] == [3, 4]


def test_trials_csv_has_its_whole_header_from_the_first_row(tmp_path):
    """the header grew during a session (28 -> 29 -> 35 columns); contact_time_s was
    the device clock at contact, read as a duration."""
    from sessionfiles.logbook import TRIAL_COLUMNS
    from experiments.responders.simulated import SimulatedResponder  # noqa: F401 (registers it)
    from experiments.responders import get_responder

    proto = _protocol(tmp_path)
    s = create_session(proto, P01, tmp_path / "data", "emulator://?clock=virtual&seed=3", seed=11,
                       responder_name="simulated", clock="virtual")
    headers = []

    class Watch(type(get_responder("simulated"))):
        def touch(self, trial, display):
            if (s.directory / "trials.csv").exists():
                headers.append((s.directory / "trials.csv").read_text().splitlines()[0])
            super().touch(trial, display)

    assert s.run(Watch()) == 0
    assert len(headers) == 12 and set(headers) == {",".join(TRIAL_COLUMNS)}
    with open(s.directory / "trials.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == list(TRIAL_COLUMNS)
    for r in rows:
        assert (r["expName"], r["protocol_version"], r["thermocue_version"]) == ("mini", "1", "0.1.0")
        assert re.fullmatch(r"\d{4}-\d\d-\d\d_\d\dh\d\d\.\d\d\.\d{3}", r["date"])
        assert r["psychopyVersion"] == "n/a"       # no PsychoPy window ran: said, not left empty
        # the contact lasted the protocol's 0.5 s; its onset is a device-clock time stamp
        assert float(r["contact_duration_s"]) == pytest.approx(0.5, abs=0.03)
        assert re.fullmatch(r"\d+(\.\d{1,3})?", r["contact_onset_s"])
        assert r["skin_temperature_in_range"] == "1" and r["status"] == "ok"
        for column in ("rt_s", "tracking_rms_C", "skin_temperature_C"):
            assert len(r[column].partition(".")[2]) <= 4, (column, r[column])
    onsets = [float(r["contact_onset_s"]) for r in rows]
    assert onsets == sorted(onsets) and onsets[-1] > onsets[0] + 5 * 0.5
