"""Loader: tidy table, exclusions, truncated / stale / duplicated / malformed logs."""
from __future__ import annotations

import csv
import json
import warnings

import pandas as pd
import pytest

from analysis import LogError, LogWarning, load_trials


def _rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _write_rows(path, rows, fieldnames=None):
    fieldnames = fieldnames or list(rows[0])
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fieldnames, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)


def test_tidy_table_counts_and_exclusions(study):
    data, _ = study(n_per_group=3, fault_rate=0.2, seed=11)
    with warnings.catch_warnings():
        warnings.simplefilter("error", LogWarning)          # a clean study warns about nothing
        log = load_trials(data)
    t = log.trials
    raw = pd.concat([pd.read_csv(p, keep_default_na=False) for p in sorted(data.rglob("trials.csv"))])
    assert len(t) == len(raw)
    assert sorted(log.sessions["participant"]) == sorted(f"{g}{i:02d}" for g in "AB" for i in range(3))
    n_fault = int((raw["status"] == "fault").sum())
    n_fam = int((raw["block"] == "familiarise").sum())
    counts = log.exclusion_counts().set_index("reason")["n_trials"]
    assert counts["familiarisation"] == n_fam == 6 * 4
    assert counts.get("status fault", 0) == n_fault > 0
    assert counts["included"] == len(raw) - n_fam - n_fault == 6 * 24
    a = log.analysable
    assert set(a["mode"]) == {"real", "simulated"} and a["included"].all()
    assert a["correct"].isin([0, 1]).all()
    assert (a["correct"] == (a["response_id"] == a["roughness_id"]).astype(int)).all()
    assert a["trial_index"].dtype.kind == "i" and a["rt_s"].dtype.kind == "f"


def test_truncated_csv_read_up_to_damage_with_warning(study):
    data, _ = study(n_per_group=1, write_events=False, seed=1)
    path = next(data.rglob("trials.csv"))
    text = path.read_text()
    lines = text.splitlines(keepends=True)
    # cut line 11 in the middle: header + 9 full rows survive, line 11 is torn
    path.write_text("".join(lines[:10]) + lines[10][:12])
    with pytest.warns(LogWarning, match=rf"{path}: line 11: torn last line"):
        log = load_trials(data)
    rows = log.trials[log.trials["source"] == str(path)]
    assert len(rows) == 9 and rows["line"].max() == 10


def test_wrong_field_count_in_the_middle_stops_there(study):
    data, _ = study(n_per_group=1, write_events=False, seed=2)
    path = next(data.rglob("trials.csv"))
    lines = path.read_text().splitlines(keepends=True)
    lines[5] = "A00,A,S1,real,5\n"
    path.write_text("".join(lines))
    with pytest.warns(LogWarning, match=rf"{path}: line 6: expected 21 fields, got 5"):
        log = load_trials(data)
    assert len(log.trials[log.trials["source"] == str(path)]) == 4


def test_nul_bytes_are_damage(study):
    data, _ = study(n_per_group=1, write_events=False, seed=3)
    path = next(data.rglob("trials.csv"))
    raw = path.read_bytes()
    cut = raw.index(b"\n", raw.index(b"\n") + 1) + 1 + 7        # 7 bytes into line 3
    path.write_bytes(raw[:cut] + b"\x00" * 64)
    with pytest.warns(LogWarning, match=rf"{path}: line 3: damaged bytes"):
        log = load_trials(data)
    assert len(log.trials[log.trials["source"] == str(path)]) == 1


def test_missing_csv_rebuilt_from_events_with_torn_tail(study):
    data, _ = study(n_per_group=1, seed=4)
    folder = next(data.rglob("trials.csv")).parent
    expected = _rows(folder / "trials.csv")
    (folder / "trials.csv").unlink()
    events = folder / "events.jsonl"
    text = events.read_text()
    events.write_text(text + '{"event": "trial_completed", "row": {"trial_ind')   # torn append
    with pytest.warns(LogWarning) as record:
        log = load_trials(data)
    messages = [str(w.message) for w in record]
    assert any(f"{folder / 'trials.csv'}: missing; rebuilt" in m for m in messages)
    assert any(f"{events}: line {text.count(chr(10)) + 1}: torn last line" in m for m in messages)
    rows = log.trials[log.trials["source"] == str(events)]
    assert len(rows) == len(expected)
    assert sorted(rows["trial_index"]) == sorted(int(r["trial_index"]) for r in expected)
    assert set(rows["participant"]) == {expected[0]["participant"]}
    assert set(rows["group"]) == {expected[0]["group"]}


def test_stale_csv_replaced_by_event_log(study):
    data, _ = study(n_per_group=1, seed=5)
    folder = next(data.rglob("trials.csv")).parent
    rows = _rows(folder / "trials.csv")
    _write_rows(folder / "trials.csv", rows[:-3])            # the last three trials not yet written
    with pytest.warns(LogWarning, match=r"older than events.jsonl \(3 trial rows missing\)"):
        log = load_trials(data)
    assert len(log.trials[log.trials["participant"] == rows[0]["participant"]]) == len(rows)


def test_exact_duplicate_dropped_with_warning(study):
    data, _ = study(n_per_group=1, write_events=False, seed=6)
    path = next(data.rglob("trials.csv"))
    rows = _rows(path)
    _write_rows(path, rows + [rows[7]])
    with pytest.warns(LogWarning, match=rf"{path}: line {len(rows) + 2}: exact duplicate of line 9"):
        log = load_trials(data)
    assert len(log.trials[log.trials["source"] == str(path)]) == len(rows)


def test_conflicting_duplicate_is_an_error(study):
    data, _ = study(n_per_group=1, write_events=False, seed=7)
    path = next(data.rglob("trials.csv"))
    rows = _rows(path)
    clash = dict(rows[7], rt_s="99.0")
    _write_rows(path, rows + [clash])
    with pytest.raises(LogError, match=rf"^{path}: rt_s: expected one row per \(participant, session, "
                                       rf"trial_index, attempt\)"):
        load_trials(data)


def test_missing_column_names_file_and_column(study):
    data, _ = study(n_per_group=1, write_events=False, seed=8)
    path = next(data.rglob("trials.csv"))
    rows = _rows(path)
    for r in rows:
        del r["status"]
    _write_rows(path, rows)
    with pytest.raises(LogError, match=rf"^{path}: status: expected a column named 'status'"):
        load_trials(data)


@pytest.mark.parametrize("column, value, expected", [
    ("status", "crashed", "expected one of ok, fault, aborted"),
    ("correct", "maybe", "expected an integer"),
    ("roughness_id", "7", "expected one of 1, 2, 3, 4"),
    ("group", "C", "expected one of A, B"),
    ("trial_index", "", "expected an integer"),
])
def test_bad_values_name_file_column_and_line(study, column, value, expected):
    data, _ = study(n_per_group=1, write_events=False, seed=9)
    path = next(data.rglob("trials.csv"))
    rows = _rows(path)
    rows[4][column] = value
    _write_rows(path, rows)
    with pytest.raises(LogError, match=rf"^{path}: {column}: {expected}.*line 6.*got '{value}'"):
        load_trials(data)


def test_correct_inconsistent_with_response_is_an_error(study):
    data, _ = study(n_per_group=1, write_events=False, seed=10)
    path = next(data.rglob("trials.csv"))
    rows = _rows(path)
    i = next(i for i, r in enumerate(rows) if r["block"] == "real")
    rows[i]["correct"] = str(1 - int(rows[i]["correct"]))
    _write_rows(path, rows)
    with pytest.raises(LogError, match=rf"^{path}: correct: expected"):
        load_trials(data)


def test_retry_after_fault_and_superseded_attempt(study):
    data, _ = study(n_per_group=1, write_events=False, seed=12)
    path = next(data.rglob("trials.csv"))
    rows = _rows(path)
    i = next(i for i, r in enumerate(rows) if r["block"] == "real")
    redo = dict(rows[i], attempt="2", rt_s="3.5")                # a second ok attempt of one trial
    _write_rows(path, rows + [redo])
    log = load_trials(data)
    t = log.trials[(log.trials["trial_index"] == int(rows[i]["trial_index"]))
                   & (log.trials["participant"] == rows[i]["participant"])]
    assert list(t["attempt"]) == [1, 2]
    assert list(t["exclusion"]) == ["superseded attempt", ""]
    assert not log.analysable.duplicated(["participant", "session", "trial_index"]).any()


def test_no_sessions_is_an_error(tmp_path):
    with pytest.raises(LogError, match="expected session folders"):
        load_trials(tmp_path)
    with pytest.raises(LogError, match="expected an existing directory"):
        load_trials(tmp_path / "nope")


def test_session_json_fills_missing_group_in_events(study):
    data, _ = study(n_per_group=1, write_csv=False, seed=13)
    events = next(data.rglob("events.jsonl"))
    lines = [json.loads(l) for l in events.read_text().splitlines()]
    for e in lines:                       # the session context lost from the event log
        e.pop("group", None)
        e.pop("participant", None)
    events.write_text("".join(json.dumps(e) + "\n" for e in lines))
    with pytest.warns(LogWarning, match="missing; rebuilt"):
        log = load_trials(data)
    meta = json.loads((events.parent / "session.json").read_text())
    rows = log.trials[log.trials["source"] == str(events)]
    assert len(rows) == 28
    assert set(rows["group"]) == {meta["group"]}
    assert set(rows["participant"]) == {meta["participant"]["id"]}


def test_aborted_attempt_in_the_event_log(study):
    data, _ = study(n_per_group=1, write_csv=False, seed=14)
    events = next(data.rglob("events.jsonl"))
    lines = events.read_text().splitlines(keepends=True)
    # attempt 1 of trial 7 was aborted (killed) before its retry, as sessionfiles.logbook logs it
    start = next(l for l in lines if '"trial_started"' in l and '"trial_index": 7,' in l)
    aborted = start.replace('"attempt": 1', '"attempt": 0')
    tail = ('{"event": "trial_aborted", "trial_index": 7, "attempt": 0, "reason": "killed", '
            '"fault_code": "E_KILL"}\n')
    i = lines.index(start)
    events.write_text("".join(lines[:i] + [aborted, tail] + lines[i:]))
    with pytest.warns(LogWarning, match="missing; rebuilt"):
        log = load_trials(data)
    t = log.trials[(log.trials["source"] == str(events)) & (log.trials["trial_index"] == 7)]
    assert list(t["attempt"]) == [0, 1]
    assert list(t["status"]) == ["aborted", "ok"]
    assert list(t["exclusion"]) == ["status aborted", ""]
    assert t["fault_code"].iloc[0] == "E_KILL" and t["mode"].iloc[0] == t["mode"].iloc[1]


def test_session_without_trials_is_skipped_with_a_warning(study):
    data, _ = study(n_per_group=1, seed=15)
    empty = data / "C99" / "S1"
    empty.mkdir(parents=True)
    (empty / "events.jsonl").write_text('{"event": "session_started", "participant": "C99"}\n')
    with pytest.warns(LogWarning, match=rf"{empty}: no trial rows"):
        log = load_trials(data)
    assert "C99" not in set(log.trials["participant"]) and len(log.sessions) == 2
    only = data / "only"
    only.mkdir()
    (empty.parent).rename(only / "C99")
    with pytest.warns(LogWarning), pytest.raises(LogError, match="expected at least one session"):
        load_trials(only)


def test_empty_csv_falls_back_to_events(study):
    data, _ = study(n_per_group=1, seed=16)
    path = next(data.rglob("trials.csv"))
    path.write_text("")
    with pytest.warns(LogWarning, match=rf"{path}: header: expected a CSV header line.*using "
                                        rf"events.jsonl instead"):
        log = load_trials(data)
    assert (log.trials["source"] == str(path.parent / "events.jsonl")).sum() == 28


# --------------------------------------------------------------------------- mixed protocols

@pytest.fixture(scope="module")
def mixed_protocols(tmp_path_factory):
    """A data folder as the README workflow leaves it: one participant's Exp. 2 session
    (``roughness_recognition``) and an Exp. 1 session (``interface_temperature``, recorded for
    calibration), both made by the real session runner on the emulated display."""
    from pathlib import Path

    from experiments.cli import main
    record = Path(__file__).resolve().parents[2] / "participants" / "examples" / "P01.json"
    data = tmp_path_factory.mktemp("mixed") / "data"
    for protocol, session in (("roughness_recognition", "S01"), ("interface_temperature", "S02")):
        status = main(["run", protocol, "--participant", str(record), "--display",
                       "emulator://?clock=virtual", "--responder", "simulated", "--data", str(data),
                       "--seed", "1", "--session", session, "--quiet"])
        assert status == 0, protocol
    return data


def test_sessions_of_a_protocol_without_answers_are_skipped(mixed_protocols, tmp_path):
    import re

    from analysis import analyze
    exp1 = mixed_protocols / "P01" / "S02"
    with pytest.warns(LogWarning, match=rf"{re.escape(str(exp1))}/session\.json: protocol: .*"
                                        rf"'interface_temperature' \(experiment 1\).*"
                                        rf"session {re.escape(str(exp1))} skipped"):
        log = load_trials(mixed_protocols)
    assert set(log.trials["session"]) == {"S01"}
    assert not log.trials["source"].str.contains("S02").any()
    skipped = log.skipped_sessions
    assert list(skipped["path"]) == [str(exp1)] and list(skipped["n_rows"]) == [0]
    assert "interface_temperature" in skipped["skipped"].iloc[0]
    assert list(log.sessions.loc[log.sessions["skipped"] == "", "session"]) == ["S01"]
    # the whole analysis runs, and its report lists the skipped session among the load problems
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        analyze(mixed_protocols, tmp_path / "out", n_boot=20, bayes=False)
    report = (tmp_path / "out" / "report.md").read_text()
    assert f"session {exp1} skipped" in report
    written = pd.read_csv(tmp_path / "out" / "sessions.csv", keep_default_na=False)
    assert written.loc[written["path"] == str(exp1), "skipped"].str.contains("interface_temperature").all()


def test_bad_roughness_id_in_a_recognition_session_is_still_an_error(mixed_protocols, tmp_path):
    import shutil
    data = tmp_path / "data"
    shutil.copytree(mixed_protocols, data)
    path = data / "P01" / "S01" / "trials.csv"
    rows = _rows(path)
    rows[5]["roughness_id"] = "0"
    _write_rows(path, rows)
    with pytest.warns(LogWarning, match="interface_temperature"), \
            pytest.raises(LogError, match=rf"{path}: roughness_id: expected one of 1, 2, 3, 4 "
                                          rf"\(line 7\), got '0'"):
        load_trials(data)


def test_missing_optional_columns_are_reported(study, tmp_path):
    from analysis import analyze
    data, _ = study(n_per_group=2, write_events=False, seed=21)
    path = sorted(data.rglob("trials.csv"))[0]
    rows = _rows(path)
    for row in rows:
        del row["rt_s"], row["tracking_rms_C"]
    _write_rows(path, rows)
    with pytest.warns(LogWarning, match=rf"{path}: rt_s, tracking_rms_C: expected optional "
                                        rf"column\(s\) rt_s, tracking_rms_C, got none"):
        log = load_trials(data)
    assert [w for w in log.warnings if str(path) in w and "rt_s" in w]
    from_path = log.trials["source"] == str(path)
    assert log.trials.loc[from_path, "rt_s"].isna().all()
    assert log.trials.loc[~from_path & log.trials["included"], "rt_s"].notna().all()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        analyze(data, tmp_path / "out", n_boot=20, bayes=False)
    assert f"{path}: rt_s, tracking_rms_C: expected optional column(s)" in \
        (tmp_path / "out" / "report.md").read_text()
