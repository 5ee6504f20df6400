"""Durable session files: fsynced appends, torn-line tolerance, atomic rewrites, trials rebuild."""
from __future__ import annotations

import csv
import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import textwrap
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import sessionfiles.logbook as logbook
from sessionfiles.errors import SessionError
from sessionfiles.logbook import (
    TRIAL_COLUMNS,
    EventLog,
    LogDamageWarning,
    atomic_write_json,
    atomic_write_text,
    ensure_dir,
    read_events,
    replay,
    trials_from_events,
    write_trials_csv,
)


def lines(path):
    return Path(path).read_bytes().split(b"\n")


# --------------------------------------------------------------------------- appends
def test_append_and_read_back(tmp_path):
    path = tmp_path / "events.jsonl"
    with EventLog(path) as log:
        a = log.append("note", text="first")
        b = log.append("note", text="ünïcode", value=np.float64(1.5), arr=np.arange(3), nan=math.nan)
    events, report = read_events(path)
    assert report.ok and report.n_events == 2
    assert events == [a, b]
    assert [e["seq"] for e in events] == [1, 2]
    assert events[1]["value"] == 1.5 and events[1]["arr"] == [0, 1, 2] and events[1]["nan"] is None
    assert events[0]["time"].endswith("Z") and "T" in events[0]["time"]
    # one object per line, each line whole
    raw = lines(path)
    assert raw[-1] == b"" and len(raw) == 3
    assert all(json.loads(x) for x in raw[:-1])


def test_every_append_is_fsynced_and_a_new_file_fsyncs_its_folder(tmp_path, monkeypatch):
    calls = []
    real_fsync = os.fsync
    monkeypatch.setattr(logbook.os, "fsync", lambda fd: (calls.append(fd), real_fsync(fd))[1])
    dir_calls = []
    real_fsync_dir = logbook.fsync_dir
    monkeypatch.setattr(logbook, "fsync_dir",
                        lambda p, durable=True: (dir_calls.append(Path(p)), real_fsync_dir(p, durable))[1])
    path = tmp_path / "events.jsonl"
    log = EventLog(path)
    assert dir_calls == [tmp_path]
    n0 = len(calls)
    for i in range(5):
        log.append("note", i=i)
        assert len(calls) == n0 + i + 1          # fsynced before append returned
    log.close()
    dir_calls.clear()
    EventLog(path).close()                        # reopening an existing file: no new entry
    assert dir_calls == []


def test_reopen_continues_seq(tmp_path):
    path = tmp_path / "events.jsonl"
    with EventLog(path) as log:
        log.append("note")
        log.append("note")
    with EventLog(path) as log:
        assert log.seq == 2
        assert log.append("note")["seq"] == 3


def test_appends_from_threads_stay_whole(tmp_path):

    path = tmp_path / "events.jsonl"
    with EventLog(path) as log:
        def work(k):
            for i in range(25):
                log.append("note", thread=k, i=i, pad="y" * 3000)
        threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    events, report = read_events(path)
    assert report.ok
    assert [e["seq"] for e in events] == list(range(1, 101))
    for k in range(4):
        assert [e["i"] for e in events if e["thread"] == k] == list(range(25))


def test_append_validates(tmp_path):
    with EventLog(tmp_path / "e.jsonl") as log:
        with pytest.raises(ValueError, match=r"trial_completed\.row: expected a value, got nothing"):
            log.append("trial_completed", trial_index=1, attempt=1)
        with pytest.raises(ValueError, match="event: expected a snake_case name, got 'Trial Done'"):
            log.append("Trial Done")
        with pytest.raises(ValueError, match=r"note\.seq: expected no value"):
            log.append("note", seq=5)
        with pytest.raises(TypeError, match="expected a JSON-ready value, got object"):
            log.append("note", thing=object())
        assert log.seq == 0
    with pytest.raises(ValueError, match="closed"):
        log.append("note")
    assert read_events(tmp_path / "e.jsonl")[0] == []


def test_second_writer_is_refused(tmp_path):
    path = tmp_path / "events.jsonl"
    with EventLog(path):
        with pytest.raises(SessionError, match="events.jsonl: expected no other process writing this log"):
            EventLog(path)
    EventLog(path).close()    # released on close


# --------------------------------------------------------------------------- damage
def two_events_and(tmp_path, tail: bytes) -> Path:
    path = tmp_path / "events.jsonl"
    with EventLog(path) as log:
        log.append("note", i=1)
        log.append("note", i=2)
    with open(path, "ab") as fh:
        fh.write(tail)
    return path


def test_torn_last_line_is_tolerated_with_a_warning(tmp_path):
    path = two_events_and(tmp_path, b'{"event":"note","seq":3,"ti')
    with pytest.warns(LogDamageWarning, match=rf"{path}: line 3: torn last line \(27 bytes\) ignored"):
        events, report = read_events(path)
    assert [e["i"] for e in events] == [1, 2]
    assert not report.ok
    assert report.torn_line == 3 and report.torn_tail == b'{"event":"note","seq":3,"ti'
    assert "torn last line 3" in report.describe()


def test_whole_last_line_without_newline_is_kept(tmp_path):
    path = two_events_and(tmp_path, b'{"event":"note","seq":3,"i":3}')
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        events, report = read_events(path)
    assert [e["i"] for e in events] == [1, 2, 3]
    assert report.ok and report.missing_newline
    with EventLog(path) as log:                  # the next append starts on its own line
        log.append("note", i=4)
    assert [e["i"] for e in read_events(path)[0]] == [1, 2, 3, 4]


@pytest.mark.parametrize("bad", [b"not json", b'{"no_event": 1}', b"\xff\xfe{}", b"[1, 2]"])
def test_undecodable_middle_line(tmp_path, bad):
    path = two_events_and(tmp_path, bad + b'\n{"event":"note","seq":4,"i":4}\n')
    with pytest.warns(LogDamageWarning, match=rf"{path}: line 3: undecodable line .*; events read up to line 2"):
        events, report = read_events(path)
    assert [e["i"] for e in events] == [1, 2]
    assert report.stopped_at == 3 and report.bad_lines[0][0] == 3
    with pytest.warns(LogDamageWarning, match="line 3: undecodable line .* skipped"):
        events, report = read_events(path, on_damage="skip")
    assert [e["i"] for e in events] == [1, 2, 4]
    # appending after buried damage is refused: it needs a human
    with pytest.raises(SessionError, match=r"events.jsonl: line 3: expected one JSON event per line"):
        EventLog(path)


def test_reopen_cuts_a_torn_tail_and_keeps_its_bytes(tmp_path):
    path = two_events_and(tmp_path, b'{"event":"trial_started","tri')
    with EventLog(path) as log:
        assert log.seq == 3                      # the repair note is seq 3
        log.append("note", i=5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        events, report = read_events(path)
    assert report.ok
    assert [e["event"] for e in events] == ["note", "note", "log_repaired", "note"]
    assert events[2]["torn_tail"] == '{"event":"trial_started","tri' and events[2]["torn_bytes"] == 29
    assert [e["seq"] for e in events] == [1, 2, 3, 4]


def test_missing_log():
    with pytest.raises(FileNotFoundError):
        read_events("/nonexistent/events.jsonl")


def _reference_log(directory: Path) -> tuple[bytes, list[dict]]:
    path = directory / "ref.jsonl"
    with EventLog(path) as log:
        evs = [log.append("note", i=i, text="é" * (i * 7 % 23), pad="x" * (i * 37 % 101)) for i in range(12)]
    return path.read_bytes(), evs


@settings(max_examples=60, deadline=None)
@given(cut=st.integers(min_value=0, max_value=10**6))
def test_any_truncation_reads_as_a_prefix(cut):
    """A log cut at any byte (even inside a UTF-8 character) reads as the whole lines before the
    cut; a partial line is reported as torn, with a warning."""

    with tempfile.TemporaryDirectory() as d:
        data, evs = _reference_log(Path(d))
        cut = cut % (len(data) + 1)
        path = Path(d) / "events.jsonl"
        path.write_bytes(data[:cut])
        whole = data[:cut].count(b"\n")
        tail = data[:cut].rsplit(b"\n", 1)[-1]
        if tail and data[cut:cut + 1] == b"\n":    # the whole last line, only its newline cut
            whole, tail = whole + 1, b""
        partial = bool(tail)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            events, report = read_events(path)
        assert events == evs[:whole]
        assert (report.torn_tail is not None) == partial
        assert len(caught) == int(partial)
        with EventLog(path) as log:                 # and the writer repairs it and goes on
            log.append("note", i=99)
        events, report = read_events(path)
        assert report.ok and events[:whole] == evs[:whole] and events[-1]["i"] == 99


# --------------------------------------------------------------------------- SIGKILL
WRITER = textwrap.dedent("""
    import sys
    from sessionfiles.logbook import EventLog
    log = EventLog(sys.argv[1])
    pad = "x" * int(sys.argv[2])
    while True:
        ev = log.append("trial_completed", trial_index=log.seq + 1, attempt=1,
                        row={"status": "ok", "pad": pad})
        print(ev["seq"], flush=True)
""")


def test_sigkill_mid_append_leaves_a_readable_log(tmp_path):
    """A writer killed with SIGKILL at arbitrary points: every acknowledged event is on disk,
    the log reads cleanly up to the last whole line and can be continued (three rounds)."""
    path = tmp_path / "events.jsonl"
    script = tmp_path / "writer.py"
    script.write_text(WRITER)
    acked_total = 0
    for round_, pad in enumerate((10, 5000, 70000)):     # small and pipe-buffer-sized lines
        proc = subprocess.Popen([sys.executable, str(script), str(path), str(pad)],
                                stdout=subprocess.PIPE, text=True)
        acked = []
        deadline = time.monotonic() + 20
        while len(acked) < 15 + 5 * round_ and time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            acked.append(int(line))
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
        proc.stdout.close()
        assert proc.returncode == -signal.SIGKILL
        assert len(acked) >= 15
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            events, report = read_events(path)
        assert not report.bad_lines
        # a torn tail may or may not exist; if it does it was reported as a warning
        assert (report.torn_tail is not None) == any(issubclass(w.category, LogDamageWarning) for w in caught)
        seqs = [e["seq"] for e in events]
        assert seqs == list(range(1, len(seqs) + 1))       # no gap, no duplicate
        assert max(acked) <= seqs[-1]                       # nothing acknowledged was lost
        assert acked[0] > acked_total                       # continued after the previous kill
        rows = trials_from_events(events)
        assert len(rows) == len([e for e in events if e["event"] == "trial_completed"])
        acked_total = seqs[-1]
    with EventLog(path) as log:                             # still appendable
        log.append("session_finished")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        events, report = read_events(path)
    assert report.ok and events[-1]["event"] == "session_finished"


# --------------------------------------------------------------------------- atomic files
def test_atomic_write_replaces_and_leaves_no_temp(tmp_path, monkeypatch):
    synced = []
    real = logbook.fsync_dir
    monkeypatch.setattr(logbook, "fsync_dir",
                        lambda p, durable=True: (synced.append(Path(p)), real(p, durable))[1])
    target = tmp_path / "session.json"
    atomic_write_json(target, {"a": 1, "x": np.int64(3), "p": Path("/tmp")})
    assert json.loads(target.read_text()) == {"a": 1, "x": 3, "p": "/tmp"}
    atomic_write_text(target, "new\n")
    assert target.read_text() == "new\n"
    assert synced == [tmp_path, tmp_path]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["session.json"]


def test_failed_atomic_write_keeps_the_old_file(tmp_path, monkeypatch):
    target = tmp_path / "session.json"
    atomic_write_text(target, "old\n")

    def boom(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(logbook.os, "replace", boom)
    with pytest.raises(OSError, match="disk full"):
        atomic_write_text(target, "new\n")
    assert target.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["session.json"]


def test_ensure_dir(tmp_path):
    d = ensure_dir(tmp_path / "data" / "P07" / "s1")
    assert d.is_dir()
    assert ensure_dir(d) == d
    (tmp_path / "f").write_text("")
    with pytest.raises(NotADirectoryError):
        ensure_dir(tmp_path / "f")


# --------------------------------------------------------------------------- trials table
def session_events(tmp_path):
    """A session: trial 1 done, trial 2 cut off and re-run, trial 3 faulted, finished."""
    path = tmp_path / "events.jsonl"
    spec = {"block": "real", "mode": "real", "roughness_um": 12.5, "repetition": 1}
    with EventLog(path) as log:
        log.append("session_started", session="s1", participant="P07", group="A", protocol_hash="h",
                   seed=1, skin_thickness_um=700.0, sex="female", n_trials=3)
        log.append("trial_started", trial_index=1, attempt=1, roughness_id=2, **spec)
        log.append("trial_completed", trial_index=1, attempt=1,
                   row={"response_id": 2, "rt_s": 1.25, "tracking_rms_C": 0.031})
        log.append("trial_started", trial_index=2, attempt=1, roughness_id=3, **dict(spec, roughness_um=50.0))
    with EventLog(path) as log:                     # crash, then resume
        log.append("session_resumed", session="s1", participant="P07", group="A", protocol_hash="h", seed=1)
        log.append("trial_aborted", trial_index=2, attempt=1, reason="interrupted")
        log.append("trial_started", trial_index=2, attempt=2, roughness_id=3, **dict(spec, roughness_um=50.0))
        log.append("trial_completed", trial_index=2, attempt=2,
                   row={"response_id": 4, "rt_s": 2.5, "tracking_rms_C": math.nan})
        log.append("trial_started", trial_index=3, attempt=1, roughness_id=1, **dict(spec, roughness_um=1.6))
        log.append("trial_completed", trial_index=3, attempt=1,
                   row={"status": "fault", "fault_code": "E_OVERTEMP", "response_id": None})
        log.append("session_finished", n_completed=3)
    return path


def test_trials_from_events(tmp_path):
    events, _ = read_events(session_events(tmp_path))
    rows = trials_from_events(events)
    assert [(r["trial_index"], r["attempt"], r["status"]) for r in rows] == [
        (1, 1, "ok"), (2, 1, "aborted"), (2, 2, "ok"), (3, 1, "fault")]
    for r in rows:
        assert (r["participant"], r["session"], r["group"], r["sex"]) == ("P07", "s1", "A", "female")
        assert r["skin_thickness_um"] == 700.0 and r["block"] == "real"
        assert r["started_at_utc"].endswith("Z")
        # PsychoPy's 0-based counter beside the 1-based one; no window ran: n/a, said so
        assert r["thisN"] == r["trial_index"] - 1
        assert (r["psychopyVersion"], r["frameRate"]) == ("n/a", "n/a")
    assert rows[0]["correct"] == 1 and rows[2]["correct"] == 0     # 2 == 2; 4 != 3
    assert rows[1]["abort_reason"] == "interrupted" and rows[1]["roughness_id"] == 3
    assert rows[2]["tracking_rms_C"] is None                     # NaN written as null
    assert rows[3]["fault_code"] == "E_OVERTEMP" and rows[3].get("correct") is None


def test_duplicate_outcome_is_ignored_with_a_warning(tmp_path):
    events, _ = read_events(session_events(tmp_path))
    dup = dict(next(e for e in events if e["event"] == "trial_completed"), seq=99)
    with pytest.warns(LogDamageWarning, match="trial 1 attempt 1: a second trial_completed event"):
        rows = trials_from_events(events + [dup])
    assert len(rows) == 4


def test_trials_csv_rebuilt_from_events(tmp_path):
    events, _ = read_events(session_events(tmp_path))
    out = tmp_path / "trials.csv"
    cols = write_trials_csv(out, trials_from_events(events))
    assert cols == list(TRIAL_COLUMNS)            # abort_reason is one of the fixed columns
    with open(out, newline="") as fh:
        table = list(csv.DictReader(fh))
    assert len(table) == 4
    assert {r["participant"] for r in table} == {"P07"} and {r["session"] for r in table} == {"s1"}
    assert table[0]["rt_s"] == "1.25" and table[0]["correct"] == "1" and table[0]["roughness_um"] == "12.5"
    assert table[2]["tracking_rms_C"] == "" and table[1]["status"] == "aborted"
    first = out.read_bytes()
    write_trials_csv(out, trials_from_events(read_events(tmp_path / "events.jsonl")[0]))
    assert out.read_bytes() == first             # a rebuild is byte-identical


def test_replay(tmp_path):
    events, _ = read_events(session_events(tmp_path))
    cut = [e for e in events if e["seq"] <= 4]            # as the log stood at the crash
    p = replay(cut)
    assert p.session["participant"] == "P07"
    assert p.completed == {1: "ok"}
    assert p.open_attempts == [(2, 1)]
    assert p.next_attempt(2) == 2 and p.next_attempt(3) == 1
    assert p.first_incomplete([1, 2, 3]) == 2
    assert not p.finished and p.last_seq == 4
    p = replay(events)
    assert p.completed == {1: "ok", 2: "ok", 3: "fault"}
    assert p.open_attempts == [] and p.aborted == [(2, 1)]
    assert p.finished and p.first_incomplete([1, 2, 3]) is None


def test_floats_are_rounded_to_the_instruments_resolution(tmp_path):
    # "168.85999999999999" in trials.csv
    from sessionfiles.logbook import write_trials_csv
    out = tmp_path / "trials.csv"
    write_trials_csv(out, [{"contact_onset_s": 168.85999999999999, "rt_s": 1.2345678,
                            "skin_temperature_C": 35.504999, "profile_resistance_m2K_W": 6.494477e-4,
                            "tracking_rms_C": 0.0, "correct": True, "cue_played": False}])
    with open(out, newline="") as fh:
        row, = list(csv.DictReader(fh))
    assert (row["contact_onset_s"], row["rt_s"], row["skin_temperature_C"]) == ("168.86", "1.2346", "35.5")
    assert (row["profile_resistance_m2K_W"], row["tracking_rms_C"]) == ("0.0006494", "0")
    assert (row["correct"], row["cue_played"]) == ("1", "0")
