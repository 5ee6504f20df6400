"""Emulated sessions log exactly the answers the code gave before the emulator speed-up.

The reference (``data/session_answers_seed0.json``) was produced by
``tests/experiments/data/make_session_answers.py`` at the commit named in its ``_comment``, before
any change to the emulator's hot paths or the simulated responder of issue 11; this test reruns
the same two sessions (P01, P16 of the seed-0 cohort, virtual clock, emulator seed 0) and
compares every logged answer, response time and percept.
"""
import json
from pathlib import Path

import pytest

DATA = Path(__file__).parent / "data"


@pytest.mark.slow
def test_emulated_sessions_log_the_reference_answers():
    import sys
    sys.path.insert(0, str(DATA))
    try:
        from make_session_answers import session_answers
    finally:
        sys.path.remove(str(DATA))
    reference = json.loads((DATA / "session_answers_seed0.json").read_text(encoding="utf-8"))["answers"]
    now = session_answers()
    assert sorted(now) == sorted(reference)
    for pid in reference:
        assert len(now[pid]) == len(reference[pid]) == 28
        for got, want in zip(now[pid], reference[pid]):
            assert got == want, (pid, got["trial_index"])
