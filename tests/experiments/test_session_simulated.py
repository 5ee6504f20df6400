"""The paper's Exp. 2 end to end: the simulated participant on the emulator's virtual clock."""
from __future__ import annotations

import csv
import json

import pytest

from _session_helpers import ROOT
from experiments.cli import main
from sessionfiles.logbook import read_events
from experiments.protocol import load_protocol
from experiments.schedule import build_schedule

pytestmark = pytest.mark.slow

P02 = ROOT / "participants" / "examples" / "P02.json"


def test_full_roughness_recognition_session_with_the_simulated_participant(tmp_path, capsys):
    status = main(["run", "roughness_recognition", "--participant", str(P02), "--display",
                   "emulator://?clock=virtual&seed=4", "--responder", "simulated",
                   "--data", str(tmp_path), "--seed", "1"])
    assert status == 0
    session = tmp_path / "P02" / "S01"
    meta = json.loads((session / "session.json").read_text())
    expected = build_schedule(load_protocol("roughness_recognition"), "P02", 1)
    assert meta["schedule"] == [s.to_dict() for s in expected] and meta["group"] == "B"
    with open(session / "trials.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    ok = [r for r in rows if r["status"] == "ok"]
    assert [int(r["trial_index"]) for r in ok] == list(range(1, 29))
    assert [r["block"] for r in ok] == ["familiarise"] * 4 + ["real"] * 12 + ["simulated"] * 12
    # Familiarisation asks for no answer (protocol: response = false); the other trials do.
    assert all(r["response_id"] == "" for r in ok[:4])
    assert all(r["response_id"] in "1234" and r["response_source"] == "simulated" for r in ok[4:])
    for r in ok[4:]:
        assert r["correct"] == str(int(r["response_id"] == r["roughness_id"]))
    # Simulated trials replayed the profile of group B's mean thickness (1000 µm), tracked closely.
    for r in ok[16:]:
        assert float(r["profile_skin_thickness_um"]) == 1000.0
        assert float(r["tracking_rms_C"]) < 0.5
    # The skin temperature measured just before each touch (the display's radiation thermometer)
    # is the simulated finger's, drawn in the paper's 35.5-36 °C; it cools a little on approach.
    skin = [float(r["skin_temperature_C"]) for r in ok]
    assert all(35.0 < v < 36.1 for v in skin), skin
    events, _ = read_events(session / "events.jsonl", warn=False)
    uploads = [e for e in events if e["event"] == "profile_uploaded"]
    assert len(uploads) >= 12 and len({e["content_hash"] for e in uploads}) == 4   # 4 samples
    # each profile carries the scene planner's decisions: the 3 mm slab is kept
    for e in uploads:
        decisions = {d["effect"]: d for d in e["parameters"]["plan"]["decisions"]}
        assert decisions["slab"]["included"]
    err = capsys.readouterr().err
    assert "trial 28 of 28 | block simulated" in err and "session finished" in err
    # ... and the experimenter reads them, one line per profile
    lines = [x for x in err.splitlines() if x.startswith("profile ") and " um): model " in x]
    assert len(lines) == 4 and all("kept: " in x and "slab" in x for x in lines), lines
