"""BIDS export checked by the reference validator (npm ``bids-validator``, installed by
scripts/setup), not by hand-written rules."""
from __future__ import annotations

import csv
import json
import shutil
import subprocess
from pathlib import Path

import pytest

from _session_helpers import P01, ROOT
from experiments.bids import bids_label, export_dataset
from experiments.logbook import TRIAL_COLUMNS

VALIDATOR = ROOT / ".venv" / "bids-validator" / "node_modules" / ".bin" / "bids-validator"


def validate(root: Path) -> dict:
    assert VALIDATOR.exists(), f"{VALIDATOR}: missing; run ./scripts/setup"
    run = subprocess.run([str(VALIDATOR), str(root), "--json"], capture_output=True, text=True,
                         timeout=300)
    start = run.stdout.index("{")
    return json.loads(run.stdout[start:])


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """Two participants, P01 with two sessions, through `thermocue run` (simulated answers)."""
    from experiments.cli import main
    from test_two_audiences import _protocol
    tmp = tmp_path_factory.mktemp("bids")
    proto = _protocol(tmp)
    data = tmp / "data"
    for record in (P01, P01, ROOT / "participants" / "examples" / "P02.json"):
        assert main(["run", str(proto), "--participant", str(record), "--display",
                     "emulator://?clock=virtual", "--responder", "simulated", "--data", str(data),
                     "--quiet"]) == 0
    return data


@pytest.mark.slow
def test_every_finished_session_is_valid_bids(study):
    root = study / "bids"
    beh = sorted(p.relative_to(root).as_posix() for p in root.rglob("*_beh.tsv"))
    assert beh == ["sub-P01/ses-S01/beh/sub-P01_ses-S01_task-mini_beh.tsv",
                   "sub-P01/ses-S02/beh/sub-P01_ses-S02_task-mini_beh.tsv",
                   "sub-P02/ses-S01/beh/sub-P02_ses-S01_task-mini_beh.tsv"]
    report = validate(root)
    assert report["issues"]["errors"] == [], report["issues"]["errors"]
    # Warnings only: no authors in dataset_description.json (the lab adds them), and P02 lacks
    # the second session P01 has (true of this data).
    assert {w["key"] for w in report["issues"]["warnings"]} == {"NO_AUTHORS", "MISSING_SESSION"}
    assert report["summary"]["subjects"] == ["P01", "P02"] and report["summary"]["tasks"] == ["mini"]
    # The TSV is the session's trials.csv (missing values n/a); the sidecar describes each column.
    tsv = (root / beh[0]).read_text().splitlines()
    with open(study / "P01" / "S01" / "trials.csv", newline="") as fh:
        table = list(csv.reader(fh))
    assert tsv[0].split("\t") == list(TRIAL_COLUMNS) and len(tsv) == len(table)
    sidecar = json.loads((root / beh[0].replace(".tsv", ".json")).read_text())
    assert sidecar["rt_s"]["Units"] == "s" and "question" in sidecar["rt_s"]["Description"]
    assert set(TRIAL_COLUMNS) <= set(sidecar)
    with open(root / "participants.tsv", newline="") as fh:
        people = list(csv.DictReader(fh, delimiter="\t"))
    assert [(p["participant_id"], p["group"]) for p in people] == [("sub-P01", "A"), ("sub-P02", "B")]


@pytest.mark.slow
def test_the_validator_catches_a_broken_file(study, tmp_path):
    """The validator really reads the files: a row with a missing cell is an error."""
    root = tmp_path / "bids"
    shutil.copytree(study / "bids", root)
    tsv = next(root.rglob("*_beh.tsv"))
    lines = tsv.read_text().splitlines()
    lines[2] = lines[2].rsplit("\t", 1)[0]
    tsv.write_text("\n".join(lines) + "\n")
    report = validate(root)
    assert any(e["key"] == "TSV_EQUAL_ROWS" for e in report["issues"]["errors"]), report["issues"]


def test_export_dataset_rebuilds_it_and_labels_are_alphanumeric(study, tmp_path):
    written = export_dataset(study, tmp_path / "again")
    assert len(written) == 3 and all(p.exists() for p in written)
    assert bids_label("roughness_recognition") == "roughnessrecognition"
    with pytest.raises(ValueError):
        bids_label("__")


def test_export_bids_command(study, tmp_path, capsys):
    from experiments.cli import main
    assert main(["export-bids", str(study), "--out", str(tmp_path / "b")]) == 0
    assert capsys.readouterr().out == f"3 session(s) of 2 participant(s) -> {tmp_path / 'b'}\n"
    assert (tmp_path / "b" / "COMPLETE").is_file()
    assert main(["export-bids", str(tmp_path / "nothing")]) == 2


@pytest.mark.slow
def test_a_rebuilt_dataset_with_its_complete_marker_is_valid_bids(study, tmp_path):
    """`export-bids` writes COMPLETE last and lists it in .bidsignore: still valid BIDS."""
    from experiments.cli import main
    out = tmp_path / "rebuilt"
    assert main(["export-bids", str(study), "--out", str(out)]) == 0
    assert (out / "COMPLETE").is_file() and "COMPLETE" in (out / ".bidsignore").read_text().split()
    report = validate(out)
    assert report["issues"]["errors"] == [], report["issues"]["errors"]
    assert report["summary"]["subjects"] == ["P01", "P02"]
