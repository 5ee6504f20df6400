"""A trial is ``ok`` only when the display delivered it.

Regression: a burst of dropped bytes ate the host's heartbeats *and* the device's WATCHDOG
event; the host then saw the device idle (``end_reason`` fault in STATUS) and logged the trial
``ok`` with no contact at all. The device's own log (``emulator://?log=PATH``) is the referee here:
every ``ok`` row must match a contact the device saw and a trial it ended itself.
"""
from __future__ import annotations

import csv
import json

from _session_helpers import P01, write_protocol
from experiments.cli import main


def _device_trials(log_path):
    """(contact time, how the trial ended) for every contact in the device's own log."""
    recs = [json.loads(line) for line in log_path.read_text().splitlines()]
    states = [r for r in recs if r["event"] == "state"]
    out = []
    for i, r in enumerate(states):
        if r["why"] == "contact":
            end = next((s["why"] for s in states[i + 1:] if s["old"] in ("PLAYING", "RECORDING")),
                       None)
            out.append((r["t_s"], end))
    return out


def test_no_ok_trial_the_device_did_not_deliver(tmp_path):
    proto = write_protocol(tmp_path, real_samples=())
    log = tmp_path / "device.jsonl"
    url = f"emulator://?clock=virtual&seed=1&faults=drop=0.9@3+0.3&log={log}"
    status = main(["run", str(proto), "--participant", str(P01), "--display", url,
                   "--responder", "simulated", "--data", str(tmp_path / "data"), "--seed", "1",
                   "--quiet"])
    assert status == 0
    with open(tmp_path / "data" / "P01" / "S01" / "trials.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    ok = [r for r in rows if r["status"] == "ok"]
    assert sorted(int(r["trial_index"]) for r in ok) == [1, 2, 3, 4]     # each once
    # the burst at 3 s hit trial 2 while armed: that attempt is flagged and run again
    assert any(r["status"] == "fault" and r["fault_code"] == "WATCHDOG" for r in rows)
    delivered = {round(t, 2): end for t, end in _device_trials(log)}
    for r in ok:
        t = round(float(r["contact_onset_s"]), 2)
        assert delivered.get(t) == "end", (r, delivered)   # a contact the device ended itself


def test_a_display_restart_mid_session_stops_it_and_resume_finishes(tmp_path, capsys):
    # Regression: a display that restarted (USB brown-out) came back without the session's
    # limits and watchdog, and the host did not notice (its time going back was ignored).
    proto = write_protocol(tmp_path, real_samples=())
    data = tmp_path / "data"
    status = main(["run", str(proto), "--participant", str(P01), "--display",
                   "emulator://?clock=virtual&seed=2&faults=reboot@4.5", "--responder", "simulated",
                   "--data", str(data), "--seed", "1", "--quiet"])
    err = capsys.readouterr().err
    assert status == 1 and "display restarted" in err and "resume" in err
    session = data / "P01" / "S01"
    with open(session / "trials.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert rows and all(r["status"] != "ok" or r["contact_onset_s"] for r in rows)
    assert any(r["fault_code"] in ("DEVICE_RESTARTED", "DisplayRestarted") for r in rows)
    assert main(["resume", str(session), "--display", "emulator://?clock=virtual&seed=3",
                 "--responder", "simulated", "--quiet"]) == 0
    with open(session / "trials.csv", newline="") as fh:
        ok = [int(r["trial_index"]) for r in csv.DictReader(fh) if r["status"] == "ok"]
    assert sorted(ok) == [1, 2, 3, 4]


def test_a_playback_tracked_worse_than_the_tolerance_is_run_again(tmp_path, capsys):
    proto = write_protocol(tmp_path, real_samples=())
    text = proto.read_text().replace('method = "exact"',
                                     'method = "exact"\nmax_tracking_error_C = 0.001')
    proto.write_text(text)
    status = main(["run", str(proto), "--participant", str(P01), "--display",
                   "emulator://?clock=virtual&seed=2", "--responder", "simulated",
                   "--data", str(tmp_path / "data"), "--seed", "1", "--quiet"])
    assert status == 1
    with open(tmp_path / "data" / "P01" / "S01" / "trials.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["status"] for r in rows] == ["fault"] * 3
    assert {r["fault_code"] for r in rows} == {"TRACKING_ERROR"}
