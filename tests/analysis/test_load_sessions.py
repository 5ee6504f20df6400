"""An explicit session-inclusion policy: on the old code a participant's
repeated and interrupted sessions were all pooled, unflagged."""
from __future__ import annotations

import json
import re
from importlib.resources import files
from pathlib import Path

import pytest

from analysis.load import load_trials
from analysis.report_markdown import sessions_markdown
from experiments.responders.base import Responder, ResponderClosed, Response

ROOT = Path(__file__).resolve().parents[2]


class Answers(Responder, name="answers-until-test"):
    human = False

    def __init__(self, stop_at=None):
        super().__init__()
        self.stop_at = stop_at

    def respond(self, trial, stimulus):
        if self.stop_at is not None and trial.trial_index >= self.stop_at:
            raise ResponderClosed("the participant left")
        return Response(trial.roughness_id, 0.4, source="test")


def _protocol(folder: Path) -> Path:
    text = (files("experiments") / "protocols" / "roughness_recognition.toml").read_text("utf-8")
    for key in ("max_contact_s", "record_s", "duration_s"):
        text = re.sub(rf"^{key} = 20\.0", f"{key} = 0.5", text, flags=re.M)
    text = re.sub(r"^repetitions = 3", "repetitions = 1", text, flags=re.M)
    path = folder / "short.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    from experiments.session import create_session
    tmp = tmp_path_factory.mktemp("sessions")
    proto = _protocol(tmp)
    record = json.loads((ROOT / "participants" / "examples" / "P02.json").read_text())
    record["initial_skin_temperature_C"] = 31.0       # a cold finger: every trial out of range
    (tmp / "P02.json").write_text(json.dumps(record))
    data = tmp / "data"
    plan = [(ROOT / "participants" / "examples" / "P01.json", None),
            (ROOT / "participants" / "examples" / "P01.json", None),
            (tmp / "P02.json", 7), (tmp / "P02.json", None)]
    for i, (record_path, stop_at) in enumerate(plan):
        s = create_session(proto, record_path, data, "emulator://?clock=virtual&seed=1", seed=i,
                           responder_name="answers-until-test", clock="virtual")
        assert s.run(Answers(stop_at)) == (1 if stop_at else 0)
    return data


def _table(log):
    return {(r.participant, r.session): (r.analysed, r.reason) for r in log.sessions.itertuples()}


def test_first_complete_session_per_participant_by_default(data):
    log = load_trials(data)
    assert _table(log) == {
        ("P01", "S01"): (True, "analysed: the first complete session of P01"),
        ("P01", "S02"): (False, "repeated session: P01's first complete session is S01"),
        ("P02", "S01"): (False, "incomplete: 6 of 12 trials"),
        ("P02", "S02"): (True, "analysed: the first complete session of P02"),
    }
    used = log.analysable.groupby(["participant", "session"]).size().to_dict()
    assert used == {("P01", "S01"): 8, ("P02", "S02"): 8}
    t = log.trials
    assert (t.loc[t["session"].eq("S02") & t["participant"].eq("P01"), "exclusion"]
            == "session not analysed").all()


def test_latest_and_all(data):
    assert {k for k, v in _table(load_trials(data, sessions="latest")).items() if v[0]} == \
        {("P01", "S02"), ("P02", "S02")}
    log = load_trials(data, sessions="all")
    assert all(v[0] for v in _table(log).values())
    assert _table(log)[("P02", "S01")][1] == "analysed (--sessions all); incomplete: 6 of 12 trials"
    assert len(log.analysable) == 8 * 3 + 2


def test_the_report_lists_every_session_and_the_cold_trials(data):
    text = "\n".join(sessions_markdown(load_trials(data)))
    assert "Inclusion policy (`--sessions first`): each participant's first complete session." in text
    # each session names the device it ran on and the image id its HELLO reported
    assert ("| P02 | S01 | emulator/press | EMU-0001 | emulator-1.0.0 | no | 6 | 12 | no | "
            "incomplete: 6 of 12 trials |") in text
    assert ("| P01 | S02 | emulator/press | EMU-0001 | emulator-1.0.0 | yes | 12 | 12 | no | "
            "repeated session: P01's first complete session is S01 |") in text
    cold = re.search(r"(\d+) trial\(s\) were run with the fingertip outside", text)
    assert cold and int(cold.group(1)) == 6 + 12      # every P02 trial, both sessions


@pytest.mark.parametrize("damage", ["", "{not json\n"])
def test_session_state_from_the_folder_read_equals_reading_the_log_again(tmp_path, damage):
    """The loader hands ``session_state`` the folder it has read (its log is not read twice);
    the state must be what reading the log anew, every damaged line skipped, gives: with a
    damaged line before ``session_finished`` the folder's own reading stops there, so the
    state still comes from the whole log."""
    from analysis.session_policy import session_state
    from sessionfiles.session_reader import read_session_folder
    folder = tmp_path / "P01" / "S1"
    folder.mkdir(parents=True)
    meta = {"participant": "P01", "session": "S1", "schedule": [{}, {}, {}]}
    (folder / "session.json").write_text(json.dumps(meta))
    events = [{"event": "session_started", "participant": "P01", "session": "S1"}]
    events += [{"event": "trial_completed", "trial_index": i, "row": {"status": "ok"}}
               for i in range(3)]
    lines = [json.dumps(e) + "\n" for e in events]
    lines.insert(2, damage)
    lines.append(json.dumps({"event": "session_finished"}) + "\n")
    (folder / "events.jsonl").write_text("".join(lines))
    read = read_session_folder(folder)
    assert (read.events_report.stopped_at is None) == (damage == "")
    again = session_state(folder, meta)
    assert session_state(folder, meta, read) == again
    assert again["complete"] is True and again["n_done"] == 3
