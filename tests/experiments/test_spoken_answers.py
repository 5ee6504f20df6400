"""The spoken-answer mode (``[presentation] answer_mode = "spoken"``, the paper's procedure).

A whole session in the PsychoPy window under Xvfb: the participant's window stays blank, tones
mark the touch and the question, and the experimenter keys the spoken answers on the keyboard
(real X key presses), undoing one wrong key with backspace and confirming each answer with
space. The trial table says ``answer_mode = spoken`` and times each answer from the question's
tone to the key (``answer_keyed_after_cue_s``), with ``rt_s`` empty.
"""
from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from _session_helpers import P01, write_protocol
from _xkeys import press_until
from test_session_gui import RECORDER, _events

pytestmark = [pytest.mark.gui, pytest.mark.slow,
              pytest.mark.skipif(shutil.which("xdotool") is None, reason="xdotool is not installed")]


def _spoken_protocol(folder: Path, during_contact: bool = False) -> Path:
    proto = write_protocol(folder, contact_s=1.0, rewarm_s=0.0, real_samples=(2,), sim_samples=(3, 4))
    text = proto.read_text().replace(
        "[[blocks]]", "[presentation]\nanswer_mode = \"spoken\"\ntext_min_s = 0.3\n"
                      f"answer_during_contact = {str(during_contact).lower()}\n\n[[blocks]]", 1)
    text = text.replace('name = "simulated"', 'name = "simulated"\ninstructions = "Say the sample\'s number."')
    proto.write_text(text)
    return proto


def _run_experimenter(cmd, env, events_path, wrong_first: int, timeout_s=150):
    """Run ``cmd`` and play the experimenter: space for each placed sample and instructions,
    the trial's own number for each spoken answer (on the first question, ``wrong_first``
    first, undone with backspace), space to confirm."""
    run = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    answered, sent = set(), []
    deadline = time.monotonic() + timeout_s
    try:
        while run.poll() is None and time.monotonic() < deadline:
            events = _events(events_path)
            waiting = [e for e in events if e["event"] == "awaiting_key" and e["seq"] not in answered]
            if not waiting:
                time.sleep(0.05)
                continue
            ev = waiting[0]
            started = [e for e in events if e["event"] == "trial_started" and e["seq"] < ev["seq"]]
            right = str(started[-1]["roughness_id"]) if started else None
            purpose = ev.get("purpose")
            if purpose == "spoken_answer":
                key = str(wrong_first) if not any(k[0] == "digit" for k in sent) else right
                sent.append(("digit", key))
            elif purpose == "confirm_answer":
                key = "space" if ev["answer"] == right else "BackSpace"
                sent.append(("confirm", key))
            else:
                key = "space"
                sent.append(("other", key))
            # one retry if the key was missed
            press_until(env, key, lambda: any(e["seq"] > ev["seq"] for e in _events(events_path)),
                        run)
            answered.add(ev["seq"])
        _, err = run.communicate(timeout=20)
    finally:
        if run.poll() is None:
            run.kill()
            run.communicate()
    return run, sent, err


@pytest.mark.parametrize("during_contact", [False, True], ids=["after_contact", "during_contact"])
def test_spoken_session_blank_window_experimenter_keys_with_undo(tmp_path, xvfb, during_contact):
    proto = _spoken_protocol(tmp_path, during_contact)
    data, shots = tmp_path / "data", tmp_path / "shots"
    shots.mkdir()
    record = tmp_path / "drawn.jsonl"
    events_path = data / "P01" / "S01" / "events.jsonl"
    run, sent, err = _run_experimenter(
        [sys.executable, str(RECORDER), str(record), str(events_path), str(shots), "--",
         "run", str(proto), "--participant", str(P01), "--display", "emulator://?clock=virtual&seed=4",
         "--responder", "psychopy", "--data", str(data), "--seed", "5", "--session", "S01",
         "--responder-option", "max_wait_s=40"], {**os.environ, **xvfb}, events_path, wrong_first=1)
    assert run.returncode == 0, err[-2000:]
    events = _events(events_path)
    # The participant's window never showed a text (the recorder sees every TextStim.draw).
    drawn = [json.loads(line) for line in record.read_text().splitlines()] if record.exists() else []
    assert [d for d in drawn if d["window"] == "thermocue"] == []
    assert not [e for e in events if e["event"] == "text_on"]
    assert [e for e in events if e["event"] == "participant_screen"] == [
        {**e, "blank": True, "answer_mode": "spoken"} for e in events if e["event"] == "participant_screen"]
    # The experimenter read the instructions and keyed the answers on their channel (stderr).
    assert "read to the participant: \"Say the sample's number.\"" in err
    assert "key the participant's spoken answer 1-4" in err
    # the goodbye too (the window drew nothing; it once reached nobody)
    assert "say to the participant: 'Thank you: the session is finished.'" in err
    with open(data / "P01" / "S01" / "trials.csv", newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["status"] == "ok"]
    assert len(rows) == 3
    for r in rows:
        assert r["answer_mode"] == "spoken" and r["rt_s"] == ""
        assert r["response_id"] == r["roughness_id"] and r["correct"] == "1"
        assert r["response_source"] == "experimenter:keyboard:ptb"
        assert 0 < float(r["answer_keyed_after_cue_s"]) < 40
    # The first answer keyed (wrong) was undone, then the right one confirmed.
    undone = [e for e in events if e["event"] == "answer_undone"]
    assert len(undone) == 1 and undone[0]["key"] == "1"
    confirmed = [e for e in events if e["event"] == "answer_confirmed"]
    assert [c["key"] for c in confirmed] == [r["roughness_id"] for r in rows]
    # Each answer is timed from its question tone: the tone's event comes before the keying,
    # and the logged time fits between the tone's and the confirmation's log time stamps.
    for row in rows:
        i = int(row["trial_index"])
        cue = [e for e in events if e["event"] == "question_cue" and e["trial_index"] == i]
        keyed = [e for e in events if e["event"] == "answer_keyed" and e["trial_index"] == i]
        assert len(cue) == 1 and keyed and cue[0]["seq"] < keyed[0]["seq"]
        assert keyed[-1]["after_cue_s"] == pytest.approx(float(row["answer_keyed_after_cue_s"]), abs=1e-4)
        response, = [e for e in events if e["event"] == "response" and e["trial_index"] == i]
        assert response["answer_mode"] == "spoken" and response["rt_s"] is None
        if during_contact:   # the tone at contact, while the trace was still being recorded
            contact = [e for e in events if e["event"] == "state" and e.get("trial_index") == i
                       and e["to"] in ("playback", "record")]
            recording = [e for e in events if e["event"] == "recording" and e["trial_index"] == i]
            assert cue[0]["seq"] < recording[-1]["seq"]
    cues = [e for e in events if e["event"] == "cue"]
    assert len(cues) >= 3
    # The analysis reads the spoken session: the answers counted, the mode and its timing kept,
    # no response time made up for them; the codebook describes both columns.
    from analysis.exports import COLUMNS
    from analysis.load import load_trials
    from analysis.psychophysics import rt_table
    log = load_trials(data)
    used = log.trials[log.trials["included"]]
    assert len(used) == 3 and list(used["answer_mode"]) == ["spoken"] * 3
    assert used["rt_s"].isna().all() and (used["answer_keyed_after_cue_s"] > 0).all()
    assert list(used["correct"]) == [1, 1, 1]
    assert rt_table(log.trials).empty
    assert {"answer_mode", "answer_keyed_after_cue_s"} <= set(COLUMNS)
