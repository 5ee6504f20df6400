"""Tests of the session engine's logic (experiments.session) with a scripted stand-in display.

The emulator-backed end-to-end and SIGKILL tests are in test_session_kill.py; the PsychoPy
window under Xvfb in test_session_gui.py.
"""
from __future__ import annotations

import csv
import io
import json
import logging
import math
import signal

import pytest

from _session_helpers import P01, ScriptedDisplay, ScriptedResponder, read_json_lines, write_protocol
from experiments.cli import main
from experiments.session import SessionInterrupted, create_session, open_session


def rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def new_session(tmp_path, **protocol):
    protocol.setdefault("sim_samples", ())
    proto = write_protocol(tmp_path, **protocol)
    return create_session(proto, P01, tmp_path / "data", "scripted://", seed=7,
                          responder_name="scripted-test", clock="virtual")


# --------------------------------------------------------------------------- whole sessions
def test_real_session_writes_every_file(tmp_path):
    s = new_session(tmp_path)
    disp, resp = ScriptedDisplay(), ScriptedResponder(answers=[1, 1, 1, 1])
    assert s.run(resp, display=disp) == 0
    meta = json.loads((s.directory / "session.json").read_text())
    assert meta["protocol_hash"] == s.protocol.hash and meta["seed"] == 7
    assert meta["participant"]["id"] == "P01" and meta["group"] == "A"
    assert len(meta["schedule"]) == 4 and meta["versions"]["numpy"]
    table = rows(s.directory / "trials.csv")
    assert [int(r["trial_index"]) for r in table] == [1, 2, 3, 4]
    assert {r["status"] for r in table} == {"ok"} and {r["participant"] for r in table} == {"P01"}
    assert {r["session"] for r in table} == {s.name} and {r["group"] for r in table} == {"A"}
    for r in table:   # correct is response_id == roughness_id, all answers were 1
        assert r["correct"] == ("1" if r["roughness_id"] == "1" else "0")
        assert r["mode"] == "real" and float(r["rt_s"]) == 0.5
        trace = (s.directory / r["trace_file"]).read_text().splitlines()
        assert trace[0].startswith("time_s,target_C,contact_C,ambient_C,finger_C,force1_N")
        assert len(trace) == 11
    ev = read_json_lines(s.directory / "events.jsonl")
    kinds = [e["event"] for e in ev]
    assert kinds[0] == "session_started" and kinds[-1] == "session_finished"
    states = [(e["from"], e["to"]) for e in ev if e["event"] == "state"]
    assert ("wait_contact", "record") in states and ("respond", "write") in states
    # Experimenter prompted to place each sample, and the emulated hand placed it.
    prompts = [c[1] for c in resp.calls if c[0] == "prompt"]
    assert len(prompts) == 4 and all("place sample" in p for p in prompts)
    assert [c[0] for c in disp.calls].count("sim_sample") == 4
    assert disp.calls[-1] == ("set_neutral", 32.0)


def test_a_display_fault_is_written_and_the_trial_run_again(tmp_path):
    s = new_session(tmp_path)
    disp = ScriptedDisplay(script=["ok", "raise", "fault", "ok"])
    assert s.run(ScriptedResponder(), display=disp) == 0
    table = rows(s.directory / "trials.csv")
    assert [(r["trial_index"], r["attempt"], r["status"]) for r in table] == [
        ("1", "1", "ok"), ("2", "1", "fault"), ("2", "2", "fault"), ("2", "3", "ok"),
        ("3", "1", "ok"), ("4", "1", "ok")]
    assert table[1]["fault_code"] == "DisplayError" and table[2]["fault_code"] == "OVER_TEMPERATURE"
    assert table[1]["response_id"] == "" and table[3]["response_id"] != ""
    # Each attempt keeps its own trace; the completed one has the plain name.
    assert [r["trace_file"] for r in table[1:4]] == [
        "traces/trial-002.attempt-1.fault.csv", "traces/trial-002.attempt-2.fault.csv",
        "traces/trial-002.csv"]
    traces = s.directory / "traces"
    assert len((traces / "trial-002.attempt-1.fault.csv").read_text().splitlines()) == 1  # no frame
    assert len((traces / "trial-002.attempt-2.fault.csv").read_text().splitlines()) == 11
    # neutral after each fault: abort then set_neutral right after the failing run_trial
    i = disp.calls.index(("run_trial", "raise"))
    assert disp.calls[i + 1:i + 3] == [("abort",), ("set_neutral", 32.0)]


def test_a_refused_command_is_written_with_the_devices_code_name(tmp_path):
    # Regression: DisplayRefused carries the device's numeric code; trials.csv showed "10"
    # where recorded faults show names (docs/display-protocol.md: 10 is FAULT_LATCHED).
    from experiments.errors import DisplayRefused

    class Refusing(ScriptedDisplay):
        def arm(self, **kw):
            super().arm(**kw)
            if len([c for c in self.calls if c[0] == "arm"]) == 2:
                raise DisplayRefused("display: ARM refused: FAULT_LATCHED (clear it)", code=10,
                                     code_name="FAULT_LATCHED")

    s = new_session(tmp_path)
    disp = Refusing()
    assert s.run(ScriptedResponder(), display=disp) == 0
    table = rows(s.directory / "trials.csv")
    assert [(r["trial_index"], r["status"], r["fault_code"]) for r in table[:3]] == [
        ("1", "ok", ""), ("2", "fault", "FAULT_LATCHED"), ("2", "ok", "")]
    ev = [e for e in read_json_lines(s.directory / "events.jsonl") if e["event"] == "display_fault"]
    assert ev[0]["fault_code"] == "FAULT_LATCHED" and "ARM refused" in ev[0]["message"]
    i = [k for k, c in enumerate(disp.calls) if c[0] == "arm"][1]   # the refused arm: neutral next
    assert disp.calls[i + 1:i + 3] == [("abort",), ("set_neutral", 32.0)]


def test_consecutive_faults_stop_cleanly_and_resume_finishes(tmp_path):
    s = new_session(tmp_path)
    disp = ScriptedDisplay(script=["ok", "raise", "timeout", "fault"])
    assert s.run(ScriptedResponder(), display=disp) == 1
    ev = read_json_lines(s.directory / "events.jsonl")
    assert ev[-1]["event"] == "session_stopped"
    assert [(r["trial_index"], r["attempt"], r["status"]) for r in rows(s.directory / "trials.csv")] \
        == [("1", "1", "ok"), ("2", "1", "fault"), ("2", "2", "fault"), ("2", "3", "fault")]
    # Resume starts at the stopped trial, as its 4th attempt; trial 1 is not repeated.
    resp = ScriptedResponder()
    assert open_session(s.directory).run(resp, display=ScriptedDisplay()) == 0
    assert [c[1] for c in resp.calls if c[0] == "respond"] == [2, 3, 4]
    table = rows(s.directory / "trials.csv")
    assert [(r["trial_index"], r["attempt"], r["status"]) for r in table][3:] == [
        ("2", "3", "fault"), ("2", "4", "ok"), ("3", "1", "ok"), ("4", "1", "ok")]


def test_a_trial_is_given_up_after_the_protocols_max_attempts_and_the_session_goes_on(tmp_path):
    proto = write_protocol(tmp_path, sim_samples=())
    proto.write_text(proto.read_text().replace("rewarm_s = 0.0", "rewarm_s = 0.0\nmax_attempts = 2"))
    s = create_session(proto, P01, tmp_path / "data", "scripted://", seed=7,
                       responder_name="scripted-test", clock="virtual", max_consecutive_faults=5)
    assert s.protocol.contact.max_attempts == 2
    out = io.StringIO()
    s.out = out
    disp = ScriptedDisplay(script=["ok", "fault", "raise", "ok", "ok"])
    assert s.run(ScriptedResponder(), display=disp) == 0
    assert [(r["trial_index"], r["attempt"], r["status"]) for r in rows(s.directory / "trials.csv")] \
        == [("1", "1", "ok"), ("2", "1", "fault"), ("2", "2", "fault"), ("3", "1", "ok"),
            ("4", "1", "ok")]
    ev = read_json_lines(s.directory / "events.jsonl")
    given = [e for e in ev if e["event"] == "trial_given_up"]
    assert [(e["trial_index"], e["attempts"], e["max_attempts"]) for e in given] == [(2, 2, 2)]
    assert ev[-1]["event"] == "session_finished" and ev[-1]["n_completed"] == 3 \
        and ev[-1]["n_given_up"] == 1


def test_a_link_that_drops_on_every_attempt_stops_the_session_instead_of_retrying_for_ever(tmp_path):
    # the in-process emulator's injected disconnect comes back with every reconnect (its device
    # time starts again at 0): before, the lost-link path skipped the fault count and one session
    # logged thousands of attempts of trial 1
    proto = write_protocol(tmp_path, contact_s=0.5, real_samples=(1,), sim_samples=(3,))
    out = io.StringIO()
    s = create_session(proto, P01, tmp_path / "data", "emulator://?clock=virtual&faults=disconnect@1*",
                       seed=4, clock="virtual", out=out)
    assert s.run(ScriptedResponder()) == 1
    ev = read_json_lines(s.directory / "events.jsonl")
    assert sum(e["event"] == "trial_started" for e in ev) == 3
    assert sum(e["event"] == "display_reconnected" for e in ev) == 3
    assert [e["trial_index"] for e in ev if e["event"] == "trial_given_up"] == [1]
    assert ev[-1]["event"] == "session_stopped" and ev[-1]["reason"] == "3 consecutive faults"
    assert "stopped after 3 consecutive faults" in out.getvalue()


def test_an_injected_once_fault_faults_one_attempt_and_the_retry_is_ok_as_attempt_2(tmp_path):
    # disconnect@1 (no "*"): an event that fires once per URL in this process; the device the
    # session opens again after the lost link does not have it, so trial 1's retry succeeds
    proto = write_protocol(tmp_path, contact_s=0.5, real_samples=(1,), sim_samples=(3,))
    out = io.StringIO()
    s = create_session(proto, P01, tmp_path / "data", "emulator://?clock=virtual&faults=disconnect@1",
                       seed=4, clock="virtual", out=out)
    assert s.run(ScriptedResponder()) == 0, out.getvalue()
    ev = read_json_lines(s.directory / "events.jsonl")
    assert [(e["trial_index"], e["attempt"], e["fault_code"]) for e in ev
            if e["event"] == "display_fault"] == [(1, 1, "LINK_LOST")]
    assert sum(e["event"] == "display_reconnected" for e in ev) == 1
    table = rows(s.directory / "trials.csv")
    assert [(r["attempt"], r["status"]) for r in table if r["trial_index"] == "1"] == \
        [("1", "fault"), ("2", "ok")]
    assert all(r["status"] == "ok" for r in table if r["trial_index"] != "1")
    assert ev[-1]["event"] == "session_finished" and ev[-1]["n_given_up"] == 0


def test_no_contact_aborts_the_attempt_and_runs_the_trial_again(tmp_path):
    s = new_session(tmp_path)
    disp = ScriptedDisplay(script=["no_contact", "ok", "ok", "ok", "ok"])
    assert s.run(ScriptedResponder(), display=disp) == 0
    table = rows(s.directory / "trials.csv")
    first = [r for r in table if r["trial_index"] == "1"]
    assert [(r["attempt"], r["status"]) for r in first] == [("1", "aborted"), ("2", "ok")]
    assert first[0]["abort_reason"] == "no_contact" and first[0]["fault_code"] == "TRIAL_TIMEOUT"
    assert (s.directory / first[0]["trace_file"]).exists()     # the aborted attempt's trace is kept
    assert first[1]["trace_file"] == "traces/trial-001.csv"


def test_interruption_puts_the_display_neutral_and_logs_it(tmp_path):
    s = new_session(tmp_path)

    class Interrupting(ScriptedResponder):
        def respond(self, trial, stimulus):
            if trial.trial_index == 2:
                raise SessionInterrupted("SIGTERM")
            return super().respond(trial, stimulus)

    disp = ScriptedDisplay()
    assert s.run(Interrupting(), display=disp) == 1
    ev = read_json_lines(s.directory / "events.jsonl")
    assert ev[-1] == {**ev[-1], "event": "session_interrupted", "reason": "SIGTERM"}
    aborted = [e for e in ev if e["event"] == "trial_aborted"]
    assert [(e["trial_index"], e["attempt"], e["reason"]) for e in aborted] == [(2, 1, "interrupted")]
    assert ("abort",) in disp.calls[-3:] and disp.calls[-1] == ("set_neutral", 32.0)
    # Resume: trial 2 again as attempt 2, trial 1 not repeated.
    resp = ScriptedResponder()
    assert open_session(s.directory).run(resp, display=ScriptedDisplay()) == 0
    assert [c[1] for c in resp.calls if c[0] == "respond"] == [2, 3, 4]
    table = rows(s.directory / "trials.csv")
    assert [(r["trial_index"], r["attempt"], r["status"]) for r in table] == [
        ("1", "1", "ok"), ("2", "1", "aborted"), ("2", "2", "ok"), ("3", "1", "ok"), ("4", "1", "ok")]


def test_sigint_handler_raises_into_the_run(tmp_path):
    s = new_session(tmp_path)

    class Signalling(ScriptedResponder):
        def cue(self):
            if self.n == 1:
                signal.raise_signal(signal.SIGINT)
            return super().cue()

    # the handler found before the run is put back: Python's default_int_handler, or SIG_IGN
    # when this process started with SIGINT ignored (a background job of a non-interactive shell)
    before = signal.getsignal(signal.SIGINT)
    assert s.run(Signalling(), display=ScriptedDisplay()) == 1
    ev = read_json_lines(s.directory / "events.jsonl")
    assert ev[-1]["event"] == "session_interrupted" and ev[-1]["reason"] == "SIGINT"
    assert signal.getsignal(signal.SIGINT) is before                        # handler restored


# --------------------------------------------------------------------------- command line
def test_bad_participant_file_is_one_line_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"id": "P09", "age": "old"}))
    status = main(["run", "roughness_recognition", "--participant", str(bad), "--display",
                   "emulator://?clock=virtual", "--responder", "console", "--data", str(tmp_path)])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and "bad.json" in err and "Traceback" not in err


def test_bad_protocol_file_is_one_line_exit_2(tmp_path, capsys):
    proto = write_protocol(tmp_path)
    proto.write_text(proto.read_text().replace("repetitions = 1", "repetitions = 'three'", 1))
    status = main(["run", str(proto), "--participant", str(P01), "--display", "emulator://",
                   "--responder", "console", "--data", str(tmp_path)])
    err = capsys.readouterr().err
    assert status == 2 and "mini.toml: blocks[0].repetitions" in err and err.count("\n") == 1


def test_resume_of_a_missing_or_broken_session_is_exit_2(tmp_path, capsys):
    assert main(["resume", str(tmp_path / "nope")]) == 2
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "session.json").write_text("{not json")
    assert main(["resume", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert "nope: expected a session folder" in err[0] and "session.json: expected valid JSON" in err[1]


def test_resume_checks_max_faults_and_needs_a_responder(tmp_path, capsys):
    s = create_session(write_protocol(tmp_path, sim_samples=()), P01, tmp_path / "data",
                       "scripted://", seed=7, clock="virtual")      # no responder recorded
    capsys.readouterr()
    assert main(["resume", str(s.directory), "--max-faults", "0"]) == 2
    assert main(["resume", str(s.directory)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[0].endswith("--max-faults: expected an integer ≥ 1, got 0")
    assert "session.json: responder: expected a name, got ''" in err[1] and len(err) == 2
    assert _nothing_logged(s.directory)    # refused before anything ran


def test_existing_session_folder_is_refused(tmp_path):
    s = new_session(tmp_path)
    s.run(ScriptedResponder(), display=ScriptedDisplay())
    from experiments.errors import SessionError
    with pytest.raises(SessionError, match="existing one"):
        create_session(s.protocol, P01, tmp_path / "data", "x", seed=1, session_name=s.name)
    second = create_session(s.protocol, P01, tmp_path / "data", "x", seed=1)
    assert second.name == "S02"


@pytest.mark.parametrize("calibrated, expected_um, source", [(None, 650.0, "protocol"),
                                                            (900.0, 900.0, "calibration")])
def test_simulated_profiles_use_the_group_mean_or_the_calibrated_thickness(
        tmp_path, calibrated, expected_um, source):
    record = json.loads(P01.read_text())          # group A (680 µm): the group mean is 650 µm
    if calibrated is not None:
        record["calibration"] = {"method": "test", "skin_thickness_um": calibrated}
    path = tmp_path / "P01.json"
    path.write_text(json.dumps(record))
    proto = write_protocol(tmp_path, real_samples=(1,), sim_samples=(2,))
    s = create_session(proto, path, tmp_path / "data", "scripted://", seed=1, clock="virtual")
    disp = ScriptedDisplay()
    assert s.run(ScriptedResponder(), display=disp) == 0
    table = rows(s.directory / "trials.csv")
    sim = [r for r in table if r["mode"] == "simulated"]
    assert len(sim) == 1 and float(sim[0]["profile_skin_thickness_um"]) == expected_um
    up = [e for e in read_json_lines(s.directory / "events.jsonl") if e["event"] == "profile_uploaded"]
    assert up[0]["skin_thickness_source"] == source and up[0]["n_points"] == 51   # 1 s at 50 Hz
    # The profile is the one the protocol describes: sample 2# (12.5 µm) on 3 mm steel at 20 °C,
    # skin at 35.5 °C, receptors at 0.6 L (mini protocol's [simulation] and [material]).
    p = up[0]["parameters"]
    assert p["roughness_m"] == pytest.approx(12.5e-6, rel=1e-12)
    assert p["skin"]["thickness_m"] == pytest.approx(expected_um * 1e-6, rel=1e-12)
    assert p["skin"]["dermis_m"] == pytest.approx(0.6 * expected_um * 1e-6, rel=1e-12)
    assert p["material"]["name"] == "stainless_steel" and p["material"]["thickness_m"] == pytest.approx(3e-3)
    assert (p["skin_temperature_C"], p["material_temperature_C"], p["duration_s"], p["rate_Hz"]) == \
        (35.5, 20.0, 1.0, 50.0)
    # playback for the simulated trial (after its upload), record for the real one
    assert [c for c in disp.calls if c[0] in ("upload", "arm")] == [("arm", "record"), ("upload", 51),
                                                                     ("arm", "playback")]


def test_psychopy_without_a_display_is_refused_before_anything_is_written(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    status = main(["run", "roughness_recognition", "--participant", str(P01), "--display",
                   "emulator://?clock=virtual", "--responder", "psychopy", "--data", str(tmp_path / "d")])
    err = capsys.readouterr().err
    assert status == 2 and "--responder psychopy: expected a display" in err and err.count("\n") == 1
    assert not (tmp_path / "d").exists()


# --------------------------------------------------------------------------- target side, pad, calibration

class _RecordingDisplay(ScriptedDisplay):
    """The scripted display, keeping every uploaded profile."""

    def upload_profile(self, t, y):
        super().upload_profile(t, y)
        self.uploads = getattr(self, "uploads", []) + [(list(t), list(y))]


def _eq5_copper_pad():
    # Eq. 5 by hand for the pad's 0.4 µm copper face (401 W/mK) against skin (0.34 W/mK),
    # 2 N on 135 mm², H = 12.5 gf/mm², Delta_a = 0.3, R_S = 21.69 µm.
    lam = 2 * 0.34 * 401.0 / (0.34 + 401.0)
    return 0.8 * math.hypot(21.69e-6, 0.4e-6) / (lam * 0.3) * (12.5 * 9.80665e-3 / 1e-6 / (2.0 / 135e-6)) ** 0.95


def _side_protocol(tmp_path, side, rate_limit="refuse", sim_samples=(2,)):
    proto = write_protocol(tmp_path, real_samples=(1,), sim_samples=sim_samples)
    text = proto.read_text().replace('method = "exact"\n', f'method = "exact"\ntarget_side = "{side}"\n'
                                     f'rate_limit = "{rate_limit}"\n')
    proto.write_text(text)
    return proto


def _calibrated_record(tmp_path, resistance=1.2e-3):
    record = json.loads(P01.read_text())
    record["calibration"] = {"method": "test", "date": "2026-11-22", "skin_thickness_um": 900.0,
                             "contact_resistance_m2K_W": {"12.5": resistance},
                             "samples": [{"key": "12.5", "roughness_id": 2, "roughness_um": 12.5}]}
    path = tmp_path / "P01.json"
    path.write_text(json.dumps(record))
    return path


def test_simulated_profile_uses_the_calibrated_resistance_and_the_protocols_side(tmp_path):
    from stimuli import Skin, target_profile
    proto = _side_protocol(tmp_path, "compensated")
    # This compensated profile starts at 12.3 °C/s over 0.1 s: above the mini protocol's 10 °C/s,
    # which the display would refuse (and create_session now does, before anything is written).
    proto.write_text(proto.read_text().replace("max_rate_C_per_s = 10.0", "max_rate_C_per_s = 15.0"))
    s = create_session(proto, _calibrated_record(tmp_path), tmp_path / "data", "scripted://", seed=1,
                       clock="virtual")
    disp = _RecordingDisplay(limits=s.protocol.display.safety_limits())   # as a real one is opened
    assert s.run(ScriptedResponder(), display=disp) == 0
    up = [e for e in read_json_lines(s.directory / "events.jsonl") if e["event"] == "profile_uploaded"]
    assert len(up) == 1
    ev = up[0]
    r_pad = _eq5_copper_pad()
    assert ev["target_side"] == "compensated"
    assert ev["pad_resistance_m2K_W"] == pytest.approx(r_pad, rel=1e-12)
    assert (ev["resistance_m2K_W"], ev["resistance_source"]) == (1.2e-3, "calibration")
    assert ev["skin_thickness_source"] == "calibration"
    # what target_profile was asked for (it records its inputs)
    p = ev["parameters"]
    assert p["side"] == "compensated" and p["resistance_m2K_per_W"] == 1.2e-3
    assert p["pad_resistance_m2K_per_W"] == pytest.approx(r_pad, rel=1e-12)
    assert p["skin"]["thickness_m"] == pytest.approx(900e-6, rel=1e-12)
    # the upload is that profile, and not the paper's material-side one
    kw = dict(roughness=12.5e-6, skin=Skin(900e-6, dermis=540e-6), skin_temperature=35.5,
              material_temperature=20.0, duration=1.0, rate=50.0, sample_thickness=3e-3,
              resistance=1.2e-3, pad_resistance=r_pad, cache=False)
    comp = target_profile(side="compensated", **kw)
    mat = target_profile(side="material", **kw)
    (t, y), = disp.uploads
    assert y == pytest.approx(list(comp.temperature), abs=1e-12)
    assert abs(y[0] - mat.temperature[0]) > 1.0     # 12.5 µm: the pad starts > 1 K warmer
    sim = [r for r in rows(s.directory / "trials.csv") if r["mode"] == "simulated"]
    assert sim[0]["target_side"] == "compensated"
    # trials.csv gives modelled resistances to 4 significant digits (the event log in full)
    assert sim[0]["pad_resistance_m2K_W"] == f"{r_pad:.4g}"
    assert float(sim[0]["profile_resistance_m2K_W"]) == 1.2e-3
    assert sim[0]["profile_resistance_source"] == "calibration"


def test_uncalibrated_sample_uses_eq5_and_the_material_side_by_default(tmp_path):
    # the calibration covers 12.5 µm only: sample 3# (50 µm) gets Eq. 5 but the calibrated thickness
    proto = write_protocol(tmp_path, real_samples=(1,), sim_samples=(3,))
    s = create_session(proto, _calibrated_record(tmp_path), tmp_path / "data", "scripted://", seed=1,
                       clock="virtual")
    assert s.run(ScriptedResponder(), display=ScriptedDisplay()) == 0
    ev, = [e for e in read_json_lines(s.directory / "events.jsonl") if e["event"] == "profile_uploaded"]
    assert ev["target_side"] == "material" and ev["resistance_source"] == "eq5"
    assert ev["skin_thickness_source"] == "calibration"
    assert ev["parameters"]["skin"]["thickness_m"] == pytest.approx(900e-6, rel=1e-12)
    # Eq. 5 for 50 µm steel (14.9 W/mK) against skin, by hand
    lam = 2 * 0.34 * 14.9 / (0.34 + 14.9)
    eq5 = 0.8 * math.hypot(21.69e-6, 50e-6) / (lam * 0.3) * (12.5 * 9.80665e-3 / 1e-6 / (2.0 / 135e-6)) ** 0.95
    assert ev["resistance_m2K_W"] == pytest.approx(eq5, rel=1e-9)


def test_slew_rate_limit_slows_a_fast_compensated_profile_and_logs_the_change(tmp_path):
    from experiments.profile_rate import window_rate
    proto = _side_protocol(tmp_path, "compensated", rate_limit="slew", sim_samples=(3,))
    s = create_session(proto, P01, tmp_path / "data", "scripted://", seed=1, clock="virtual")
    disp = _RecordingDisplay()
    assert s.run(ScriptedResponder(), display=disp) == 0
    (t, y), = disp.uploads
    assert window_rate(y, 0.02, 0.1) <= 10.0          # the display's limit (13.5 °C/s unslowed)
    ev, = [e for e in read_json_lines(s.directory / "events.jsonl") if e["event"] == "profile_uploaded"]
    assert 0.05 < ev["rate_limited_max_change_C"] < 0.5
    row, = [r for r in rows(s.directory / "trials.csv") if r["mode"] == "simulated"]
    # trials.csv: to the display's resolution (3 decimals); the event log in full
    assert float(row["rate_limited_max_change_C"]) == round(ev["rate_limited_max_change_C"], 3)


def test_a_compensated_profile_the_pad_cannot_give_names_protocol_and_field(tmp_path):
    from experiments.errors import SessionError
    from experiments.protocol import load_protocol
    from experiments.session import simulated_target_profile
    from participants_schema import Participant
    proto = load_protocol(_side_protocol(tmp_path, "compensated"))
    # a calibrated sample resistance below the pad's: no pad temperature can compensate
    record = json.loads(_calibrated_record(tmp_path, resistance=1e-4).read_text())
    with pytest.raises(SessionError, match=r"mini\.toml: simulation\.target_side: 'compensated' "
                                           r"for sample 12\.5 µm \(calibration resistance\)"):
        simulated_target_profile(proto, Participant.from_record(record), "A", 680.0, 2, 12.5)


def _nothing_logged(directory):
    """No event written: the claimed log (claimed with the folder) is empty."""
    log = directory / "events.jsonl"
    return not log.exists() or log.read_bytes() == b""


# --------------------------------------------------------------------------- the package's shape
def test_progress_is_logged_on_thermocue_session_and_not_told(tmp_path, caplog):

    proto = write_protocol(tmp_path, sim_samples=())
    told = io.StringIO()
    s = create_session(proto, P01, tmp_path / "data", "scripted://", seed=7,
                       responder_name="scripted-test", clock="virtual", out=told)
    caplog.set_level(logging.INFO, logger="thermocue.session")
    assert s.run(ScriptedResponder(), display=ScriptedDisplay(script=["fault"])) == 0
    progress = [r.getMessage() for r in caplog.records if r.name == "thermocue.session"]
    assert any(m.startswith("trial 1 of 4 | block real") for m in progress)
    assert any(m.startswith("trial 1 of 4 | block real") and m.endswith("| attempt 2")
               for m in progress)
    assert any(m.startswith("session finished: 4 trials") for m in progress)
    # the experimenter's channel keeps what is theirs (the fault), and no progress line
    assert "trial 1: display fault OVER_TEMPERATURE" in told.getvalue()
    assert "of 4 | block" not in told.getvalue()


def test_quiet_logger_gives_no_progress_lines(tmp_path, caplog):

    caplog.set_level(logging.WARNING, logger="thermocue.session")
    s = new_session(tmp_path)
    assert s.run(ScriptedResponder(), display=ScriptedDisplay()) == 0
    assert not [r for r in caplog.records if r.name == "thermocue.session"]


def test_pause_points_are_a_hooks_object_reached_in_order(tmp_path):
    from experiments.session import PAUSE_ENV, PAUSE_POINTS, PauseAt, SessionHooks
    from experiments.session.hooks import hooks_from_env

    class Seen(SessionHooks):
        def __init__(self):
            self.points = []

        def at(self, point, spec, attempt):
            self.points.append((point, spec.trial_index, attempt))

    proto = write_protocol(tmp_path, real_samples=(1,), sim_samples=(2,))
    s = create_session(proto, P01, tmp_path / "data", "scripted://", seed=7,
                       responder_name="scripted-test", clock="virtual")
    s.hooks = seen = Seen()
    assert s.run(ScriptedResponder(), display=ScriptedDisplay()) == 0
    real = [p for p, t, a in seen.points if s.schedule[t - 1].mode == "real" and t == 1]
    assert real == ["trial_started", "armed", "playback", "after_response", "after_write"]
    sim = next(x.trial_index for x in s.schedule if x.mode == "simulated")
    assert [p for p, t, a in seen.points if t == sim] == list(PAUSE_POINTS)
    # the environment variable of the kill tests: no points, the do-nothing base class
    assert type(hooks_from_env({})) is SessionHooks
    assert hooks_from_env({PAUSE_ENV: "upload:9, playback:2"}).points == {("upload", 9), ("playback", 2)}
    assert isinstance(hooks_from_env({PAUSE_ENV: "upload:9"}), PauseAt)
    with pytest.raises(ValueError, match=f"{PAUSE_ENV}: expected point:trial_index"):
        hooks_from_env({PAUSE_ENV: "nowhere:1"})
