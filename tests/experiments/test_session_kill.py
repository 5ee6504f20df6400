"""SIGKILL `thermocue run` at many points, `thermocue resume`, and prove nothing is lost.

The runner is a real subprocess on the in-process emulator with its virtual clock
(``emulator://?clock=virtual``), answered by the console responder from a pipe. The engine's
test hook ``THERMOCUE_TEST_PAUSE_AT=point:trial`` makes it print ``THERMOCUE_PAUSED`` and wait
at a named point (before the upload, while the display plays or records, between the response
and the write, ...); the test then kills it with SIGKILL, which no handler can see. A second test
kills at seeded random times instead, wherever the runner happens to be.

What must hold after every kill and resume (docs/design.md, "Durability"):

* every trial of the schedule ends with exactly one completed row, in schedule order;
* a completed trial is never run again and its row never changes;
* an attempt cut off mid-way is kept as an ``aborted`` row (attempt 1) and the trial is re-run
  as attempt 2;
* ``trials.csv`` equals the table rebuilt from ``events.jsonl``;
* the schedule is the one stored at the start.
"""
from __future__ import annotations

import csv
import json
import os
import select
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from _session_helpers import P01, write_protocol
from sessionfiles.logbook import read_events, trials_from_events

pytestmark = pytest.mark.slow

THERMOCUE = [sys.executable, "-m", "experiments"]
URL = "emulator://?clock=virtual&seed=3"
ANSWERS = "1\n" * 400          # confirmations and answers alike: any line confirms, "1" answers


def _spawn(args, pause=None):
    env = {k: v for k, v in os.environ.items() if k != "THERMOCUE_TEST_PAUSE_AT"}
    if pause:
        env["THERMOCUE_TEST_PAUSE_AT"] = pause
    proc = subprocess.Popen(THERMOCUE + args, env=env, stdin=subprocess.PIPE,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        proc.stdin.write(ANSWERS.encode())
        proc.stdin.close()
    except BrokenPipeError:
        pass
    proc.stdin = None
    return proc


def _wait_paused(proc, timeout=40.0) -> str:
    """Read stderr until the pause marker; return the marker line."""
    buf = b""
    deadline = time.monotonic() + timeout
    fd = proc.stderr.fileno()
    while time.monotonic() < deadline:
        ready, _, _ = select.select([fd], [], [], 0.2)
        if ready:
            chunk = os.read(fd, 4096)
            if not chunk:
                break
            buf += chunk
            for line in buf.decode(errors="replace").splitlines():
                if line.startswith("THERMOCUE_PAUSED"):
                    return line
    proc.kill()
    proc.wait()
    raise AssertionError(f"no pause marker; exit {proc.returncode}; stderr:\n{buf.decode()[-3000:]}")


def _kill(proc) -> None:
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=10)
    proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL


def _finish(proc, timeout=90) -> str:
    _, err = proc.communicate(timeout=timeout)
    assert proc.returncode == 0, err.decode()[-3000:]
    return err.decode()


def _rows(session):
    with open(session / "trials.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def _completed(rows) -> dict:
    """Completed rows by trial index, without empty cells (columns come and go with the rows)."""
    return {r["trial_index"]: {k: v for k, v in r.items() if v != ""}
            for r in rows if r["status"] in ("ok", "fault")}


def _check(session, schedule, done_before: dict) -> dict:
    """Invariants that hold at any moment; returns the completed rows by trial index."""
    events, report = read_events(session / "events.jsonl", warn=False)
    assert not report.bad_lines
    seqs = [e["seq"] for e in events]
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)
    rows = _rows(session)
    keys = [(r["trial_index"], r["attempt"]) for r in rows]
    assert len(keys) == len(set(keys)), "a trial attempt written twice"
    done = _completed(rows)
    assert len(done) == len([r for r in rows if r["status"] in ("ok", "fault")]), "a trial completed twice"
    for index, row in done_before.items():   # completed rows never change or vanish
        assert done[index] == row
    order = [int(r["trial_index"]) for r in rows if r["status"] in ("ok", "fault")]
    assert order == [s["trial_index"] for s in schedule][:len(order)]
    for r in rows:
        assert r["status"] in ("ok", "fault", "aborted")
        if r["status"] == "aborted":
            assert (r["trial_index"], str(int(r["attempt"]) + 1)) in keys or r["trial_index"] not in done
    return done


def _session_starts(session) -> int:
    try:
        text = (session / "events.jsonl").read_text(errors="replace")
    except FileNotFoundError:
        return 0
    return text.count('"event":"session_started"') + text.count('"event":"session_resumed"')


def _rebuilt_equals_csv(session) -> None:
    events, _ = read_events(session / "events.jsonl", warn=False)
    rebuilt = trials_from_events(events)
    rows = _rows(session)
    assert [(str(r["trial_index"]), str(r["attempt"]), r["status"]) for r in rebuilt] == \
        [(r["trial_index"], r["attempt"], r["status"]) for r in rows]


@pytest.fixture
def protocol(tmp_path):
    return write_protocol(tmp_path, contact_s=1.0, rewarm_s=0.25)


def test_kill_at_named_points_then_resume_loses_and_duplicates_nothing(tmp_path, protocol):
    data = tmp_path / "data"
    session = data / "P01" / "S01"
    run = ["run", str(protocol), "--participant", str(P01), "--display", URL, "--responder", "console",
           "--data", str(data), "--seed", "11", "--session", "S01", "--quiet"]
    resume = ["resume", str(session), "--quiet"]
    # (point, trial): trials 1-4 are real, 5-8 simulated (the protocol's fixed block order).
    points = [("playback", 2), ("after_response", 3), ("after_write", 4), ("upload", 5),
              ("playback", 6), ("armed", 7), ("trial_started", 8)]
    done: dict = {}
    schedule = None
    for i, (point, trial) in enumerate(points):
        proc = _spawn(run if i == 0 else resume, pause=f"{point}:{trial}")
        marker = _wait_paused(proc)
        assert marker.split()[1:3] == [point, str(trial)]
        _kill(proc)
        if schedule is None:
            schedule = json.loads((session / "session.json").read_text())["schedule"]
            assert [s["mode"] for s in schedule] == ["real"] * 4 + ["simulated"] * 4
        events, _ = read_events(session / "events.jsonl", warn=False)
        last_start = [e for e in events if e["event"] == "trial_started"][-1]
        assert last_start["trial_index"] == trial
        done = _check(session, schedule, done)
        # the killed trial is complete only when killed after its write
        assert (str(trial) in done) == (point == "after_write")
    err = _finish(_spawn(resume))
    assert "Traceback" not in err
    done = _check(session, schedule, done)
    assert sorted(int(k) for k in done) == list(range(1, 9))
    rows = _rows(session)
    assert all(r["status"] in ("ok", "aborted") for r in rows)
    aborted = sorted((int(r["trial_index"]), int(r["attempt"])) for r in rows if r["status"] == "aborted")
    assert aborted == [(2, 1), (3, 1), (5, 1), (6, 1), (7, 1), (8, 1)]
    assert {r["abort_reason"] for r in rows if r["status"] == "aborted"} == {"killed"}
    for index, row in done.items():
        assert row["attempt"] == ("1" if index in ("1", "4") else "2")
        assert row["response_id"] == "1" and row["correct"] == str(int(row["roughness_id"] == "1"))
        trace = (session / row["trace_file"]).read_text().splitlines()
        assert trace[0].startswith("time_s,target_C,contact_C") and len(trace) > 20
    # Attempts killed after recording had started keep their (partial) traces.
    kept = sorted(p.name for p in (session / "traces").glob("*.aborted.csv"))
    assert kept == ["trial-002.attempt-1.aborted.csv", "trial-003.attempt-1.aborted.csv",
                    "trial-006.attempt-1.aborted.csv"]
    _rebuilt_equals_csv(session)
    events, _ = read_events(session / "events.jsonl", warn=False)
    assert [e["event"] for e in events].count("session_resumed") == len(points)
    assert events[-1]["event"] == "session_finished"
    meta = json.loads((session / "session.json").read_text())
    assert meta["schedule"] == schedule


def test_kill_at_random_moments_then_resume(tmp_path, protocol):
    data = tmp_path / "data"
    session = data / "P01" / "S01"
    # A real clock for the session's own waits (0.25 s rewarming) stretches the run over a
    # couple of seconds, so that the kills land inside it.
    run = ["run", str(protocol), "--participant", str(P01), "--display", URL, "--responder", "console",
           "--data", str(data), "--seed", "12", "--session", "S01", "--quiet", "--clock", "real"]
    resume = ["resume", str(session), "--quiet", "--clock", "real"]
    rng = np.random.default_rng(20261122)
    done: dict = {}
    schedule = None
    landed = []
    for delay in rng.uniform(0.05, 1.5, size=4):
        runs = _session_starts(session)
        proc = _spawn(resume if (session / "session.json").exists() else run)
        deadline = time.monotonic() + 40      # Python's start-up varies with the machine's load:
        while _session_starts(session) == runs and proc.poll() is None \
                and time.monotonic() < deadline:   # count from the run's first event
            time.sleep(0.01)
        time.sleep(delay)          # wherever it is: an fsync, a frame, a rewrite of trials.csv
        if proc.poll() is not None:
            break
        _kill(proc)
        if not (session / "session.json").exists():
            continue
        schedule = schedule or json.loads((session / "session.json").read_text())["schedule"]
        if (session / "trials.csv").exists():
            done = _check(session, schedule, done)
        landed.append(len(done))
    assert any(0 < n < 8 for n in landed), f"no kill landed mid-session: {landed}"
    _finish(_spawn(resume if (session / "session.json").exists() else run))
    schedule = schedule or json.loads((session / "session.json").read_text())["schedule"]
    done = _check(session, schedule, done)
    assert sorted(int(k) for k in done) == list(range(1, 9))
    _rebuilt_equals_csv(session)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_sigterm_and_sigint_put_the_display_neutral_and_close_the_log(tmp_path, protocol, sig):
    data = tmp_path / "data"
    session = data / "P01" / "S01"
    device_log = tmp_path / "device.jsonl"
    url = f"emulator://?clock=virtual&seed=3&log={device_log}"
    proc = _spawn(["run", str(protocol), "--participant", str(P01), "--display", url, "--responder",
                   "console", "--data", str(data), "--seed", "13", "--session", "S01", "--quiet"],
                  pause="playback:6")          # a simulated trial, the profile playing
    _wait_paused(proc)
    os.kill(proc.pid, sig)
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 1 and b"Traceback" not in err
    events, report = read_events(session / "events.jsonl", warn=False)
    assert report.ok and events[-1]["event"] == "session_interrupted"
    assert events[-1]["reason"] == signal.Signals(sig).name
    aborted = [e for e in events if e["event"] == "trial_aborted"]
    assert [(e["trial_index"], e["attempt"], e["reason"]) for e in aborted] == [(6, 1, "interrupted")]
    # The device was playing, then told to stop and hold neutral: its own log says so.
    device = [json.loads(line) for line in device_log.read_text().splitlines()]
    playing = max(i for i, d in enumerate(device) if d.get("state") == "PLAYING")
    after = device[playing + 1:]
    assert after and after[0] == {**after[0], "event": "state", "old": "PLAYING", "state": "IDLE",
                                  "why": "abort"}
    assert any(d["event"] == "neutral" and d["neutral_C"] == 32.0 for d in after)
    # And the interrupted session resumes at trial 6, attempt 2.
    _finish(_spawn(["resume", str(session), "--quiet"]))
    rows = _rows(session)
    assert [(r["trial_index"], r["attempt"], r["status"]) for r in rows if r["trial_index"] == "6"] \
        == [("6", "1", "aborted"), ("6", "2", "ok")]
    assert len(_completed(rows)) == 8


def test_kill_while_the_display_plays_over_a_pty_then_resume_on_the_same_device(tmp_path):
    """The device outlives the host: ``thermocue emulator`` on a real pty, the runner killed
    during playback (the device's watchdog sees the heartbeat stop), resumed on the same pty."""
    proto = write_protocol(tmp_path, contact_s=0.5, rewarm_s=0.0, real_samples=(1, 2), sim_samples=(3, 4))
    link = tmp_path / "pty"
    emulator = subprocess.Popen(THERMOCUE + ["emulator", "--link", str(link), "--clock", "virtual"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 30
        while not link.exists():
            assert emulator.poll() is None and time.monotonic() < deadline, "emulator did not start"
            time.sleep(0.05)
        data = tmp_path / "data"
        session = data / "P01" / "S01"
        proc = _spawn(["run", str(proto), "--participant", str(P01), "--display", str(link),
                       "--responder", "console", "--data", str(data), "--seed", "4", "--session", "S01",
                       "--quiet"], pause="playback:3")
        _wait_paused(proc)
        _kill(proc)
        schedule = json.loads((session / "session.json").read_text())["schedule"]
        done = _check(session, schedule, {})
        assert sorted(done) == ["1", "2"]
        _finish(_spawn(["resume", str(session), "--quiet"]))
    finally:
        emulator.terminate()
        emulator.wait(timeout=10)
    # What the design promises, not what a quiet machine does: every trial ends ``ok`` exactly
    # once, in schedule order; the attempt the kill cut off is kept as ``aborted``; any other
    # attempt before a trial's ``ok`` (a busy machine's watchdog trip, a lost frame) is a
    # written ``fault`` that carries its code, and the trial ran again after it.
    rows = _rows(session)
    ok = [r["trial_index"] for r in rows if r["status"] == "ok"]
    assert ok == [str(s["trial_index"]) for s in schedule], rows
    assert ("3", "1", "aborted") in [(r["trial_index"], r["attempt"], r["status"]) for r in rows]
    for index in ok:
        mine = [r for r in rows if r["trial_index"] == index]
        assert [r["attempt"] for r in mine] == [str(k) for k in range(1, len(mine) + 1)]
        assert mine[-1]["status"] == "ok"
        for r in mine[:-1]:
            assert r["status"] in ("aborted", "fault"), r
            if r["status"] == "fault":
                assert r.get("fault_code"), r
    for index, row in done.items():                   # rows completed before the kill stand
        now = next(r for r in rows if r["trial_index"] == index and r["status"] == "ok")
        assert {k: v for k, v in now.items() if v != ""} == row
    _rebuilt_equals_csv(session)
