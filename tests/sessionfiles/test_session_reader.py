"""The one reader of session folders (sessionfiles.session_reader) and the commands that use it:
real files, real FIFOs, real device links, real emulated sessions."""
from __future__ import annotations

import csv
import io
import json
import os
import shutil
import socket
import sys
from pathlib import Path

import pytest

from sessionfiles.session_reader import (SessionFileError, check_text, read_regular_bytes,
                                        read_session_folder, read_session_folders, row_problem)

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
from fuzz_session_folders import make_sessions, run_forked  # noqa: E402


# --------------------------------------------------------------------------- files
@pytest.mark.parametrize("kind", ["fifo", "dev_zero", "dev_urandom", "folder", "socket"])
def test_special_files_are_refused_by_name_without_opening_them(tmp_path, kind):
    path = tmp_path / "trials.csv"
    expected = {"fifo": "a FIFO (named pipe)", "dev_zero": "a character device (a symbolic link "
                "to /dev/zero)", "dev_urandom": "a character device (a symbolic link to "
                "/dev/urandom)", "folder": "a folder", "socket": "a socket"}[kind]
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "folder":
        path.mkdir()
    elif kind == "socket":
        s = socket.socket(socket.AF_UNIX)
        s.bind(str(path))
        s.close()
    else:
        os.symlink("/dev/" + kind[4:], path)
    with pytest.raises(SessionFileError) as err:
        read_regular_bytes(path)
    assert str(err.value) == f"{path}: expected a regular file, got {expected}"


def test_size_bound_is_checked_before_reading(tmp_path):
    path = tmp_path / "events.jsonl"
    with open(path, "wb") as fh:            # sparse: the bound is judged on the size alone
        fh.truncate(300 << 20)
    with pytest.raises(SessionFileError, match=rf"^{path}: size: expected at most 268435456 "
                                               rf"bytes, got 314572800$"):
        read_regular_bytes(path)
    small = tmp_path / "x.csv"
    small.write_bytes(b"a" * 11)
    with pytest.raises(SessionFileError, match="at most 10 bytes, got 11"):
        read_regular_bytes(small, limit=10)
    assert read_regular_bytes(small, limit=11) == b"a" * 11


def test_encodings_utf8_with_or_without_bom_others_refused_with_the_byte(tmp_path):
    p = tmp_path / "trials.csv"
    text = "participant,rt_s\nP01,0.4\nP\u00e9,0.5\n"
    assert check_text(text.encode("utf-8"), p) == text.encode("utf-8")
    assert check_text(b"\xef\xbb\xbf" + text.encode("utf-8"), p) == text.encode("utf-8")
    with pytest.raises(SessionFileError, match=rf"^{p}: encoding: expected UTF-8 text, got UTF-16 "
                                               rf"\(byte-order mark at byte 0\)"):
        check_text(text.encode("utf-16"), p)
    with pytest.raises(SessionFileError, match=r"got UTF-16 or UTF-32 without a byte-order mark "
                                               r"\(NUL byte at byte 1\)"):
        check_text(text.encode("utf-16-le"), p)
    latin = text.encode("latin-1")
    at = latin.index(b"\xe9")
    with pytest.raises(SessionFileError, match=rf"^{p}: byte {at}: expected UTF-8 text, got 0xe9 "
                                               rf"\(Latin-1"):
        check_text(latin, p)
    nul = b"participant,rt_s\nP\x0001,0.4\n"
    with pytest.raises(SessionFileError, match=rf"^{p}: byte {nul.index(0)}: expected text, got a "
                                               rf"NUL byte"):
        check_text(nul, p)
    # what a crash leaves is damage for the tolerant readers, not a refusal
    assert check_text(b"a,b\n1,2\n3,\xe2\x82", p) == b"a,b\n1,2\n3,\xe2\x82"   # torn mid-character
    assert check_text(b"a,b\n1,2\n" + b"\x00" * 64, p) == b"a,b\n1,2\n" + b"\x00" * 64


GOOD = {"participant": "P01", "session": "S01", "block": "real", "status": "ok", "trial_index": "5", "attempt": "1",
        "roughness_id": "2", "response_id": "3", "correct": "0", "rt_s": "0.4",
        "roughness_um": "12.5", "mode": "real", "tracking_rms_C": "", "contact_force_N": "2.4"}


@pytest.mark.parametrize("column,value,expected", [
    ("status", "ol", "expected one of ok, fault, aborted"),
    ("response_id", "7", "expected one of 1, 2, 3, 4 or blank"),
    ("correct", "1", "expected 0 for response_id 3 on roughness_id 2"),
    ("rt_s", "-3", "expected a finite time >= 0 s"),
    ("rt_s", "1e999", "expected a finite time >= 0 s"),
    ("rt_s", "nan?", "expected a finite time >= 0 s"),
    ("rt_s", "inf", "expected a finite time >= 0 s"),
    # a missing number is an empty cell, never a text that pandas or a spreadsheet reads as NaN
    ("rt_s", "nan", "expected a finite time >= 0 s"),
    ("rt_s", "NaN", "expected a finite time >= 0 s"),
    ("rt_s", "n/a", "expected a finite time >= 0 s"),
    ("correct", "None", "expected an integer, 0 or 1"),
    ("block", "", "expected a value (the session writes one in every row)"),
    ("block", "  ", "expected a value (the session writes one in every row)"),
    ("roughness_um", "-1.6", "expected a roughness Ra in (0, 10000] um"),
    ("participant", "P0\x001", "expected text without NUL bytes"),
    ("trial_index", "0", "expected an integer >= 1"),
    ("roughness_id", "9", "expected one of 1, 2, 3, 4"),
    ("tracking_rms_C", "-0.5", "expected a finite tracking error >= 0 degC"),
    ("contact_force_N", "inf", "expected a force in [0, 1000] N"),
])
def test_every_value_against_the_tables_domain(column, value, expected):
    assert row_problem(GOOD) is None
    assert row_problem({**GOOD, "rt_s": "", "response_id": "", "correct": ""}) is None
    problem = row_problem({**GOOD, column: value})
    assert problem is not None and problem[0] == column and problem[1].startswith(expected)
    assert problem[2] == value


def test_correct_without_an_answer_and_a_protocols_own_samples():
    assert row_problem({**GOOD, "response_id": "", "correct": "1"})[:2] == (
        "correct", "expected blank for a row without response_id")
    assert row_problem({**GOOD, "roughness_id": "6", "response_id": "6", "correct": "1"},
                       samples=[5, 6]) is None
    assert row_problem({**GOOD}, samples=[5, 6])[:2] == ("roughness_id", "expected one of 5, 6")


# --------------------------------------------------------------------------- sessions
@pytest.fixture(scope="module")
def base(tmp_path_factory):
    """Two real sessions (P01 group A, P02 group B) on the emulated display, virtual clock."""
    return make_sessions(tmp_path_factory.mktemp("reader"))


@pytest.fixture
def data(base, tmp_path):
    out = tmp_path / "data"
    shutil.copytree(base, out)
    return out


def _set(path: Path, line: int, column: str, value: str) -> None:
    with open(path, newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    rows[line - 1][rows[0].index(column)] = value
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(rows)
    path.write_text(buf.getvalue(), encoding="utf-8")


def _answered_line(path: Path) -> int:
    with open(path, newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    return next(i + 2 for i, r in enumerate(rows) if r["response_id"] and r["correct"] == "1")


def _run(args, tmp_path, name="run"):
    how, status, out, err = run_forked(args, tmp_path / name, timeout_s=120)
    assert how == "exit", f"hung: {args}"
    assert "Traceback" not in err, err
    return status, out, err


def test_a_copied_participant_folder_is_read_once_and_named(data):
    shutil.copytree(data / "P01", data / "P01 copy")
    found = read_session_folders(data)
    assert [f.path for f in found.folders] == [data / "P01" / "S01", data / "P02" / "S01"]
    assert found.skipped == [(data / "P01 copy" / "S01",
                              f"a copy of {data / 'P01' / 'S01'} (same session P01/S01, same "
                              f"event log); read once")]
    from analysis.load import load_trials
    log = load_trials(data)
    assert sorted(log.sessions["path"]) == [str(data / "P01" / "S01"), str(data / "P02" / "S01")]
    assert list(log.not_read["path"]) == [str(data / "P01 copy" / "S01")]
    assert log.trials.groupby("participant").size().to_dict() == {"P01": 12, "P02": 12}


def test_a_backup_taken_mid_session_is_read_once_the_longer_log_kept(data):
    backup = data / "old" / "P01" / "S01"
    shutil.copytree(data / "P01" / "S01", backup)
    raw = (backup / "events.jsonl").read_bytes().splitlines(keepends=True)
    (backup / "events.jsonl").write_bytes(b"".join(raw[: len(raw) // 2]))
    found = read_session_folders(data)
    assert data / "P01" / "S01" in [f.path for f in found.folders]
    assert [p for p, _ in found.skipped] == [backup]
    assert "an earlier copy" in found.skipped[0][1]


def test_two_folders_one_session_diverging_logs_refused(data):
    other = data / "again" / "P01" / "S01"
    shutil.copytree(data / "P01" / "S01", other)
    with open(other / "events.jsonl", "a", encoding="utf-8") as fh:
        fh.write('{"event":"note","seq":999,"text":"edited"}\n')
    raw = (data / "P01" / "S01" / "events.jsonl").read_bytes()
    (data / "P01" / "S01" / "events.jsonl").write_bytes(raw.replace(b'"seq":2,', b'"seq":2,"x":1,', 1))
    with pytest.raises(SessionFileError, match=r"session: expected one folder per session, got two "
                                               r"holding P01/S01 with different event logs"):
        read_session_folders(data)


def test_a_session_json_of_another_session_is_refused(data):
    shutil.copy(data / "P02" / "S01" / "session.json", data / "P01" / "S01" / "session.json")
    path = data / "P01" / "S01" / "session.json"
    with pytest.raises(SessionFileError, match=rf"^{path}: participant_id: expected 'P01' \(the "
                                               rf"participant of events.jsonl's session_started\), "
                                               rf"got 'P02'"):
        read_session_folder(data / "P01" / "S01")


def test_folder_names_that_differ_are_reported_and_the_files_identity_used(data):
    (data / "P01").rename(data / "P07")
    sf = read_session_folder(data / "P07" / "S01")
    assert (sf.participant, sf.session) == ("P01", "S01")
    assert any("folder names P07/S01 differ from the session's own P01/S01" in n for n in sf.notes)


@pytest.mark.parametrize("column,value,message", [
    ("rt_s", "-3", "rt_s: expected a finite time >= 0 s (at most a day) (line {line}), got '-3'"),
    ("rt_s", "1e999", "rt_s: expected a finite time >= 0 s (at most a day) (line {line}), got '1e999'"),
    ("rt_s", "nan", "rt_s: expected a finite time >= 0 s (at most a day) (line {line}), got 'nan'"),
    ("block", "", "block: expected a value (the session writes one in every row) (line {line}), "
                  "got ''"),
    ("status", "ol", "status: expected one of ok, fault, aborted (line {line}), got 'ol'"),
    ("response_id", "7", "response_id: expected one of 1, 2, 3, 4 or blank (line {line}), got '7'"),
    ("correct", "0", "correct: expected 1 for response_id"),
    ("roughness_um", "-1.6", "roughness_um: expected a roughness Ra in (0, 10000] um (line {line}), "
                             "got '-1.6'"),
    ("participant", "P02", "participant: expected 'P01' (the session's own"),
])
def test_analyze_and_export_bids_refuse_impossible_values_in_one_line(data, tmp_path, column, value,
                                                                      message):
    from analysis import LogError
    from analysis.load import load_trials
    from experiments.bids import export_dataset
    table = data / "P01" / "S01" / "trials.csv"
    line = _answered_line(table)
    _set(table, line, column, value)
    expected = f"{table}: {message.format(line=line)}"
    with pytest.raises(LogError) as err:
        load_trials(data)
    assert str(err.value).startswith(expected), str(err.value)
    out = tmp_path / "bids"
    with pytest.raises(SessionFileError) as err:
        export_dataset(data, out)
    assert str(err.value).startswith(expected)
    assert not out.exists()                             # refused before anything was written


def test_a_nul_byte_in_a_cell_is_refused_with_its_offset(data):
    from analysis import LogError
    from analysis.load import load_trials
    table = data / "P01" / "S01" / "trials.csv"
    raw = table.read_bytes()
    at = raw.index(b"P01", raw.index(b"\n"))
    table.write_bytes(raw[:at + 1] + b"\x00" + raw[at + 2:])
    with pytest.raises(LogError, match=rf"^{table}: byte {at + 1}: expected text, got a NUL byte"):
        load_trials(data)


def test_rt_in_the_event_log_is_checked_too(data):
    from analysis import LogError
    from analysis.load import load_trials
    folder = data / "P01" / "S01"
    (folder / "trials.csv").unlink()
    lines = (folder / "events.jsonl").read_text("utf-8").splitlines(keepends=True)
    i = next(i for i, l in enumerate(lines) if '"trial_completed"' in l and '"rt_s":0.4' in l)
    lines[i] = lines[i].replace('"rt_s":0.4', '"rt_s":-3', 1)
    (folder / "events.jsonl").write_text("".join(lines), encoding="utf-8")
    with pytest.raises(LogError, match=rf"^{folder / 'events.jsonl'}: rt_s: expected a finite time "
                                       rf">= 0 s \(at most a day\) \(line {i + 1}\), got -3"):
        load_trials(data)


@pytest.mark.parametrize("name", ["trials.csv", "events.jsonl", "session.json"])
@pytest.mark.parametrize("kind", ["fifo", "dev_zero", "dev_urandom"])
def test_special_files_in_a_session_end_both_commands_at_once(data, tmp_path, name, kind):
    path = data / "P02" / "S01" / name
    path.unlink()
    os.mkfifo(path) if kind == "fifo" else os.symlink("/dev/" + kind[4:], path)
    what = "a FIFO (named pipe)" if kind == "fifo" else \
        f"a character device (a symbolic link to /dev/{kind[4:]})"
    status, _, err = _run(["export-bids", str(data), "--out", str(tmp_path / "b")], tmp_path)
    assert status == 2
    assert err.strip() == f"thermocue export-bids: {path}: expected a regular file, got {what}"
    from analysis import LogError
    from analysis.load import load_trials
    with pytest.raises(LogError, match=rf"^{path}: expected a regular file, got "):
        load_trials(data)


@pytest.mark.parametrize("encoding", ["utf-16", "latin-1"])
def test_export_bids_names_the_file_of_another_encoding(data, tmp_path, encoding):
    path = data / "P01" / "S01" / "session.json"
    text = path.read_text("utf-8").replace('"occupation": "student"', '"occupation": "\u00e9tudiant"')
    assert "\u00e9" in text
    path.write_bytes(text.encode(encoding))
    status, _, err = _run(["export-bids", str(data), "--out", str(tmp_path / "b")], tmp_path)
    assert status == 2
    if encoding == "utf-16":
        assert err.strip() == (f"thermocue export-bids: {path}: encoding: expected UTF-8 text, got "
                               f"UTF-16 (byte-order mark at byte 0); save it as UTF-8")
    else:
        at = text.encode("latin-1").index(b"\xe9")
        assert err.strip() == (f"thermocue export-bids: {path}: byte {at}: expected UTF-8 text, got "
                               f"0xe9 (Latin-1 or another 8-bit encoding?); save it as UTF-8")


def test_utf8_with_a_bom_is_read(data):
    from analysis.load import load_trials
    for name in ("trials.csv", "session.json", "events.jsonl"):
        path = data / "P01" / "S01" / name
        path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    log = load_trials(data)
    assert log.trials.groupby("participant").size().to_dict() == {"P01": 12, "P02": 12}
    assert list(log.sessions["n_planned"]) == [12, 12]
    # the analysis' other readers of session.json follow the same rules
    from analysis.missing import _schedule
    from analysis.session_meta import read_session_meta
    assert len(read_session_meta(data / "P01" / "S01")["schedule"]) == 12
    assert _schedule(data / "P01" / "S01") is not None


def test_export_bids_exports_a_session_without_session_json_from_its_log(data, tmp_path, capsys):
    from experiments.cli import main
    (data / "P01" / "S01" / "session.json").unlink()
    assert main(["export-bids", str(data), "--out", str(tmp_path / "b")]) == 0
    assert capsys.readouterr().out == f"2 session(s) of 2 participant(s) -> {tmp_path / 'b'}\n"
    beh = tmp_path / "b" / "sub-P01" / "ses-S01" / "beh" / \
        "sub-P01_ses-S01_task-roughnessrecognition_beh.tsv"
    assert beh.is_file()
    with open(tmp_path / "b" / "participants.tsv", newline="") as fh:
        people = {r["participant_id"]: r for r in csv.DictReader(fh, delimiter="\t")}
    assert people["sub-P01"]["group"] == "A" and people["sub-P01"]["sex"] == "female"
    assert people["sub-P01"]["age"] == "n/a"                   # the record is in session.json only


def test_export_bids_names_every_folder_it_does_not_export(data, tmp_path, capsys):
    from experiments.cli import main
    shutil.copytree(data / "P02", data / "backup")
    (data / "empty" / "S01").mkdir(parents=True)
    (data / "empty" / "S01" / "events.jsonl").write_text(
        '{"event":"session_started","seq":1,"participant":"P09","session":"S01"}\n')
    assert main(["export-bids", str(data), "--out", str(tmp_path / "b")]) == 0
    out, err = capsys.readouterr()
    assert out == (f"2 session(s) of 2 participant(s) -> {tmp_path / 'b'}; 2 folder(s) not exported "
                   f"(named above)\n")
    assert (f"thermocue export-bids: not exported: {data / 'backup' / 'S01'}: a copy of "
            f"{data / 'P02' / 'S01'} (same session P02/S01, same event log); read once") in err
    assert (f"thermocue export-bids: not exported: {data / 'empty' / 'S01'}: no trial rows") in err
    assert sorted(p.name for p in (tmp_path / "b").glob("sub-*")) == ["sub-P01", "sub-P02"]


def test_no_sub_none_and_no_rows_under_another_id(data, tmp_path):
    from experiments.bids import export_dataset
    meta = data / "P01" / "S01" / "session.json"
    record = json.loads(meta.read_text("utf-8"))
    record["participant_id"] = None
    record["participant"]["id"] = None
    meta.write_text(json.dumps(record), encoding="utf-8")
    written = export_dataset(data, tmp_path / "b")
    assert sorted(p.parent.parent.parent.name for p in written) == ["sub-P01", "sub-P02"]
    assert not list((tmp_path / "b").glob("sub-None*"))


def test_the_profile_reader_names_a_file_of_another_encoding(tmp_path):
    from experiments.errors import UserInputError
    from experiments.psychopy_plugin.profiles import file_profile
    path = tmp_path / "cue.csv"
    text = "time_s,target_C,note\n0,32,\u00e9\n0.01,31.9,\n"
    path.write_bytes(text.encode("utf-16"))
    with pytest.raises(UserInputError, match=rf"^{path}: encoding: expected UTF-8 text, got UTF-16"):
        file_profile(path)
    path.write_bytes(text.encode("latin-1"))
    at = text.encode("latin-1").index(b"\xe9")
    with pytest.raises(UserInputError, match=rf"^{path}: byte {at}: expected UTF-8 text, got 0xe9"):
        file_profile(path)
    path.unlink()
    os.mkfifo(path)
    with pytest.raises(UserInputError, match=rf"^{path}: expected a regular file, got a FIFO"):
        file_profile(path)
    path.unlink()
    path.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    assert file_profile(path).target_C.tolist() == [32.0, 31.9]


def test_calibrate_refuses_a_fifo_in_place_of_a_trace(data):
    from experiments.calibration import load_session_traces
    from experiments.calibration.errors import CalibrationError
    trace = data / "P01" / "S01" / "traces" / "trial-001.csv"
    trace.unlink()
    os.mkfifo(trace)
    with pytest.raises(CalibrationError, match=rf"^{trace}: expected a regular file, got a FIFO"):
        load_session_traces(data / "P01" / "S01")


def test_resume_refuses_a_special_file_before_opening_it(data, tmp_path):
    path = data / "P01" / "S01" / "session.json"
    path.unlink()
    os.mkfifo(path)
    status, _, err = _run(["resume", str(data / "P01" / "S01")], tmp_path)
    assert status == 2
    assert err.strip() == f"thermocue resume: {path}: expected a regular file, got a FIFO (named pipe)"


def test_a_duplicated_unanswered_row_is_dropped_not_a_pandas_na_error(data):
    """An exact duplicate with blank (NA) cells: once a ``TypeError: boolean value of NA``."""
    import warnings

    from analysis import LogWarning
    from analysis.load import load_trials
    (data / "P01" / "S01" / "events.jsonl").unlink()         # the table is then the record
    table = data / "P01" / "S01" / "trials.csv"
    lines = table.read_text("utf-8").splitlines(keepends=True)
    first = lines[1]                                           # familiarisation: no answer
    assert ",real,1,1.6," in first and ",,," in first
    table.write_text("".join(lines + [first]), encoding="utf-8")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LogWarning)
        log = load_trials(data)
    assert any(f"{table}: line {len(lines) + 1}: exact duplicate of line 2" in str(w.message)
               for w in caught)
    assert log.trials.groupby("participant").size().to_dict() == {"P01": 12, "P02": 12}


def test_a_damaged_outcome_event_is_reported_not_raised():
    from sessionfiles.logformat import trials_from_events
    events = [{"event": "session_started", "participant": "P01", "session": "S01"},
              {"event": "trial_started", "trial_index": [1], "attempt": 1},
              {"event": "trial_completed", "seq": 3, "trial_index": [1], "attempt": 1, "row": {}},
              {"event": "trial_completed", "seq": 4, "trial_index": 2, "attempt": 1, "row": 5},
              {"event": "trial_completed", "seq": 5, "trial_index": 3, "attempt": 1,
               "row": {"status": "ok"}}]
    damage: list = []
    rows = trials_from_events(events, damage=damage)
    assert [r["trial_index"] for r in rows] == [3]
    assert damage == ["trial_completed event (seq 3): trial_index: expected an integer, got [1]; "
                      "ignored",
                      "trial_completed event (seq 4): row: expected a mapping, got 5; ignored"]


def test_a_folder_with_only_a_copy_of_session_json_is_named_not_read(data):
    stray = data / "spare" / "S01"
    stray.mkdir(parents=True)
    shutil.copy(data / "P01" / "S01" / "session.json", stray / "session.json")
    found = read_session_folders(data)
    assert [f.path for f in found.folders] == [data / "P01" / "S01", data / "P02" / "S01"]
    assert found.skipped == [(stray, f"no event log and no trials table; session P01/S01 is read "
                                     f"from {data / 'P01' / 'S01'}")]
