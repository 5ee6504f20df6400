"""The session's per-frame and per-trial writes (speed) give the same bytes as before.

* a trace line (:class:`~sessionfiles.session_files.TraceWriter`) is the cells of
  :func:`~sessionfiles.logformat.format_cell` whatever the values (remembered hundredths, -0.0,
  non-finite, integers, numpy scalars);
* ``trials.csv`` grows by its new lines between trials (one ``write``; not a rewrite of the
  whole table), and ends as the table rebuilt from the events;
* the events the table is rebuilt from, read a few lines at a time, are what
  :func:`~sessionfiles.logbook.read_events` reads, torn last line included.
"""
from __future__ import annotations

import json
import math
import os
import time

import numpy as np
import pytest

from experiments.display.types import Telemetry
from sessionfiles.logbook import append_text, read_events, trials_csv_text, trials_from_events
from sessionfiles.logformat import TRACE_COLUMNS, TRACE_DECIMALS, format_cell
from experiments.session.trials_table import TrialsTable
from sessionfiles.session_files import TraceWriter


def _reference_line(values, state):
    return ",".join([format_cell(float(v), c, TRACE_DECIMALS)
                     for v, c in zip(values, TRACE_COLUMNS)] + [state]) + "\n"


def test_trace_lines_are_format_cells_text_for_any_value(tmp_path):
    rng = np.random.default_rng(1)
    odd = [0.0, -0.0, 0.0, -0.0, math.nan, math.inf, -math.inf, 1, -3, np.float64(31.25),
           np.float32(0.1), 1e-300, 123456.789012345, 1 / 3, -0.01, 0.01, True]
    frames = []
    for i in range(3000):
        cells = list(np.round(rng.uniform(-40, 60, 8), 2))      # whole hundredths, repeated
        if i % 3 == 0:
            cells[rng.integers(0, 8)] = odd[i // 3 % len(odd)]
        frames.append(((i + 1) * 0.01, *cells[:4], tuple(cells[4:])))
    w = TraceWriter(tmp_path / "trial-001.csv")
    want = [",".join(TRACE_COLUMNS) + "\n"]
    for i, (t, sp, ct, amb, fin, forces) in enumerate(frames):
        state = ("PLAYING", "ARMED", "record", "n/a")[i % 4]
        w.write(Telemetry(i, t, sp, ct, amb, fin, forces, state, None))
        want.append(_reference_line((t, sp, ct, amb, fin, *forces), state))
    w.close()
    got = (tmp_path / "trial-001.csv").read_text(encoding="utf-8")
    assert got.splitlines(keepends=True) == want
    assert ",-0," in got and ",0," in got          # -0.0 is not written as 0.0 or vice versa
    # what the session reads back (contact force, the responder's stimulus): the values as
    # written, as numpy makes them of the frames' own numbers (nan, -0.0, float32 and all)
    time_s, target_C, contact_C, forces_N = w.arrays()
    for got_a, want_a in ((time_s, [f[0] for f in frames]), (target_C, [f[1] for f in frames]),
                          (contact_C, [f[2] for f in frames]),
                          (forces_N, [f[5] for f in frames])):
        want_a = np.asarray(want_a, dtype=float)
        assert got_a.shape == want_a.shape and got_a.tobytes() == want_a.tobytes()
    assert forces_N.shape == (3000, 4) and w.arrays()[0] is time_s       # made once
    assert w.time_s == time_s.tolist() and w.forces_N[7] == tuple(forces_N[7])


def test_a_frame_with_telemetrys_field_names_writes_the_same_line(tmp_path):
    # the Display protocol promises Telemetry-like frames; a display passing an object with the
    # same field names (not the named tuple) gets the same trace line, not a TypeError mid-trial
    from types import SimpleNamespace
    tele = Telemetry(7, 0.07, 24.5, 31.25, 22.0, 35.1, (0.5, 0.25, 0.0, 1.0), "PLAYING", None)
    obj = SimpleNamespace(**tele._asdict())
    lines = []
    for name, frame in (("a.csv", tele), ("b.csv", obj)):
        w = TraceWriter(tmp_path / name)
        w.write(frame)
        w.close()
        lines.append((tmp_path / name).read_text(encoding="utf-8"))
    assert lines[0] == lines[1]
    assert lines[0].splitlines()[1] == _reference_line((0.07, 24.5, 31.25, 22.0, 35.1, 0.5, 0.25, 0.0, 1.0), "PLAYING")[:-1]


def test_append_text_appends_whole_lines_only_to_the_file_it_expects(tmp_path):
    path = tmp_path / "trials.csv"
    path.write_bytes(b"a,b\n1,2\n")
    assert append_text(path, "3,4\n", expected_size=8)
    assert path.read_bytes() == b"a,b\n1,2\n3,4\n"
    assert not append_text(path, "5,6\n", expected_size=8)      # someone else changed it
    assert path.read_bytes() == b"a,b\n1,2\n3,4\n"
    with pytest.raises(ValueError):
        append_text(path, "5,", expected_size=12)
    assert path.read_bytes() == b"a,b\n1,2\n3,4\n"
    path.unlink()                                  # gone: not created by an append either
    assert not append_text(path, "5,6\n", expected_size=12) and not path.exists()


def test_events_read_a_few_lines_at_a_time_are_read_events(tmp_path):
    path = tmp_path / "events.jsonl"
    path.write_bytes(b"")
    table = TrialsTable(path, tmp_path / "trials.csv")
    lines = [json.dumps({"event": "e", "seq": i, "x": [i, 0.1 * i]}).encode() + b"\n"
             for i in range(1, 40)]
    chunks = [b"", lines[0], b"".join(lines[1:5]), lines[5][:7], lines[5][7:], b"\n",
              b"".join(lines[6:20]), b"not json\n", b"".join(lines[20:]), b'{"event": "to']
    for chunk in chunks:
        with open(path, "ab") as fh:
            fh.write(chunk)
        assert table.events() == read_events(path, warn=False)[0]


def test_trials_csv_grows_by_lines_and_is_the_table_of_the_events(tmp_path, monkeypatch):
    from experiments.participant_model.cohort import write_cohort
    from experiments.simulation.figure9.study import run_participant
    paths = {p.stem: p for p in write_cohort(tmp_path / "participants", seed=0)}
    replaced = []
    real_replace = os.replace

    def counting_replace(src, dst, *a, **k):
        if os.path.basename(dst) == "trials.csv":
            replaced.append(dst)
        return real_replace(src, dst, *a, **k)

    monkeypatch.setattr(os, "replace", counting_replace)
    res = run_participant(paths["P01"], tmp_path / "data", seed=0, durable=False)
    session = res["session_dir"]
    assert res["n_trials"] == 28
    assert len(replaced) == 1            # the first table of the run; then its new lines only
    # a durable session (a person's) replaces the table atomically every time, never appends
    replaced.clear()
    durable = run_participant(paths["P02"], tmp_path / "durable", seed=0, durable=True)
    assert len(replaced) >= durable["n_trials"]
    events, report = read_events(os.path.join(session, "events.jsonl"), warn=False)
    assert report.ok
    rows = trials_from_events(events)
    for row in rows:
        row.setdefault("trace_file", None)
    want, _ = trials_csv_text(rows)
    with open(os.path.join(session, "trials.csv"), encoding="utf-8", newline="") as fh:
        assert fh.read() == want


def test_the_table_formats_each_row_once_and_is_the_table_of_the_events(tmp_path, monkeypatch):
    # trials.csv after every trial formats only the rows it has not formatted yet, and stays
    # exactly trials_csv_text of the events: through a new column, an aborted attempt whose
    # trace_file comes from its event, a second event for an attempt (ignored), a row whose
    # value changes with its event, and a log rewritten under the table (all read again)
    import warnings

    import sessionfiles.logbook as logbook
    calls = []
    real_format_cell = logbook.format_cell
    monkeypatch.setattr(logbook, "format_cell", lambda v, c="", *a: calls.append(c) or
                        real_format_cell(v, c, *a))
    path = tmp_path / "events.jsonl"
    path.write_bytes(b"")
    table = TrialsTable(path, tmp_path / "trials.csv")
    seq = iter(range(1, 1000))

    def log(**ev):
        with open(path, "a", encoding="utf-8") as fh:
            fh.write(json.dumps({"seq": next(seq), "time": "2026-01-01T00:00:00.000Z", **ev}) + "\n")

    def check(new_rows, header=False):
        calls.clear()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            table.write()
            formatted = len(calls)
            rows = trials_from_events(read_events(path, warn=False)[0])
        aborted = {}
        for ev in read_events(path, warn=False)[0]:
            if ev["event"] == "trial_aborted":
                aborted[(ev["trial_index"], ev["attempt"])] = ev.get("trace_file")
        for row in rows:
            if row.get("status") == "aborted":
                row["trace_file"] = aborted.get((row["trial_index"], row["attempt"]))
            else:
                row.setdefault("trace_file", None)
        want, columns = trials_csv_text(rows)
        assert (tmp_path / "trials.csv").read_text(encoding="utf-8") == want
        assert formatted == (new_rows + header) * len(columns), (formatted, new_rows, columns)

    log(event="session_started", participant="P01", session="1")
    for i in range(1, 6):
        log(event="trial_started", trial_index=i, attempt=1, block="main", roughness_id=i % 4)
        log(event="trial_completed", trial_index=i, attempt=1,
            row={"response_id": i % 3, "rt_s": 0.5 + i / 7, "tracking_rms_C": math.nan})
        check(new_rows=1, header=i == 1)
    log(event="trial_started", trial_index=6, attempt=1)
    log(event="trial_aborted", trial_index=6, attempt=1, reason="no contact",
        trace_file="traces/trial-006.attempt-1.aborted.csv")
    check(new_rows=1)
    log(event="trial_started", trial_index=6, attempt=2)
    log(event="trial_completed", trial_index=6, attempt=2, row={"new_column_um": 3.25})
    check(new_rows=7, header=True)                        # a new column: every row again
    log(event="trial_completed", trial_index=6, attempt=2, row={"new_column_um": 9.0})
    check(new_rows=0)                                     # a second event: ignored
    log(event="trial_aborted", trial_index=6, attempt=1, reason="again", trace_file="other.csv")
    check(new_rows=1)                                     # the aborted row's trace_file changed
    text = path.read_text(encoding="utf-8").replace('"rt_s": 0.6428571428571428', '"rt_s": 0.25')
    path.write_text(text[:len(text) // 2], encoding="utf-8")     # a shorter log: read again
    with open(path, "a", encoding="utf-8") as fh:
        fh.write(text[len(text) // 2:])
    check(new_rows=7)


def test_an_event_is_made_json_ready_once_and_written_as_dumps_writes_it(tmp_path, monkeypatch):
    import sessionfiles.logbook as logbook
    import sessionfiles.logformat as logformat
    from sessionfiles.logformat import dumps
    top = []
    real = logformat.to_jsonable

    def counting(obj):                                 # the whole event, wherever it is made ready
        if isinstance(obj, dict) and obj.get("event") == "note":
            top.append(1)
        return real(obj)

    monkeypatch.setattr(logbook, "to_jsonable", counting)
    monkeypatch.setattr(logformat, "to_jsonable", counting)
    values = dict(text="Ra 1.6 µm, 20 °C", x=0.1, big=1e300, neg=-0.0, n=np.int64(3),
                  a=np.array([1.5, np.nan]), nested={"k": [1, {"z": (2, 3.25)}]}, none=None,
                  inf=math.inf, flag=True, path=tmp_path / "x")
    with logbook.EventLog(tmp_path / "events.jsonl") as log:
        rec = log.append("note", time="2026-01-01T00:00:00.000Z", **values)
    assert len(top) == 1                               # one to_jsonable of the event, not two
    line = (tmp_path / "events.jsonl").read_text(encoding="utf-8")
    assert line == dumps({"event": "note", "seq": 1, "time": "2026-01-01T00:00:00.000Z",
                          **values}) + "\n"
    assert line == json.dumps(rec, ensure_ascii=False, allow_nan=False,
                              separators=(",", ":")) + "\n"
    assert dumps(values, indent=0) == json.dumps(real(values), ensure_ascii=False,
                                                 allow_nan=False, indent=0, separators=(",", ":"))


def test_package_versions_are_read_once_per_process_and_handed_out_as_new_dicts(monkeypatch):
    import sessionfiles.session_files as sf
    calls = []
    real = sf.metadata.version
    monkeypatch.setattr(sf.metadata, "version", lambda name: calls.append(name) or real(name))
    sf._package_versions.cache_clear()
    try:
        a = sf.package_versions()
        n = len(calls)
        b = sf.package_versions()
        assert n == len(calls) == 8 and a == b and a is not b and a["numpy"] == np.__version__
        a["numpy"] = "changed"
        assert sf.package_versions()["numpy"] == np.__version__
    finally:
        sf._package_versions.cache_clear()


def test_a_trace_reaches_the_file_while_the_trial_runs(tmp_path):
    # thermocue monitor follows the trace as it is written: a frame that comes flush_interval_s
    # or more after the last flush is on disk at once, many frames before flush_every
    path = tmp_path / "trial-001.csv"
    w = TraceWriter(path, flush_every=10**6, flush_interval_s=0.05)
    tele = Telemetry(0, 0.01, 32.0, 31.9, 20.0, 35.0, (0.0,) * 4, "ARMED", None)
    w.write(tele)
    time.sleep(0.06)
    w.write(tele._replace(device_time_s=0.02, state="PLAYING"))
    on_disk = path.read_text(encoding="utf-8").splitlines()
    assert len(on_disk) == 3 and on_disk[-1].endswith(",PLAYING")     # header and both frames
    w.close()
