"""The log format's one home: standard library only, and the writer and analysis agree.

The reader, the projection and replay are exercised through the writer in test_logbook.py and
through analysis in tests/analysis/test_load*.py; here: what importing the module costs, the
column lists' consistency, the one cell formatter in both files, and the cases where analysis'
copy of the projection used to disagree with the writer's.
"""
from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from sessionfiles import logformat
from experiments.display.types import Telemetry
from sessionfiles.logbook import EventLog
from sessionfiles.logformat import (
    COLUMN_DECIMALS,
    FORCE_COLUMNS,
    OPTIONAL_COLUMNS,
    REQUIRED_COLUMNS,
    TRACE_COLUMNS,
    TRACE_DECIMALS,
    TRIAL_COLUMNS,
    format_cell,
    read_csv_prefix,
    read_events,
    trials_from_events,
)
from sessionfiles.session_files import TraceWriter

ROOT = Path(__file__).resolve().parents[2]
HEAVY = ("numpy", "serial", "stimuli", "scipy", "pandas")


def test_importing_the_format_pulls_in_no_runtime_or_numerics():
    code = ("import sys, json; import sessionfiles.logformat; "
            f"print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in {HEAVY!r})))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                         timeout=60, check=True)
    assert json.loads(out.stdout) == []
    # the check itself sees these modules when they are imported
    code = code.replace("import sessionfiles.logformat", "import sessionfiles.logformat, numpy")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                         timeout=60, check=True)
    assert "numpy" in json.loads(out.stdout)


def test_column_lists_agree():
    assert len(set(TRIAL_COLUMNS)) == len(TRIAL_COLUMNS)
    assert set(REQUIRED_COLUMNS) <= set(TRIAL_COLUMNS)
    assert set(OPTIONAL_COLUMNS) <= set(TRIAL_COLUMNS)
    assert set(COLUMN_DECIMALS) <= set(TRIAL_COLUMNS)
    assert TRACE_COLUMNS[0] == "time_s" and TRACE_COLUMNS[-1] == "state"
    assert FORCE_COLUMNS == ("force1_N", "force2_N", "force3_N", "force4_N")
    assert set(TRACE_DECIMALS) == set(TRACE_COLUMNS) - {"state"}


def test_one_formatter_two_conventions():
    assert format_cell(24.0, "skin_temperature_C") == "24"          # trials.csv: decimals, cut
    assert format_cell(24.0, "anything_else") == "24.0"             # trials.csv: repr
    assert format_cell(6.494477e-4, "pad_resistance_m2K_W") == "0.0006494"
    assert format_cell(24.0, "ambient_C", TRACE_DECIMALS) == "24"   # traces: %.10g
    assert format_cell(12.3456789012345, "time_s", TRACE_DECIMALS) == "12.3456789"
    for bad in (math.nan, math.inf, -math.inf, None):
        assert format_cell(bad, "time_s", TRACE_DECIMALS) == "" == format_cell(bad, "rt_s")


def _frame(t, finger):
    return Telemetry(counter=1, device_time_s=t, setpoint_C=33.0, contact_C=31.2345678901,
                     ambient_C=24.0, finger_C=finger, forces_N=(0.25, 0.0, 0.5, 0.125),
                     state="record", fault=None)


def test_a_trace_line_with_a_missing_value_keeps_the_files_convention(tmp_path):
    """A non-finite value is a blank cell and the line's other cells are written as every other
    line of the trace (before: ``repr(round(v, 6))`` for the whole line, ``inf`` written)."""
    path = tmp_path / "trial-001.csv"
    w = TraceWriter(path)
    w.write(_frame(0.01, 34.0))
    w.write(_frame(0.02, math.nan))
    w.write(_frame(0.03, math.inf))
    w.close()
    header, rows, lines, damage = read_csv_prefix(path)
    assert header == list(TRACE_COLUMNS) and damage == [] and lines == [2, 3, 4]
    assert rows[0] == ["0.01", "33", "31.23456789", "24", "34", "0.25", "0", "0.5", "0.125", "record"]
    assert rows[1] == ["0.02", "33", "31.23456789", "24", "", "0.25", "0", "0.5", "0.125", "record"]
    assert rows[2][0] == "0.03" and rows[2][4] == "" and rows[2][1:] == rows[1][1:]


def test_read_csv_prefix_stops_at_the_damage(tmp_path):
    path = tmp_path / "trials.csv"
    path.write_bytes(b"a,b\n1,2\n\n3,4\n5\n6,7\n")
    header, rows, lines, damage = read_csv_prefix(path)
    assert header == ["a", "b"] and rows == [["1", "2"], ["3", "4"]] and lines == [2, 4]
    assert damage == [f"{path}: line 5: expected 2 fields, got 1; read the 2 rows before it"]
    path.write_bytes(b"a,b\n1,2\n3,")
    assert read_csv_prefix(path)[1:] == ([["1", "2"]], [2], [
        f"{path}: line 3: torn last line (no newline at its end); ignored"])
    path.write_bytes(b"")
    assert read_csv_prefix(path) == (None, [], [], [])


def test_the_report_gives_each_events_line_and_the_warned_messages(tmp_path):
    path = tmp_path / "events.jsonl"
    path.write_bytes(b'{"event":"a"}\n\n{"event":"b"}\nnot json\n{"event":"c"}\n{"event":"d", "x')
    with pytest.warns(logformat.LogDamageWarning) as caught:
        events, report = read_events(path, on_damage="skip")
    assert [e["event"] for e in events] == ["a", "b", "c"]
    assert report.event_lines == (1, 3, 5)
    assert list(report.damage) == [str(w.message) for w in caught]
    assert report.damage[0].startswith(f"{path}: line 4: undecodable line")
    assert report.damage[1] == f"{path}: line 6: torn last line (16 bytes) ignored"


# --------------------------------------------------------------------------- writer == analysis
def _log(path, *extra):
    with EventLog(path) as log:
        log.append("session_started", session="S1", participant="P07", group="A", protocol_hash="h",
                   seed=1, skin_thickness_um=700.0, sex="F", date="2026-11-24_10h00.00.000")
        log.append("trial_started", trial_index=1, attempt=1, block="real", mode="real",
                   roughness_id=2.0, roughness_um=12.5, repetition=1)
        log.append("trial_completed", trial_index=1, attempt=1,
                   row={"response_id": 2, "rt_s": 1.25, "status": "ok", "tags": ["x"]})
        log.append("trial_started", trial_index=2, attempt=1, block="real", mode="simulated",
                   roughness_id=3, roughness_um=50.0, repetition=1)
        log.append("trial_aborted", trial_index=2, attempt=1, reason="killed", fault_code="E_KILL")
        for name, fields in extra:
            log.append(name, **fields)
    return path


def test_analysis_rebuilds_the_rows_the_writer_rebuilds(tmp_path):
    """analysis.load.read_trial_events is the writer's projection (nested values left out, the
    event's line added): ``correct`` compares the logged values (2 == 2.0: correct; analysis'
    old copy compared their text, '2' != '2.0'), and only trial_* events make rows."""
    from analysis.load import read_trial_events
    path = _log(tmp_path / "events.jsonl",
                ("trial", {"trial": {"trial_index": 9, "status": "ok", "roughness_id": 1}}))
    events, _ = read_events(path)
    writer = trials_from_events(events)
    table, context = read_trial_events(path)
    got = table.to_dict("records")
    assert len(got) == len(writer) == 2
    for row, lines, mine in zip(writer, (3, 5), got):
        expected = {k: v for k, v in row.items() if not isinstance(v, (dict, list))}
        assert {k: v for k, v in mine.items() if k != "line" and v == v} == \
            {k: v for k, v in expected.items() if v is not None}
        assert mine["line"] == lines
    assert writer[0]["correct"] == 1 and got[0]["correct"] == 1
    assert got[1]["status"] == "aborted" and got[1]["abort_reason"] == "killed"
    assert context == {"participant": "P07", "group": "A", "session": "S1",
                       "skin_thickness_um": 700.0, "sex": "F", "date": "2026-11-24_10h00.00.000"}
    # a log of other events holding a trial-like payload has no trial rows (the old copy's
    # speculative "other writers" branch made one)
    other = tmp_path / "other.jsonl"
    other.write_text(json.dumps({"event": "trial", "trial": {"trial_index": 9, "status": "ok"}}) + "\n")
    assert read_trial_events(other)[0].empty and trials_from_events(read_events(other)[0]) == []


def test_analysis_reports_a_second_outcome_as_the_writer_does(tmp_path):
    from analysis import LogWarning
    from analysis.load import read_trial_events
    path = _log(tmp_path / "events.jsonl",
                ("trial_completed", {"trial_index": 1, "attempt": 1, "row": {"response_id": 3}}))
    messages = []
    with pytest.warns(LogWarning, match=r"events.jsonl: trial 1 attempt 1: a second trial_completed "
                                        r"event \(seq 6\) ignored"):
        table, _ = read_trial_events(path, messages)
    assert list(table["response_id"].iloc[:1]) == [2] and len(table) == 2 and len(messages) == 1


def test_analysis_warns_of_a_torn_log_in_the_writers_words(tmp_path):
    from analysis import LogWarning
    from analysis.load import read_trial_events
    path = _log(tmp_path / "events.jsonl")
    with open(path, "ab") as fh:
        fh.write(b'{"event":"trial_started","tri')
    with pytest.warns(logformat.LogDamageWarning) as by_writer:
        read_events(path)
    with pytest.warns(LogWarning) as by_analysis:
        table, _ = read_trial_events(path)
    assert [str(w.message) for w in by_analysis] == [str(w.message) for w in by_writer] == [
        f"{path}: line 6: torn last line (29 bytes) ignored"]
    assert len(table) == 2


def test_trials_csv_written_and_read_back_by_analysis(tmp_path):
    """The writer's trials.csv and analysis' reading of it, through the shared column lists."""
    from analysis.load import read_trials_csv
    from sessionfiles.logbook import write_trials_csv
    events, _ = read_events(_log(tmp_path / "events.jsonl"))
    write_trials_csv(tmp_path / "trials.csv", trials_from_events(events))
    table = read_trials_csv(tmp_path / "trials.csv")
    assert list(table.columns) == [*TRIAL_COLUMNS, "tags", "line"]
    assert list(table["correct"]) == ["1", ""] and list(table["status"]) == ["ok", "aborted"]
    with open(tmp_path / "trials.csv", newline="") as fh:
        assert next(csv.reader(fh))[:3] == ["participant", "session", "group"]


def test_to_jsonable_gives_every_kind_of_value_its_json_form():
    # the exact built-in types take a shortcut; their subclasses, other mappings and sequences,
    # numpy, paths and dates the general rules: each checked against its JSON form by hand
    import collections
    import datetime as dt
    import enum

    import numpy as np

    class Level(enum.IntEnum):
        HIGH = 3

    value = {1: (1.5, math.inf, -math.nan, None, True, "a"), "n": [np.float64("nan"), np.int64(7)],
             "m": collections.OrderedDict(k=np.array([0.25, 2.0])), "e": Level.HIGH,
             "p": Path("a") / "b.csv", "d": dt.date(2024, 5, 6), "f": np.float64(0.5)}
    got = logformat.to_jsonable(value)
    assert got == {"1": [1.5, None, None, None, True, "a"], "n": [None, 7], "m": {"k": [0.25, 2.0]},
                   "e": 3, "p": "a/b.csv", "d": "2024-05-06", "f": 0.5}
    assert type(got["m"]) is dict and type(got["n"][1]) is int
    assert json.loads(logformat.dumps(value)) == got
    with pytest.raises(TypeError):
        logformat.to_jsonable({"x": object()})
