"""Durability is a setting each writer and each session takes, not a process-wide flag.

``os.fsync`` is counted (the real call still runs): a writer given ``durable=False`` makes the
same files without one fsync, while any other writer in the same process, at the same time,
still fsyncs everything.
"""
from __future__ import annotations

import io
import os

import pytest

from sessionfiles import logbook, session_files


@pytest.fixture
def fsyncs(monkeypatch):
    calls = []
    real = os.fsync

    def counting(fd):
        calls.append(fd)
        return real(fd)

    monkeypatch.setattr(os, "fsync", counting)
    return calls


def _write_all(folder, durable):
    logbook.ensure_dir(folder / "a" / "b", durable=durable)
    logbook.atomic_write_text(folder / "a" / "t.txt", "x\n", durable=durable)
    logbook.atomic_write_json(folder / "a" / "j.json", {"k": 1}, durable=durable)
    with logbook.EventLog(folder / "a" / "events.jsonl", durable=durable) as log:
        log.append("note", text="one")
        log.append("note", text="two")
    logbook.write_trials_csv(folder / "a" / "trials.csv", [], durable=durable)
    assert logbook.append_text(folder / "a" / "t.txt", "y\n", 2, durable=durable)
    session_files.TraceWriter(folder / "a" / "trace.csv", durable=durable).close()


def test_no_fsync_when_off_and_every_fsync_when_on_in_one_process(tmp_path, fsyncs):
    _write_all(tmp_path / "off", durable=False)
    assert fsyncs == []
    _write_all(tmp_path / "on", durable=True)
    # dirs (2 made + parent), 2 atomic writes (file + folder each), the log (new file + folder,
    # 2 appends), trials.csv (2), the append (1), the trace (file + folder)
    assert len(fsyncs) >= 14
    off = sorted(p.relative_to(tmp_path / "off") for p in (tmp_path / "off").rglob("*"))
    on = sorted(p.relative_to(tmp_path / "on") for p in (tmp_path / "on").rglob("*"))
    assert off == on                                           # the same files either way
    for rel in (p for p in on if (tmp_path / "on" / p).is_file() and p.name != "events.jsonl"):
        assert (tmp_path / "off" / rel).read_bytes() == (tmp_path / "on" / rel).read_bytes()


def test_the_default_is_durable_and_there_is_no_process_switch(tmp_path, fsyncs):
    assert not hasattr(logbook, "set_durable") and not hasattr(logbook, "is_durable")
    with logbook.EventLog(tmp_path / "events.jsonl") as log:
        log.append("note")
    assert len(fsyncs) >= 3                  # the new file, its folder, the append


@pytest.mark.slow          # two emulated sessions end to end, one fsyncing every event
def test_a_non_durable_session_leaves_a_durable_one_durable(tmp_path, fsyncs):
    from experiments.responders import get_responder
    from experiments.session import create_session
    from experiments.participant_model.cohort import write_cohort
    paths = {p.stem: p for p in write_cohort(tmp_path / "participants", seed=0)}

    def run(pid, durable):
        session = create_session("roughness_recognition", paths[pid], tmp_path / "data",
                                 "emulator://?clock=virtual&seed=0", seed=0,
                                 responder_name="simulated", clock="virtual", out=io.StringIO(),
                                 durable=durable)
        assert session.durable is durable
        fsyncs.clear()
        assert session.run(get_responder("simulated", seed=0)) == 0
        return list(fsyncs)

    fast = run("P01", False)
    slow = run("P16", True)
    # the non-durable session's run fsyncs only outside the session's own writers (the profile
    # cache, not a session's file; its BIDS export follows the session's setting); the durable
    # one each event
    events = sum(1 for _ in open(tmp_path / "data" / "P16" / "S01" / "events.jsonl"))
    assert len(slow) >= events > len(fast)
