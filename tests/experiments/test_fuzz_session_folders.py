"""The short form of benchmarks/fuzz_session_folders.py: 20 damaged copies of real emulated
sessions through ``analyze`` and ``export-bids``, each run in its own process under a time-out.
No traceback, no hang, no refusal without a file named, no session folder dropped unsaid, no row
filed under another id."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
from fuzz_session_folders import BAD, run_fuzz  # noqa: E402


@pytest.mark.slow
def test_twenty_damaged_session_folders(tmp_path):
    lines = []
    result = run_fuzz(20, seed=20261126, work=tmp_path, timeout_s=240, report=lines.append)
    counts = result["counts"]
    for cmd in ("analyze", "export-bids"):
        assert sum(n for (c, _), n in counts.items() if c == cmd) == 20
    assert {o: n for (c, o), n in counts.items() if o in BAD} == {}, "\n".join(lines)
    # the damage is real: some runs are refused, some read around it
    assert counts[("export-bids", "refused")] > 0 and counts[("export-bids", "ok")] > 0
    assert sum(result["kinds"].values()) >= 20
