"""Damage is never repaired silently.

Regression: an events.jsonl cut mid-file (damage, a partial copy, a restore) was read as a log
torn by a crash in its last line: resume dropped completed trials from trials.csv, re-ran them,
overwrote their traces and exited 0 without a word.
"""
from __future__ import annotations

import hashlib

import pytest

from _session_helpers import P01, ScriptedDisplay, ScriptedResponder, write_protocol
from experiments.errors import SessionError
from experiments.session import create_session, open_session


def _stopped_session(tmp_path):
    s = create_session(write_protocol(tmp_path, sim_samples=()), P01, tmp_path / "data",
                       "scripted://", seed=7, clock="virtual")
    disp = ScriptedDisplay(script=["ok", "ok", "raise", "raise", "raise"])
    assert s.run(ScriptedResponder(), display=disp) == 1          # stopped after 3 faults
    return s.directory


def _fingerprint(directory):
    return {p.relative_to(directory).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(directory.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("where", [0.15, 0.4, 0.6, 0.8])
def test_a_log_cut_mid_file_is_refused_and_nothing_changes(tmp_path, where, capsys):
    directory = _stopped_session(tmp_path)
    log = directory / "events.jsonl"
    data = log.read_bytes()
    cut = int(len(data) * where)
    assert data[:cut].count(b"\n") < data.count(b"\n") - 1       # not in the last line
    log.write_bytes(data[:cut])
    before = _fingerprint(directory)
    with pytest.raises(SessionError) as err:
        open_session(directory).run(ScriptedResponder(), display=ScriptedDisplay())
    msg = str(err.value)
    assert str(log) in msg and "cut or replaced" in msg and "trial " in msg
    assert _fingerprint(directory) == before                     # nothing re-run, nothing lost


def test_a_torn_last_line_is_repaired_and_said(tmp_path, capsys):
    directory = _stopped_session(tmp_path)
    log = directory / "events.jsonl"
    log.write_bytes(log.read_bytes() + b'{"event": "note", "se')  # a crash during an append
    capsys.readouterr()
    assert open_session(directory).run(ScriptedResponder(), display=ScriptedDisplay()) == 0
    err = capsys.readouterr().err
    assert "repaired:" in err and "torn last line (21 bytes" in err


def test_an_existing_trace_is_never_overwritten(tmp_path, capsys):
    directory = _stopped_session(tmp_path)
    stray = directory / "traces" / "trial-003.csv"       # the log never explains this file
    stray.write_text("time_s\n1.0\n")
    # trial 3 was started in the log, so the log is complete; the file must still survive
    assert open_session(directory).run(ScriptedResponder(), display=ScriptedDisplay()) == 0
    kept = list((directory / "traces").glob("trial-003.replaced-before-attempt-*.csv"))
    assert len(kept) == 1 and kept[0].read_text() == "time_s\n1.0\n"
    assert "repaired:" in capsys.readouterr().err
