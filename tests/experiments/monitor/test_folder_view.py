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
