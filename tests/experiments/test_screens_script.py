"""docs/screens/make_screens.py regenerates the screenshots and their on-screen times.

The script runs two sessions (keyed and spoken answers) on the real clock against
``thermocue emulator`` under Xvfb with real keys; here it writes into a temporary folder, and
the page it writes must have a screenshot for every state and, for every participant state with
a minimum, a measured time no shorter than that minimum (the script refuses to write the page
otherwise: this checks it did not write one that says less).
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.gui, pytest.mark.slow,
              pytest.mark.skipif(shutil.which("xdotool") is None, reason="xdotool is not installed")]

SCRIPT = Path(__file__).resolve().parents[2] / "docs" / "screens" / "make_screens.py"


@pytest.mark.timeout(900)      # two sessions on the real clock: ~90 s on 2 cores at load 5
def test_make_screens_writes_every_state_with_times_at_least_their_minimum(tmp_path, xvfb):
    out = tmp_path / "screens"
    run = subprocess.run([sys.executable, str(SCRIPT), str(out)], env={**os.environ, **xvfb},
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    page = (out / "README.md").read_text(encoding="utf-8")
    rows = [line.split(" | ") for line in page.splitlines() if line.startswith("| `")]
    states = {r[0].strip("| `") for r in rows}
    assert {"welcome", "instructions", "instructions_key", "please_wait", "label", "cue_label",
            "cue", "question", "feedback", "rewarm", "finished", "spoken_blank",
            "place_sample", "question_asked", "confirm_answer", "undone", "say_goodbye"} <= states
    for r in rows:
        png = re.search(r"\(([\w.]+\.png)\)", r[1]).group(1)
        assert (out / png).stat().st_size > 1000, png
        minimum = re.search(r"= ([\d.]+) s$", r[3]) if len(r) == 5 else None
        if minimum:      # "1.007" or "1.007–1.107 (n = 4)": the shortest first
            shortest = float(re.match(r"[\d.]+", r[4]).group(0))
            assert shortest >= float(minimum.group(1)), r
