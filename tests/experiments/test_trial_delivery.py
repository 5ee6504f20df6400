"""A trial is ``ok`` only when the display delivered it (issue 16, item 1).

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
        t = round(float(r["contact_time_s"]), 2)
        assert delivered.get(t) == "end", (r, delivered)   # a contact the device ended itself
