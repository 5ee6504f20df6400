"""Personal data and results are ignored by git, the examples are not."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.skipif(shutil.which("git") is None or not (ROOT / ".git").exists(),
                    reason="not a git checkout")
def test_data_results_and_participant_records_are_ignored():
    paths = ["data/P01/S01/trials.csv", "results/report.md", "participants/P07.json",
             "participants/examples/P01.json", "experiments/session/engine.py"]
    run = subprocess.run(["git", "check-ignore", "--no-index", *paths], cwd=ROOT,
                         capture_output=True, text=True)
    assert run.stdout.split() == paths[:3]
