"""The monitor's reading of a session folder: missing, half-written, damaged, live
(experiments.monitor.folder), without a browser."""
from __future__ import annotations

import json
import shutil

import pytest

from _session_helpers import P01, ScriptedDisplay, ScriptedResponder, write_protocol
from experiments.monitor.folder import FolderView, page_state
from experiments.monitor.stream import Cursor, update_for
from experiments.session import create_session


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A finished session with one faulted attempt (trial 1's first)."""
    tmp = tmp_path_factory.mktemp("finished")
    s = create_session(write_protocol(tmp, sim_samples=()), P01, tmp / "data", "scripted://",
                       seed=7, responder_name="scripted-test", clock="virtual")
    assert s.run(ScriptedResponder(), display=ScriptedDisplay(script=["fault"])) == 0
    return s.directory


def test_a_missing_folder_is_a_sentence_and_the_view_follows_it_once_it_appears(tmp_path, finished):
    folder = tmp_path / "P01" / "S01"
    view = FolderView(folder)
    view.poll()
    assert "no such session folder" in view.problem and str(folder) in view.problem
    folder.mkdir(parents=True)
    view.poll()
    assert "not a session folder (yet)" in view.problem
    shutil.copy(finished / "events.jsonl", folder / "events.jsonl")
    view.poll()
    assert "session.json: not written yet" in view.problem
    assert len(view.rows) == 5                       # the log is shown meanwhile
    shutil.copy(finished / "session.json", folder / "session.json")
    view.poll()
    assert view.problem is None and view.meta_public()["n_trials"] == 4
    assert view.status()["end"] == "finished" and view.status()["time_left_s"] == 0.0


def test_a_file_given_as_the_folder_is_named(finished):
    view = FolderView(finished / "trials.csv")
    view.poll()
    assert view.problem == f"{finished / 'trials.csv'}: expected a session folder, got a file"


def test_a_half_written_last_line_waits_and_a_damaged_line_stops_the_view_there(tmp_path, finished):
    folder = tmp_path / "S01"
    shutil.copytree(finished, folder)
    lines = (finished / "events.jsonl").read_bytes().splitlines(keepends=True)
    cut = next(i for i, line in enumerate(lines) if b'"trial_completed"' in line)
    (folder / "events.jsonl").write_bytes(b"".join(lines[:cut]) + lines[cut][:40])
    view = FolderView(folder)
    view.poll()
    assert view.problem is None and view.rows == []     # torn: not read yet, not an error
    with open(folder / "events.jsonl", "ab") as fh:
        fh.write(lines[cut][40:] + b'{"event": "state", "seq": 9\n' + b"".join(lines[cut + 1:]))
    view.poll()
    assert len(view.rows) == 1
    assert f"line {cut + 2} is damaged" in view.problem and "up to the line before it" in view.problem


def test_a_faulted_attempt_is_a_row_with_its_code_words_and_a_marker_on_its_trace(finished):
    view = FolderView(finished)
    view.poll()
    first = view.rows[0]
    assert (first["trial"], first["attempt"], first["status"], first["fault_code"]) == \
        (1, 1, "fault", "OVER_TEMPERATURE")
    assert "44.8 °C" in first["words"] and first["message"] == "pad above limit"
    got = view.trial_trace(first["trace_file"])
    assert got["fault"]["code"] == "OVER_TEMPERATURE"
    assert got["fault"]["time_s"] == got["trace"]["t"][-1]      # no FAULT frame: the last one
    assert view.trial_trace("session.json") is None              # only files the log names
    assert view.trial_trace("traces/../session.json") is None


def test_the_stream_sends_each_part_once_and_the_status_again_each_second(finished):
    view = FolderView(finished)
    view.poll()
    cursor = Cursor()
    first = update_for(view, cursor, now_s=1000.0)
    assert first["meta"]["participant"] == "P01" and first["problem"] is None
    assert first["rows_from"] == 0 and len(first["rows"]) == 5
    assert first["trace"]["reset"] and first["trace"]["key"] == [4, 1]
    assert update_for(view, cursor, now_s=1000.5) is None
    again = update_for(view, cursor, now_s=1001.0)
    assert list(again) == ["status"]


@pytest.mark.parametrize("machine,device,armed,want", [
    ("prompt", None, False, "neutral"), ("prepare", None, True, "armed"),
    ("wait_contact", "ARMED", True, "armed"), ("wait_contact", "PLAYING", True, "playing"),
    ("wait_contact", "RECORDING", True, "recording"), ("wait_contact", "FAULT", True, "fault"),
    ("fault", None, True, "fault"), ("rewarm", None, False, "neutral")])
def test_the_five_states(machine, device, armed, want):
    assert page_state(machine, device, armed) == want


def test_a_fifo_in_the_logs_place_is_a_sentence_not_a_hang(tmp_path, finished):
    import os
    folder = tmp_path / "S01"
    shutil.copytree(finished, folder)
    (folder / "events.jsonl").unlink()
    os.mkfifo(folder / "events.jsonl")
    view = FolderView(folder)
    view.poll()
    assert "events.jsonl" in view.problem and "cannot be read" in view.problem
    json.dumps(view.status())                       # the page's status still serialises


def test_the_running_attempt_that_faults_gets_its_marker_on_the_live_trace(tmp_path, finished):
    # the log cut just after the faulted attempt's trial_completed: that attempt is the live one
    folder = tmp_path / "S01"
    shutil.copytree(finished, folder)
    lines = (finished / "events.jsonl").read_bytes().splitlines(keepends=True)
    cut = next(i for i, line in enumerate(lines) if b'"trial_completed"' in line)
    (folder / "events.jsonl").write_bytes(b"".join(lines[:cut + 1]))
    view = FolderView(folder)
    view.poll()
    assert view.live.key == (1, 1) and view.live.done
    msg = update_for(view, Cursor())
    assert msg["trace"]["fault"]["code"] == "OVER_TEMPERATURE" and msg["trace"]["done"]
    assert msg["status"]["last_fault"]["code"] == "OVER_TEMPERATURE"
    assert msg["status"]["state"] == "neutral"     # the machine went on to write


def test_a_watchdog_trip_is_marked_where_the_display_fell_back_to_neutral():
    from experiments.monitor.trace import TraceColumns, fault_marker
    data = TraceColumns()
    data.add_lines([b"time_s,target_C,contact_C,ambient_C,finger_C,force1_N,force2_N,force3_N,"
                    b"force4_N,state"]
                   + [f"{0.01 * i:.2f},30,30.{i},20,35,0.5,0.5,0.5,0.5,{s}".encode()
                      for i, s in enumerate(["ARMED", "PLAYING", "PLAYING", "IDLE", "IDLE"])])
    marker = fault_marker(data, "WATCHDOG", "host heartbeat lost")
    assert (marker["time_s"], marker["value_C"]) == (0.03, 30.3)
    assert "heard nothing from the computer for 90 ms" in marker["words"]


def test_answers_are_shown_only_in_blocks_that_give_the_participant_feedback(finished):
    view = FolderView(finished)
    view.poll()
    assert all(r["answer"] is None and r["correct"] is None for r in view.rows)   # no feedback
    view.meta["blocks"] = [{"name": "real", "feedback": True, "response": True}]
    view._end_attempt({"event": "trial_completed", "trial_index": 9, "attempt": 1,
                       "row": {"status": "ok", "block": "real", "response_id": 2, "correct": 0}})
    assert (view.rows[-1]["answer"], view.rows[-1]["correct"]) == (2, 0)


def test_a_log_cut_shorter_or_replaced_is_read_again_from_its_start(tmp_path, finished):
    # thermocue resume cuts a torn last line; a log restored from a backup is another file
    folder = tmp_path / "S01"
    shutil.copytree(finished, folder)
    whole = (finished / "events.jsonl").read_bytes()
    view = FolderView(folder)
    view.poll()
    assert len(view.rows) == 5
    lines = whole.splitlines(keepends=True)
    cut = next(i for i, line in enumerate(lines) if b'"trial_completed"' in line)
    with open(folder / "events.jsonl", "r+b") as fh:        # the same file, cut shorter
        fh.truncate(len(b"".join(lines[:cut + 1])))
    view.poll()
    assert len(view.rows) == 1 and view.problem is None and view.meta is not None
    (folder / "events.new").write_bytes(whole)
    (folder / "events.new").replace(folder / "events.jsonl")   # another file under the name
    view.poll()
    assert len(view.rows) == 5 and view.status()["end"] == "finished"


def test_a_page_starts_afresh_when_the_log_does(tmp_path, finished):
    folder = tmp_path / "S01"
    shutil.copytree(finished, folder)
    view = FolderView(folder)
    view.poll()
    cursor = Cursor()
    assert len(update_for(view, cursor)["rows"]) == 5
    with open(folder / "events.jsonl", "r+b") as fh:
        fh.truncate(0)
    view.poll()
    msg = update_for(view, cursor)
    assert (msg["rows_from"], msg["rows"]) == (0, [])          # the page clears its table
