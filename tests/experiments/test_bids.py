"""BIDS export checked by the reference validator (npm ``bids-validator``, installed by
scripts/setup), not by hand-written rules."""
from __future__ import annotations

import csv
import json
import shutil
import subprocess
from pathlib import Path

import pytest

from _session_helpers import P01, ROOT
from experiments.bids import PARTICIPANT_LEVEL_COLUMNS, bids_label, export_dataset
from experiments.bids_events import EVENT_COLUMNS, TRIAL_TYPES
from sessionfiles.logbook import TRIAL_COLUMNS

#: The study's authors, in its protocol's [protocol] table.
AUTHORS = ["Ada Lovelace", "Charles Babbage"]
BEH_COLUMNS = [c for c in TRIAL_COLUMNS if c not in PARTICIPANT_LEVEL_COLUMNS]

VALIDATOR = ROOT / ".venv" / "bids-validator" / "node_modules" / ".bin" / "bids-validator"


def validate(root: Path) -> dict:
    assert VALIDATOR.exists(), f"{VALIDATOR}: missing; run ./scripts/setup"
    run = subprocess.run([str(VALIDATOR), str(root), "--json"], capture_output=True, text=True,
                         timeout=300)
    start = run.stdout.index("{")
    return json.loads(run.stdout[start:])


def _with_authors(proto: Path, authors) -> Path:
    """``proto`` with ``authors`` in its [protocol] table."""
    text = proto.read_text()
    listed = ", ".join(json.dumps(a) for a in authors)
    proto.write_text(text.replace("[protocol]\n", f"[protocol]\nauthors = [{listed}]\n", 1))
    return proto


def _read_tsv(path: Path) -> list[dict]:
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh, delimiter="\t"))


def _hidden(root: Path) -> list[str]:
    return sorted(p.relative_to(root).as_posix() for p in root.rglob(".*"))


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """Two participants, P01 with two sessions, through `thermocue run` (simulated answers)."""
    from experiments.cli import main
    from test_two_audiences import _protocol
    tmp = tmp_path_factory.mktemp("bids")
    proto = _with_authors(_protocol(tmp), AUTHORS)
    data = tmp / "data"
    for record in (P01, P01, ROOT / "participants" / "examples" / "P02.json"):
        assert main(["run", str(proto), "--participant", str(record), "--display",
                     "emulator://?clock=virtual", "--responder", "simulated", "--data", str(data),
                     "--quiet"]) == 0
    return data


@pytest.mark.slow
def test_every_finished_session_is_valid_bids(study):
    root = study / "bids"
    beh = sorted(p.relative_to(root).as_posix() for p in root.rglob("*_beh.tsv"))
    assert beh == ["sub-P01/ses-S01/beh/sub-P01_ses-S01_task-mini_beh.tsv",
                   "sub-P01/ses-S02/beh/sub-P01_ses-S02_task-mini_beh.tsv",
                   "sub-P02/ses-S01/beh/sub-P02_ses-S01_task-mini_beh.tsv"]
    events = sorted(p.relative_to(root).as_posix() for p in root.rglob("*_events.tsv"))
    assert events == [b.replace("_beh.tsv", "_events.tsv") for b in beh]
    report = validate(root)
    assert report["issues"]["errors"] == [], report["issues"]["errors"]
    # The one warning: P02 lacks the second session P01 has (true of this data, nothing to fix).
    # No NO_AUTHORS: the protocol's [protocol] authors are the dataset's Authors.
    assert [w["key"] for w in report["issues"]["warnings"]] == ["MISSING_SESSION"]
    assert json.loads((root / "dataset_description.json").read_text())["Authors"] == AUTHORS
    assert report["summary"]["subjects"] == ["P01", "P02"] and report["summary"]["tasks"] == ["mini"]
    assert set(report["summary"]["dataTypes"]) == {"beh", "events"}
    # The TSV is the session's trials.csv (missing values n/a) without the participant's own
    # columns; the sidecar describes each column.
    tsv = (root / beh[0]).read_text().splitlines()
    with open(study / "P01" / "S01" / "trials.csv", newline="") as fh:
        table = list(csv.reader(fh))
    assert table[0] == list(TRIAL_COLUMNS)
    assert tsv[0].split("\t") == BEH_COLUMNS and len(tsv) == len(table)
    assert not {"sex", "group", "skin_thickness_um", "age"} & set(tsv[0].split("\t"))
    sidecar = json.loads((root / beh[0].replace(".tsv", ".json")).read_text())
    assert sidecar["rt_s"]["Units"] == "s" and "question" in sidecar["rt_s"]["Description"]
    assert set(BEH_COLUMNS) <= set(sidecar) and "sex" not in sidecar
    # The participant's own values: once, in participants.tsv, as the sessions' rows had them.
    people = _read_tsv(root / "participants.tsv")
    assert [(p["participant_id"], p["group"]) for p in people] == [("sub-P01", "A"), ("sub-P02", "B")]
    for person, folder in zip(people, ("P01/S01", "P02/S01")):
        with open(study / folder / "trials.csv", newline="") as fh:
            first = next(csv.DictReader(fh))
        assert (person["sex"], person["group"]) == (first["sex"], first["group"])
        assert float(person["skin_thickness_um"]) == float(first["skin_thickness_um"])
    described = json.loads((root / "participants.json").read_text())
    assert set(described["group"]["Levels"]) == {"A", "B"} and described["skin_thickness_um"]["Units"] == "um"
    # Nothing hidden left in the dataset (the participants.tsv lock is on the folder itself).
    assert _hidden(root) == []


@pytest.mark.slow
def test_the_validator_catches_a_broken_file(study, tmp_path):
    """The validator really reads the files: a row with a missing cell is an error."""
    root = tmp_path / "bids"
    shutil.copytree(study / "bids", root)
    tsv = next(root.rglob("*_beh.tsv"))
    lines = tsv.read_text().splitlines()
    lines[2] = lines[2].rsplit("\t", 1)[0]
    tsv.write_text("\n".join(lines) + "\n")
    report = validate(root)
    assert any(e["key"] == "TSV_EQUAL_ROWS" for e in report["issues"]["errors"]), report["issues"]


def test_export_dataset_rebuilds_it_and_labels_are_alphanumeric(study, tmp_path):
    written = export_dataset(study, tmp_path / "again")
    assert len(written) == 3 and all(p.exists() for p in written)
    assert bids_label("roughness_recognition") == "roughnessrecognition"
    with pytest.raises(ValueError):
        bids_label("__")


def test_export_bids_command(study, tmp_path, capsys):
    from experiments.cli import main
    assert main(["export-bids", str(study), "--out", str(tmp_path / "b")]) == 0
    assert capsys.readouterr().out == f"3 session(s) of 2 participant(s) -> {tmp_path / 'b'}\n"
    assert (tmp_path / "b" / "COMPLETE").is_file()
    assert main(["export-bids", str(tmp_path / "nothing")]) == 2


def test_a_non_durable_export_writes_the_same_files_without_one_fsync(study, tmp_path,
                                                                     monkeypatch):
    """A session with durability off (a simulated study's) exports without fsyncs; the files
    are those of a durable export, byte for byte."""
    import os
    from experiments.bids import export_session
    calls = []
    real = os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: (calls.append(fd), real(fd))[1])
    session = sorted(p.parent for p in study.glob("*/*/session.json"))[0]
    export_session(session, tmp_path / "off", durable=False)
    assert calls == []
    export_session(session, tmp_path / "on")                  # the default: durable
    files = sorted(p.relative_to(tmp_path / "on") for p in (tmp_path / "on").rglob("*")
                   if p.is_file())
    assert len(calls) >= 2 * len(files)                       # each file and its folder
    assert files == sorted(p.relative_to(tmp_path / "off") for p in (tmp_path / "off").rglob("*")
                           if p.is_file())
    for rel in files:
        assert (tmp_path / "off" / rel).read_bytes() == (tmp_path / "on" / rel).read_bytes()


@pytest.mark.slow
def test_a_rebuilt_dataset_with_its_complete_marker_is_valid_bids(study, tmp_path):
    """`export-bids` writes COMPLETE last and lists it in .bidsignore: still valid BIDS."""
    from experiments.cli import main
    out = tmp_path / "rebuilt"
    assert main(["export-bids", str(study), "--out", str(out)]) == 0
    assert (out / "COMPLETE").is_file() and "COMPLETE" in (out / ".bidsignore").read_text().split()
    report = validate(out)
    assert report["issues"]["errors"] == [], report["issues"]["errors"]
    assert report["summary"]["subjects"] == ["P01", "P02"]


def _log(folder: Path) -> list[dict]:
    return [json.loads(line) for line in (folder / "events.jsonl").read_text().splitlines()]


def _utc(text: str):
    import datetime as dt
    return dt.datetime.fromisoformat(text.replace("Z", "+00:00"))


@pytest.mark.slow
def test_events_tsv_times_every_trial_on_the_log_clock(study):
    """Each session's events.tsv against its own log and trials.csv: onsets in seconds from
    session_started on the log's clock, contact for real trials, playback for simulated ones,
    the answer inside its trial, the trial's values on every row."""
    root = study / "bids"
    for folder, stem in ((study / "P01" / "S01", "sub-P01/ses-S01/beh/sub-P01_ses-S01_task-mini"),
                         (study / "P02" / "S01", "sub-P02/ses-S01/beh/sub-P02_ses-S01_task-mini")):
        rows = _read_tsv(root / f"{stem}_events.tsv")
        assert list(rows[0]) == list(EVENT_COLUMNS)
        log = _log(folder)
        zero = _utc(log[0]["time"])
        assert log[0]["event"] == "session_started"
        onsets = [float(r["onset"]) for r in rows]
        assert onsets == sorted(onsets) and onsets[0] >= 0
        with open(folder / "trials.csv", newline="") as fh:
            trials = list(csv.DictReader(fh))
        assert {r["trial_type"] for r in rows} <= set(TRIAL_TYPES)
        for trial in trials:
            mine = [r for r in rows if r["trial_index"] == trial["trial_index"]
                    and r["attempt"] == trial["attempt"]]
            kinds = [r["trial_type"] for r in mine]
            touch = "contact" if trial["mode"] == "real" else "playback"
            answered = trial["response_id"] != ""
            assert kinds[0] == "trial" and kinds.count(touch) == 1 and kinds.count("cue") == 1
            assert kinds.count("response") == int(answered)
            assert ("contact" if touch == "playback" else "playback") not in kinds
            for r in mine:      # the trial's values on each of its rows
                assert (r["sample"], r["mode"], r["block"], r["status"]) == (
                    trial["roughness_id"], trial["mode"], trial["block"], trial["status"])
                assert r["response"] == (trial["response_id"] or "n/a")
                assert r["correct"] == (trial["correct"] or "n/a")
            # Times: the log's stamps of the trial's own events, minus session_started's.
            started = next(e for e in log if e["event"] == "trial_started"
                           and e["trial_index"] == int(trial["trial_index"]))
            ended = next(e for e in log if e["event"] == "trial_completed"
                         and e["trial_index"] == int(trial["trial_index"]))
            whole = mine[0]
            assert float(whole["onset"]) == pytest.approx((_utc(started["time"]) - zero).total_seconds(), abs=5e-4)
            assert float(whole["duration"]) == pytest.approx(
                (_utc(ended["time"]) - _utc(started["time"])).total_seconds(), abs=5e-4)
            state = "record" if touch == "contact" else "playback"     # the engine's state
            entered = next(e for e in log if e["event"] == "state" and e.get("to") == state
                           and e.get("trial_index") == int(trial["trial_index"]))
            contact = next(r for r in mine if r["trial_type"] == touch)
            # a virtual-clock session: the host's time of reading the first frame in contact and
            # of the recording's end, logged with the state once the trial ended
            assert _utc(entered["contact_at_utc"]) <= _utc(entered["ended_at_utc"]) <= _utc(entered["time"])
            assert float(contact["onset"]) == pytest.approx((_utc(entered["contact_at_utc"]) - zero).total_seconds(), abs=5e-4)
            assert float(contact["duration"]) == pytest.approx(
                (_utc(entered["ended_at_utc"]) - _utc(entered["contact_at_utc"])).total_seconds(), abs=5e-4)
            t0, t1 = float(whole["onset"]), float(whole["onset"]) + float(whole["duration"])
            for r in mine:
                assert t0 <= float(r["onset"]) <= t1 + 1e-9
                if r["duration"] != "n/a":
                    assert float(r["onset"]) + float(r["duration"]) <= t1 + 1e-9
            if answered:
                answer = next(r for r in mine if r["trial_type"] == "response")
                assert float(answer["onset"]) >= float(contact["onset"]) + float(contact["duration"]) - 1e-9
                assert answer["duration"] == "0.0"
        sidecar = json.loads((root / f"{stem}_events.json").read_text())
        assert set(sidecar) == set(EVENT_COLUMNS)
        assert sidecar["onset"]["Units"] == sidecar["duration"]["Units"] == "s"
        assert set(sidecar["trial_type"]["Levels"]) == set(TRIAL_TYPES)
        assert sidecar["roughness_um"]["Units"] == "um"


def test_an_attempt_without_contact_or_end_gets_no_made_up_time():
    """An attempt aborted before contact has no contact row; an attempt whose end was never
    logged (the session killed) has duration n/a and status n/a."""
    from experiments.bids_events import event_rows
    def ev(kind, t, **fields):
        return {"event": kind, "time": f"2026-01-01T10:00:{t:06.3f}Z", **fields}
    spec = {"block": "real", "mode": "real", "roughness_id": 2, "roughness_um": 12.5, "repetition": 1}
    log = [ev("session_started", 0.0, session="S01", participant="P01", protocol_hash="x", seed=1),
           ev("trial_started", 1.0, trial_index=1, attempt=1, **spec),
           ev("cue", 1.5, trial_index=1, attempt=1, played=True),
           ev("state", 1.6, trial_index=1, attempt=1, **{"from": "cue", "to": "wait_contact"}),
           ev("state", 6.6, trial_index=1, attempt=1, **{"from": "wait_contact", "to": "no_contact"}),
           ev("trial_aborted", 6.7, trial_index=1, attempt=1, reason="no contact"),
           ev("trial_started", 8.0, trial_index=1, attempt=2, **spec),
           ev("cue", 8.25, trial_index=1, attempt=2, played=False),
           ev("state", 9.0, trial_index=1, attempt=2, contact_at_utc="2026-01-01T10:00:08.500Z",
              ended_at_utc="2026-01-01T10:00:08.900Z", **{"from": "wait_contact", "to": "record"})]
    rows = [dict(zip(EVENT_COLUMNS, r)) for r in event_rows(log)]
    # Real clock: the recording's length is the row's (never written here): no contact row.
    assert [(r["onset"], r["duration"], r["trial_type"], r["attempt"], r["status"]) for r in rows] == [
        (1.0, 5.7, "trial", 1, "aborted"), (1.5, None, "cue", 1, "aborted"),
        (8.0, None, "trial", 2, None)]
    assert all(r["response"] is None and r["correct"] is None and r["sample"] == 2 for r in rows)
    assert event_rows(log[1:]) is None          # no session start: no onsets to give
    # Virtual clock: the host's own times of the contact and of the recording's end.
    virtual = [{**log[0], "clock": "virtual"}] + log[1:]
    assert [(r[0], r[1], r[2]) for r in event_rows(virtual)][-1] == (8.5, 0.4, "contact")
    # An attempt cut by a killed process, marked aborted when the session resumed: its end is
    # not known (the resume's time is not it).
    killed = log + [ev("session_resumed", 30.0, session="S01", participant="P01", protocol_hash="x",
                       seed=1),
                    ev("trial_aborted", 30.1, trial_index=1, attempt=2, reason="killed")]
    rows = [dict(zip(EVENT_COLUMNS, r)) for r in event_rows(killed)]
    assert [(r["onset"], r["duration"], r["attempt"], r["status"]) for r in rows if r["trial_type"] == "trial"] \
        == [(1.0, 5.7, 1, "aborted"), (8.0, None, 2, "aborted")]
    # A state logged without those times (an earlier version's log): no contact row.
    old = [{k: v for k, v in e.items() if not k.endswith("_at_utc")} for e in virtual]
    assert "contact" not in [r[2] for r in event_rows(old)]


def test_spoken_answers_are_timed_when_keyed_and_a_question_may_outlast_its_trial():
    from experiments.bids_events import event_rows
    def ev(kind, t, **fields):
        return {"event": kind, "time": f"2026-01-01T10:00:{t:06.3f}Z", **fields}
    spec = {"block": "real", "mode": "simulated", "roughness_id": 3, "roughness_um": 50.0}
    log = [ev("session_started", 0.0, session="S01", participant="P01", protocol_hash="x", seed=1),
           ev("trial_started", 1.0, trial_index=1, attempt=1, **spec),
           ev("state", 4.0, trial_index=1, attempt=1, contact_at_utc="2026-01-01T10:00:02.900Z",
              ended_at_utc="2026-01-01T10:00:03.250Z", **{"from": "wait_contact", "to": "playback"}),
           ev("question_cue", 4.5, trial_index=1, played=True),
           ev("answer_keyed", 6.0, trial_index=1, key="2", after_cue_s=1.5),
           ev("answer_undone", 6.5, trial_index=1, key="2", replaced_by="3"),
           ev("answer_keyed", 7.0, trial_index=1, key="3", after_cue_s=2.5),
           ev("answer_confirmed", 8.0, trial_index=1, key="3"),
           ev("response", 8.1, trial_index=1, attempt=1, response_id=3, answer_mode="spoken"),
           ev("trial_completed", 8.2, trial_index=1, attempt=1,
              row={"status": "ok", "correct": 1, "contact_duration_s": 1.25}),
           ev("trial_started", 10.0, trial_index=2, attempt=1, **spec),
           ev("text_on", 11.0, state="question", text="Which sample?"),
           ev("response", 12.0, trial_index=2, attempt=1, response_id=1, answer_mode="keyed"),
           ev("trial_completed", 12.1, trial_index=2, attempt=1, row={"status": "ok", "correct": 0}),
           ev("text_off", 13.0, state="question")]
    rows = [dict(zip(EVENT_COLUMNS, r)) for r in event_rows(log)]
    assert [(r["onset"], r["duration"], r["trial_type"], r["trial_index"], r["response"], r["correct"],
             r["answer_mode"]) for r in rows] == [
        (1.0, 7.2, "trial", 1, 3, 1, "spoken"), (2.0, 1.25, "playback", 1, 3, 1, "spoken"),
        (4.5, None, "question_cue", 1, 3, 1, "spoken"), (7.0, 0.0, "response", 1, 3, 1, "spoken"),
        (10.0, 2.1, "trial", 2, 1, 0, "keyed"), (11.0, 2.0, "question", 2, 1, 0, "keyed"),
        (12.0, 0.0, "response", 2, 1, 0, "keyed")]


@pytest.mark.slow
def test_authors_from_the_command_line_or_one_line_saying_how(study, tmp_path, capsys):
    """--author NAME (repeatable) replaces the protocol's; a study without either is exported,
    with one warning line naming the file and both ways to add them."""
    from experiments.cli import main
    out = tmp_path / "given"
    assert main(["export-bids", str(study), "--out", str(out), "--author", "Grace Hopper",
                 "--author", "Alan Turing"]) == 0
    assert json.loads((out / "dataset_description.json").read_text())["Authors"] == [
        "Grace Hopper", "Alan Turing"]
    assert "Authors" not in capsys.readouterr().err
    report = validate(out)
    assert report["issues"]["errors"] == []
    assert [w["key"] for w in report["issues"]["warnings"]] == ["MISSING_SESSION"]
    # A protocol without authors, no --author: written, and told.
    from test_two_audiences import _protocol
    data = tmp_path / "data"
    assert main(["run", str(_protocol(tmp_path)), "--participant", str(P01), "--display",
                 "emulator://?clock=virtual", "--responder", "simulated", "--data", str(data),
                 "--quiet"]) == 0
    capsys.readouterr()
    bare = tmp_path / "bare"
    assert main(["export-bids", str(data), "--out", str(bare)]) == 0
    err = [line for line in capsys.readouterr().err.splitlines() if "Authors" in line]
    assert err == [f"thermocue export-bids: warning: {bare / 'dataset_description.json'}: Authors: "
                   f"none given (the BIDS validator warns NO_AUTHORS); add `authors = [\"Name\", "
                   f"...]` to the protocol's [protocol] table, or pass --author NAME (once per author)"]
    assert "Authors" not in json.loads((bare / "dataset_description.json").read_text())
    assert [w["key"] for w in validate(bare)["issues"]["warnings"]] == ["NO_AUTHORS"]


def test_protocol_authors_are_checked(tmp_path):
    from test_two_audiences import _protocol
    from experiments.errors import ProtocolError
    from experiments.protocol import load_protocol
    proto = _protocol(tmp_path)
    assert load_protocol(proto).authors == ()
    assert load_protocol(_with_authors(proto, ["A. B.", "C. D."])).authors == ("A. B.", "C. D.")
    for bad, what in (("\"A. B.\"", r"protocol\.authors: expected .*a list of author names"),
                      ("[\"A\", \"\"]", r"protocol\.authors\[1\]: expected a non-empty string, got ''"),
                      ("[\"A\", \"A\"]", r"protocol\.authors: expected each author once")):
        text = _protocol(tmp_path).read_text().replace("[protocol]\n", f"[protocol]\nauthors = {bad}\n", 1)
        proto.write_text(text)
        with pytest.raises(ProtocolError, match=what):
            load_protocol(proto)


def _merge_many(root, worker, n):
    from experiments.bids import _participants
    for i in range(n):
        _participants(Path(root), {f"sub-W{worker}N{i}": {"participant_id": f"sub-W{worker}N{i}",
                                                           "group": "A"}})


def test_parallel_sessions_lose_no_participant_and_leave_no_lock_file(tmp_path):
    """Sessions finishing at once (separate processes) each merge their participant into
    participants.tsv: all of them are there, and no lock file is left in the dataset."""
    import multiprocessing
    root = tmp_path / "bids"
    root.mkdir()
    (root / ".participants.lock").write_text("")        # left by an earlier version: removed
    ctx = multiprocessing.get_context("fork")
    workers = [ctx.Process(target=_merge_many, args=(str(root), w, 40)) for w in range(4)]
    for w in workers:
        w.start()
    for w in workers:
        w.join(120)
        assert w.exitcode == 0
    ids = [r["participant_id"] for r in _read_tsv(root / "participants.tsv")]
    assert sorted(ids) == sorted(f"sub-W{w}N{i}" for w in range(4) for i in range(40))
    assert _hidden(root) == []


@pytest.mark.slow
@pytest.mark.gui
def test_a_window_session_on_the_real_clock_has_its_question_and_real_durations(tmp_path, xvfb):
    """A PsychoPy-window session on the real clock (real X keys, the emulator on a pty): its
    events.tsv has the question rows, and the contact lasted, on the log's clock, at least the
    protocol's recording time (the device records record_s = 1 s from the contact on)."""
    import os
    if shutil.which("xdotool") is None:
        pytest.skip("xdotool is not installed")
    from _session_helpers import write_protocol
    from test_session_gui import THERMOCUE, _run_answering
    link = tmp_path / "thermo-pty"
    emulator = subprocess.Popen(THERMOCUE + ["emulator", "--link", str(link)],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        import time
        deadline = time.monotonic() + 20
        while not link.exists():
            assert emulator.poll() is None and time.monotonic() < deadline, "emulator did not start"
            time.sleep(0.05)
        proto = _with_authors(write_protocol(tmp_path, contact_s=1.0, rewarm_s=0.0,
                                             real_samples=(2,), sim_samples=(3,)), AUTHORS)
        data = tmp_path / "data"
        run, _, _, err = _run_answering(
            THERMOCUE + ["run", str(proto), "--participant", str(P01), "--display", str(link),
                         "--responder", "psychopy", "--data", str(data), "--session", "S01",
                         "--responder-option", "max_wait_s=40"],
            {**os.environ, **xvfb}, data / "P01" / "S01" / "events.jsonl")
    finally:
        emulator.terminate()
        emulator.wait(timeout=10)
    assert run.returncode == 0, err[-2000:]
    root = data / "bids"
    rows = _read_tsv(root / "sub-P01/ses-S01/beh/sub-P01_ses-S01_task-mini_events.tsv")
    log = _log(data / "P01" / "S01")
    assert log[0]["clock"] == "real"
    with open(data / "P01" / "S01" / "trials.csv", newline="") as fh:
        trials = [t for t in csv.DictReader(fh) if t["status"] == "ok"]
    assert [(t["mode"], t["roughness_id"]) for t in trials] == [("real", "2"), ("simulated", "3")]
    for t in trials:
        mine = [r for r in rows if (r["trial_index"], r["attempt"]) == (t["trial_index"], t["attempt"])]
        kinds = [r["trial_type"] for r in mine]
        touch = "contact" if t["mode"] == "real" else "playback"
        assert kinds.count(touch) == 1 and kinds.count("question") == 1 and kinds.count("response") == 1
        contact = mine[kinds.index(touch)]
        question = mine[kinds.index("question")]
        answer = mine[kinds.index("response")]
        # The recording's length (the display's clock) ending when the host had it back: with
        # the engine's state event's ended_at_utc, on the log's clock.
        assert float(contact["duration"]) == pytest.approx(float(t["contact_duration_s"]), abs=1e-3)
        entered = next(e for e in log if e["event"] == "state" and e.get("to") == ("record" if touch == "contact" else "playback")
                       and e.get("trial_index") == int(t["trial_index"]) and e.get("attempt") == int(t["attempt"]))
        end = (_utc(entered["ended_at_utc"]) - _utc(log[0]["time"])).total_seconds()
        assert float(contact["onset"]) + float(contact["duration"]) == pytest.approx(end, abs=2e-3)
        # the question came after the touch ended, the answer while it was up (or as it went)
        assert float(question["onset"]) >= end - 0.002
        assert float(question["onset"]) <= float(answer["onset"])
        if question["duration"] != "n/a":
            assert float(answer["onset"]) <= float(question["onset"]) + float(question["duration"]) + 0.002
        assert answer["response"] == t["response_id"] == t["roughness_id"]
    report = validate(root)
    assert report["issues"]["errors"] == [] and report["issues"]["warnings"] == [], report["issues"]


def test_faulted_and_contactless_attempts_in_the_events_and_still_valid_bids(tmp_path):
    """The engine's own outcomes (the scripted stand-in display: a link error, a faulted
    recording, no contact): every attempt has its trial row with its status; a contact row only
    where the display saw contact; no response where none was asked; valid BIDS."""
    from _session_helpers import ScriptedDisplay, ScriptedResponder, write_protocol
    from experiments.bids import export_session
    from experiments.session import create_session
    proto = _with_authors(write_protocol(tmp_path, sim_samples=()), AUTHORS)
    s = create_session(proto, P01, tmp_path / "data", "scripted://", seed=7,
                       responder_name="scripted-test", clock="virtual")
    assert s.run(ScriptedResponder(), display=ScriptedDisplay(
        script=["ok", "raise", "fault", "ok", "no_contact", "ok"])) == 0
    beh = export_session(s.directory, tmp_path / "bids")
    rows = _read_tsv(beh.with_name(beh.name.replace("_beh.tsv", "_events.tsv")))
    seen = [(r["trial_index"], r["attempt"], r["trial_type"], r["status"], r["response"])
            for r in rows if r["trial_index"] in ("2", "3") and r["trial_type"] != "cue"]
    with open(s.directory / "trials.csv", newline="") as fh:
        answers = {t["trial_index"]: t["response_id"] for t in csv.DictReader(fh) if t["status"] == "ok"}
    two, three = answers["2"], answers["3"]
    assert two and three
    assert seen == [
        ("2", "1", "trial", "fault", "n/a"),                 # the link error: no recording
        ("2", "2", "trial", "fault", "n/a"), ("2", "2", "contact", "fault", "n/a"),  # then a fault
        ("2", "3", "trial", "ok", two), ("2", "3", "contact", "ok", two), ("2", "3", "response", "ok", two),
        ("3", "1", "trial", "aborted", "n/a"),               # no contact
        ("3", "2", "trial", "ok", three), ("3", "2", "contact", "ok", three),
        ("3", "2", "response", "ok", three)]
    report = validate(tmp_path / "bids")
    assert report["issues"]["errors"] == [] and report["issues"]["warnings"] == [], report["issues"]
