"""Sessions a lab can trust: one live session per participant unless asked, a resume on the
session's own clock, and a finished session said to be finished before anything else."""
from __future__ import annotations

import json

from _session_helpers import P01, ScriptedResponder, read_json_lines, write_protocol
from experiments.cli import main
from experiments.session import create_session, open_session
from experiments.session.hooks import SessionHooks

URL = "emulator://?clock=virtual&seed=1"


class Interrupt(SessionHooks):
    """Ctrl-C at the start of trial 2 (the session ends interrupted: unfinished, resumable)."""

    def at(self, point, spec, attempt):
        if point == "trial_started" and spec.trial_index == 2:
            raise KeyboardInterrupt


def _interrupted_session(tmp_path, url=URL, clock="virtual"):
    proto = write_protocol(tmp_path, real_samples=(), contact_s=0.5)
    s = create_session(proto, P01, tmp_path / "data", url, seed=1, responder_name="simulated",
                       clock=clock)
    s.hooks = Interrupt()
    assert s.run(ScriptedResponder()) == 1
    return proto, s


def _run_args(proto, tmp_path, *extra):
    return ["run", str(proto), "--participant", str(P01), "--display", URL, "--responder",
            "simulated", "--data", str(tmp_path / "data"), "--seed", "2", "--quiet", *extra]


def test_a_second_live_session_of_a_participant_is_refused(tmp_path, capsys):
    proto, s = _interrupted_session(tmp_path)
    capsys.readouterr()
    assert main(_run_args(proto, tmp_path)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "P01 has 1 unfinished session(s)" in err[0] and str(s.directory) in err[0]
    assert "--allow-second-session" in err[0] and "thermocue resume" in err[0]
    assert sorted(p.name for p in (tmp_path / "data" / "P01").iterdir()) == ["S01"]   # nothing written


def test_allow_second_session_warns_and_runs(tmp_path, capsys):
    proto, s = _interrupted_session(tmp_path)
    capsys.readouterr()
    assert main(_run_args(proto, tmp_path, "--allow-second-session")) == 0
    err = capsys.readouterr().err
    assert "warning: participant P01 has 1 unfinished session(s)" in err
    events = read_json_lines(tmp_path / "data" / "P01" / "S02" / "events.jsonl")
    assert events[-1]["event"] == "session_finished"


def test_a_finished_session_does_not_block_a_new_one(tmp_path, capsys):
    proto = write_protocol(tmp_path, real_samples=(), contact_s=0.5)
    assert main(_run_args(proto, tmp_path)) == 0
    assert main(_run_args(proto, tmp_path)) == 0          # the finished-session warning only
    assert (tmp_path / "data" / "P01" / "S02" / "session.json").exists()


def test_resume_keeps_the_sessions_clock_unless_told(tmp_path):
    # a virtual-clock session on a real-clock display URL (``--clock virtual``): a resume used to
    # follow the URL and switch to the real clock (rewarming for real between trials)
    _, s = _interrupted_session(tmp_path, url=URL, clock="virtual")
    meta = json.loads((s.directory / "session.json").read_text())
    meta["display_url"] = "emulator://?seed=1"            # the URL says real clock
    (s.directory / "session.json").write_text(json.dumps(meta))
    assert open_session(s.directory).clock.virtual
    assert open_session(s.directory, display_url="emulator://").clock.virtual
    assert not open_session(s.directory, clock="real").clock.virtual
    assert not open_session(s.directory, clock="auto").clock.virtual   # follow the URL, as asked


def test_a_virtual_clock_session_on_a_pty_resumes_virtual(tmp_path):
    # `thermocue emulator --clock virtual` on a pty and `run --clock virtual`: the URL is a path
    # that names no clock, and a resume on it used to switch to the real clock
    proto = write_protocol(tmp_path, real_samples=(), contact_s=0.5)
    s = create_session(proto, P01, tmp_path / "data", str(tmp_path / "pty"), seed=1,
                       responder_name="simulated", clock="virtual")
    assert open_session(s.directory).clock.virtual
    assert not open_session(s.directory, clock="real").clock.virtual
    assert not open_session(s.directory, display_url="emulator://?clock=real").clock.virtual


def test_resume_of_a_finished_session_says_so_before_anything_else(tmp_path, capsys, monkeypatch):
    proto = write_protocol(tmp_path, real_samples=(), contact_s=0.5)
    assert main(_run_args(proto, tmp_path)) == 0
    capsys.readouterr()
    session = tmp_path / "data" / "P01" / "S01"
    monkeypatch.delenv("DISPLAY", raising=False)          # a window could not open: not asked
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["resume", str(session), "--responder", "psychopy",
                 "--display", "/dev/nonexistent-display"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"thermocue: session {session} is already finished; nothing to do"]
