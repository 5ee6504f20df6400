"""What `thermocue run` and `resume` check before anything is written or played, and what they say.

Against the in-process emulator (``emulator://?clock=virtual``) where a display is needed:
simulated profiles the display would refuse, the display URL, ``--quiet``, an edited
``session.json``, the clock on resume, the progress line's elapsed time, the console's bell.
"""
from __future__ import annotations

import csv
import datetime as dt
import io
import json
import logging
import multiprocessing
from pathlib import Path

import pytest

from _session_helpers import P01, ScriptedDisplay, ScriptedResponder, read_json_lines, write_protocol
from experiments.cli import main
from experiments.profile_rate import window_rate
from experiments.session import create_session, open_session, plan_session

EMU = "emulator://?clock=virtual&seed=2"


def rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def edit(path, old, new):
    text = path.read_text()
    assert old in text, f"test setup: {old!r} not in {path.name}"
    path.write_text(text.replace(old, new, 1))
    return path


def run_args(proto, data, display=EMU, responder="simulated", *extra):
    return ["run", str(proto), "--participant", str(P01), "--display", display, "--responder",
            responder, "--data", str(data), "--seed", "5", *extra]


# --------------------------------------------------------------------------- 1. simulated profiles
@pytest.mark.parametrize("old, new, field, got", [
    ("max_rate_C_per_s = 10.0", "max_rate_C_per_s = 0.5", "display.max_rate_C_per_s", "got 0.5"),
    ("material_temperature_C = 20.0", "material_temperature_C = 60", "simulation.material_temperature_C",
     "got 60.0"),
])
def test_profiles_the_display_would_refuse_stop_the_run_before_anything_is_written(
        tmp_path, capsys, old, new, field, got):
    # Regression: the real block ran (trials 1-4) and the first simulated trial faulted 3 times.
    proto = edit(write_protocol(tmp_path), old, new)
    data = tmp_path / "data"
    assert main(run_args(proto, data)) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"thermocue run: {proto}: {field}: expected ") and got in err
    assert not data.exists()


def test_the_rate_message_gives_the_fastest_profiles_rate(tmp_path):
    from experiments.errors import ProtocolError
    from experiments.display.safety import profile_max_rate
    from experiments.session import simulated_target_profile
    from participants_schema import Participant
    proto = edit(write_protocol(tmp_path), "max_rate_C_per_s = 10.0", "max_rate_C_per_s = 0.5")
    with pytest.raises(ProtocolError) as ei:
        plan_session(proto, P01, tmp_path / "data", EMU, seed=5)
    from experiments.protocol import load_protocol
    p = load_protocol(proto)
    rates = {i: profile_max_rate(simulated_target_profile(p, Participant.read(P01), "A", 680.0, i,
                                                          p.sample(i).roughness_um).temperature, 0.02, 0.1)
             for i in (1, 2, 3, 4)}
    fastest = max(rates, key=rates.get)
    assert f"{rates[fastest]:.3g} °C/s over 0.1 s (sample {fastest}#" in str(ei.value)


def test_slewed_profiles_are_accepted_and_played_within_the_limit(tmp_path):
    proto = edit(write_protocol(tmp_path, real_samples=(1,)), 'method = "exact"\n',
                 'method = "exact"\nrate_limit = "slew"\n')
    edit(proto, "max_rate_C_per_s = 10.0", "max_rate_C_per_s = 2.0")
    data = tmp_path / "data"
    assert main(run_args(proto, data, EMU, "simulated", "--quiet")) == 0
    session = data / "P01" / "S01"
    table = rows(session / "trials.csv")
    assert [r["status"] for r in table] == ["ok"] * 5
    uploads = [e for e in read_json_lines(session / "events.jsonl") if e["event"] == "profile_uploaded"]
    assert len(uploads) == 4 and all(e["rate_limited_max_change_C"] > 0 for e in uploads)
    plan = plan_session(proto, P01, tmp_path / "other", EMU, seed=5)
    assert len(plan.profiles) == 4
    for prof in plan.profiles.values():
        assert window_rate(prof.temperature, 0.02, 0.1) <= 2.0 + 0.01 / 0.1


def test_slewing_below_the_rounding_step_is_refused_naming_the_rate(tmp_path):
    # limit_rate cannot slow a 0.01 °C-resolution profile below 0.1 °C/s over 0.1 s (it raised
    # a bare ValueError at the first simulated trial).
    from experiments.errors import ProtocolError
    proto = edit(write_protocol(tmp_path), 'method = "exact"\n', 'method = "exact"\nrate_limit = "slew"\n')
    edit(proto, "max_rate_C_per_s = 10.0", "max_rate_C_per_s = 0.05")
    with pytest.raises(ProtocolError, match=r"mini\.toml: display\.max_rate_C_per_s: expected more than "
                                            r"0\.1 °C/s with simulation\.rate_limit = 'slew'.*got 0\.05$"):
        plan_session(proto, P01, tmp_path / "data", EMU, seed=5)
    assert not (tmp_path / "data").exists()


def test_a_profile_longer_than_the_device_holds_is_refused_before_the_folder(tmp_path, capsys):
    # The emulator holds 65,536 points; 400 s at 200 Hz is 80,001.
    proto = write_protocol(tmp_path, contact_s=400.0, real_samples=(1,), sim_samples=(1,))
    edit(proto, "rate_Hz = 50.0", "rate_Hz = 200.0")
    data = tmp_path / "data"
    assert main(run_args(proto, data)) == 2
    err = capsys.readouterr().err
    assert f"{proto}: simulation.duration_s: expected a profile of at most 65536 points" in err
    assert "got 400.0 s (80001 points)" in err and err.count("\n") == 1
    assert not (data / "P01").exists()


# --------------------------------------------------------------------------- 3. the display URL
@pytest.mark.parametrize("display, status, message", [
    ("{tmp}/no-such-tty", 1, "thermocue run: display: cannot open '{tmp}/no-such-tty': no such device"),
    ("/dev/null", 2, "thermocue run: --display: expected a serial device (a terminal), got '/dev/null'"),
    ("emulator://?bogus=1", 2, "thermocue run: --display: expected a display URL, got "
                               "'emulator://?bogus=1': expected a URL of the form"),
    ("nosuch://x", 2, "thermocue run: --display: expected a display URL or a serial device path, got "
                      "'nosuch://x'"),
])
def test_a_bad_or_unreachable_display_leaves_no_session_folder(tmp_path, capsys, display, status, message):
    # Regression: the folder was written first, so each try left an empty S01, S02, ...
    display, message = display.format(tmp=tmp_path), message.format(tmp=tmp_path)
    data = tmp_path / "data"
    for _ in range(2):
        assert main(run_args(write_protocol(tmp_path), data, display, "simulated", "--quiet")) == status
        err = capsys.readouterr().err
        assert err.startswith(message) and err.count("\n") == 1 and "Traceback" not in err
    assert not data.exists()


def test_resume_with_a_bad_display_runs_and_logs_nothing(tmp_path, capsys):
    s = create_session(write_protocol(tmp_path), P01, tmp_path / "data", EMU, seed=5,
                       responder_name="simulated")
    capsys.readouterr()
    assert main(["resume", str(s.directory), "--display", "emulator://?bogus=1"]) == 2
    assert main(["resume", str(s.directory), "--display", str(tmp_path / "gone")]) == 1
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith("thermocue resume: --display: expected a display URL")
    assert err[1].startswith(f"thermocue resume: display: cannot open '{tmp_path / 'gone'}'")
    assert "nothing was run" in err[1] and len(err) == 2
    assert _nothing_logged(s.directory)


# --------------------------------------------------------------------------- 4. --quiet
def test_quiet_still_says_why_the_session_stopped(tmp_path, capsys):
    # Regression: with --quiet, "stopped after 3 faults" was not printed: exit 1 and no reason.
    proto = write_protocol(tmp_path, real_samples=(1, 2), sim_samples=())
    data = tmp_path / "data"
    status = main(run_args(proto, data, "emulator://?clock=virtual&faults=sensor_range", "simulated",
                           "--quiet"))
    err = capsys.readouterr().err
    assert status == 1
    assert "stopped after 3 consecutive faults; resume with `thermocue resume" in err
    # the sensor fault latches: ABORT does not clear it, the next ARMs are refused
    assert err.count("trial 1: display fault SENSOR_FAILURE") == 1
    assert err.count("trial 1: display fault FAULT_LATCHED") == 2
    assert "trial 1 of 2" not in err and "group A" not in err     # progress stays quiet


# --------------------------------------------------------------------------- 5. an edited session.json
@pytest.mark.parametrize("change, message", [
    (lambda m: m.update(seed="x"), "seed: expected an integer ≥ 0, got 'x'"),
    (lambda m: m.update(seed=True), "seed: expected an integer ≥ 0, got True"),
    (lambda m: m.update(seed=8), "schedule: expected the schedule of the stored protocol, participant "
                                 "P01 and seed 8"),
    (lambda m: m["schedule"][0].update(roughness_id=m["schedule"][0]["roughness_id"] % 4 + 1),
     "schedule: expected the schedule of the stored protocol, participant P01 and seed 7 (8 trials; "
     "trial 1:"),
    (lambda m: m["schedule"].pop(), "schedule: expected the schedule of the stored protocol, participant "
                                    "P01 and seed 7 (8 trials; trial 8:"),
    (lambda m: m.update(group="C"), "group: expected one of ('A', 'B'), got 'C'"),
])
def test_resume_refuses_an_edited_seed_or_schedule(tmp_path, capsys, change, message):
    s = create_session(write_protocol(tmp_path), P01, tmp_path / "data", "scripted://", seed=7,
                       responder_name="simulated", clock="virtual")
    path = s.directory / "session.json"
    meta = json.loads(path.read_text())
    change(meta)
    path.write_text(json.dumps(meta))
    capsys.readouterr()
    assert main(["resume", str(s.directory), "--display", EMU]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"thermocue resume: {path}: {message}") and err.count("\n") == 1
    assert _nothing_logged(s.directory)


def test_a_schedule_from_another_algorithm_is_resumed_as_stored_and_said(tmp_path, capsys):
    # A thermocue whose schedule algorithm changed cannot rebuild an older session's schedule;
    # it must not refuse to finish that participant's session, but say it did not check it.
    s = create_session(write_protocol(tmp_path), P01, tmp_path / "data", "scripted://", seed=7,
                       clock="virtual")
    path = s.directory / "session.json"
    meta = json.loads(path.read_text())
    assert meta["schedule_algorithm"] == "thermocue-schedule-v1"
    meta["schedule_algorithm"] = "thermocue-schedule-v0"
    meta["schedule"].reverse()
    path.write_text(json.dumps(meta))
    capsys.readouterr()
    again = open_session(s.directory)
    assert again.schedule == list(reversed(s.schedule))
    assert "schedule_algorithm: made by 'thermocue-schedule-v0'" in capsys.readouterr().err


def test_an_unedited_session_json_resumes(tmp_path):
    s = create_session(write_protocol(tmp_path), P01, tmp_path / "data", "scripted://", seed=7,
                       clock="virtual")
    again = open_session(s.directory)
    assert again.schedule == s.schedule and again.seed == 7 and again.group == "A"


# --------------------------------------------------------------------------- 6. clock and elapsed
def test_resume_takes_the_clock_from_the_display_it_uses(tmp_path):
    # Regression: the stored clock was kept when the new display URL names another clock.
    proto = write_protocol(tmp_path, real_samples=(1,), sim_samples=(2,))
    s = create_session(proto, P01, tmp_path / "data", "/dev/ttyUSB0", seed=7, responder_name="simulated")
    assert json.loads((s.directory / "session.json").read_text())["clock"] == "real"
    assert open_session(s.directory).clock.virtual is False
    assert open_session(s.directory, display_url=EMU).clock.virtual is True
    assert open_session(s.directory, display_url=EMU, clock="auto").clock.virtual is True
    assert open_session(s.directory, display_url=EMU, clock="real").clock.virtual is False
    assert main(["resume", str(s.directory), "--display", EMU, "--quiet"]) == 0
    start, = [e for e in read_json_lines(s.directory / "events.jsonl") if e["event"] == "session_started"]
    assert start["clock"] == "virtual" and start["display_url"] == EMU


def test_progress_counts_elapsed_time_from_the_sessions_first_start(tmp_path, caplog):
    # Regression: "elapsed" restarted at 0:00 on resume.

    from sessionfiles.logbook import EventLog, now_iso
    caplog.set_level(logging.INFO, logger="thermocue.session")   # progress is logged
    s = create_session(write_protocol(tmp_path, sim_samples=()), P01, tmp_path / "data", "scripted://",
                       seed=7, clock="virtual")
    an_hour_ago = (dt.datetime.now(dt.timezone.utc) - dt.timedelta(hours=1, seconds=5))
    with EventLog(s.directory / "events.jsonl") as log:
        log.append("session_started", time=an_hour_ago.isoformat(timespec="milliseconds"),
                   **s._context())
        log.append("session_interrupted", time=now_iso(), reason="SIGINT")

    class Watching(ScriptedResponder):
        def progress(self, text):
            self.calls.append(("progress", text))

    out = io.StringIO()
    resp = Watching()
    again = open_session(s.directory, out=out)
    assert again.run(resp, display=ScriptedDisplay()) == 0
    lines = [c[1] for c in resp.calls if c[0] == "progress"]
    assert len(lines) == 4 and all("| elapsed 1:00:0" in t for t in lines), lines
    assert "session finished: 4 trials, 1:00:0" in caplog.text


# --------------------------------------------------------------------------- 7. the console's bell
def test_console_cue_without_a_terminal_is_logged_as_not_played(tmp_path, monkeypatch, capsys):
    # Regression: cue_played was 1 with stdout and stderr redirected (no bell could sound).
    proto = write_protocol(tmp_path, real_samples=(1, 2), sim_samples=())
    monkeypatch.setattr("sys.stdin", io.StringIO("\n1\n\n2\n"))   # confirm, answer; twice
    data = tmp_path / "data"
    assert main(run_args(proto, data, EMU, "console", "--quiet")) == 0
    session = data / "P01" / "S01"
    assert [r["cue_played"] for r in rows(session / "trials.csv")] == ["0", "0"]
    events = read_json_lines(session / "events.jsonl")
    assert [e["played"] for e in events if e["event"] == "cue"] == [False, False]
    reasons = [e["reason"] for e in events if e["event"] == "cue_unavailable"]
    assert len(reasons) == 2 and "not terminals" in reasons[0]
    assert "\a" not in capsys.readouterr().out


def _nothing_logged(directory):
    """No event written: the claimed log (claimed with the folder) is empty."""
    log = directory / "events.jsonl"
    return not log.exists() or log.read_bytes() == b""


# --------------------------------------------------------------------------- claims
def test_two_runs_claiming_one_session_folder_never_mix(tmp_path):
    # Regression: two concurrent `thermocue run` of one participant: S01/session.json ended up
    # holding the losing process's seed and schedule under the winner's log.
    proto = write_protocol(tmp_path, sim_samples=())
    data = tmp_path / "data"
    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(2) as pool:
        results = pool.starmap(_claim, [(proto, data, seed) for seed in (11, 12, 13, 14)])
    dirs = [d for d, _ in results if d is not None]
    assert len(dirs) == 4 and len(set(dirs)) == 4        # four folders, S01..S04, one each
    for d, seed in results:
        assert json.loads((Path(d) / "session.json").read_text())["seed"] == seed


def _claim(proto, data, seed):
    s = create_session(proto, P01, data, "scripted://", seed=seed, clock="virtual")
    return str(s.directory), seed


def test_a_second_claim_of_a_named_folder_is_refused(tmp_path):
    from experiments.errors import SessionError
    from sessionfiles.session_files import claim_session_folder
    first = claim_session_folder(tmp_path / "P01" / "S01")
    try:
        with pytest.raises(SessionError, match="another run is creating right now"):
            claim_session_folder(tmp_path / "P01" / "S01")
    finally:
        first.close()
    # a claim killed before session.json (empty, unlocked log) is taken again
    claim_session_folder(tmp_path / "P01" / "S01").close()
    (tmp_path / "P01" / "S01" / "session.json").write_text("{}")
    with pytest.raises(SessionError, match="got an existing one"):
        claim_session_folder(tmp_path / "P01" / "S01")


@pytest.mark.parametrize("change, field", [
    (lambda m: m.update(seed=8, schedule=None), "seed"),
    (lambda m: m.update(group="B"), "group"),
    (lambda m: m.update(session="S07"), "session"),
])
def test_resume_refuses_a_session_json_that_differs_from_the_log(tmp_path, capsys, change, field):
    from experiments.schedule import build_schedule
    proto = write_protocol(tmp_path, sim_samples=())
    s = create_session(proto, P01, tmp_path / "data", "scripted://", seed=7, clock="virtual")
    assert s.run(ScriptedResponder(), display=ScriptedDisplay(script=["ok", "raise", "raise",
                                                                      "raise"])) == 1
    path = s.directory / "session.json"
    meta = json.loads(path.read_text())
    change(meta)
    if meta["schedule"] is None:          # a consistent seed + schedule pair, from another run
        meta["schedule"] = [t.to_dict() for t in build_schedule(s.protocol, "P01", 8)]
    path.write_text(json.dumps(meta))
    capsys.readouterr()
    assert main(["resume", str(s.directory), "--display", EMU, "--responder", "simulated"]) == 2
    err = capsys.readouterr().err
    assert f"{path}: {field}: expected" in err and "session_started" in err, err


def test_a_claim_killed_before_session_json_is_taken_again_by_the_next_run(tmp_path):
    # a run killed between claiming S01 and writing session.json leaves S01 with an empty,
    # unlocked log: the next run takes S01 (not S02), and resume is not needed
    (tmp_path / "data" / "P01" / "S01").mkdir(parents=True)
    (tmp_path / "data" / "P01" / "S01" / "events.jsonl").write_bytes(b"")
    s = create_session(write_protocol(tmp_path, sim_samples=()), P01, tmp_path / "data",
                       "scripted://", seed=7, clock="virtual")
    assert s.directory.name == "S01"
    (tmp_path / "data" / "P01" / "S02").mkdir()
    (tmp_path / "data" / "P01" / "S02" / "notes.txt").write_text("not ours")
    s3 = create_session(write_protocol(tmp_path, sim_samples=()), P01, tmp_path / "data",
                        "scripted://", seed=8, clock="virtual")
    assert s3.directory.name == "S03"
