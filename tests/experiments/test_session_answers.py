"""A simulated study's fast path logs exactly the answers of the durable (fsync) path.

The reference (``data/session_answers_seed0.json``) is produced by
``tests/experiments/data/make_session_answers.py`` with ``durable=True``: the path every real
session takes, one fsync per event. This test reruns the same two sessions (P01, P16 of the
seed-0 cohort, virtual clock, emulator seed 0) on the fast path a simulated study uses
(``durable=False``) and compares every logged answer, response time and percept.

History: the first reference was made at a89728d, before any speed change, and the fast path
matched it. The model then changed on purpose (the simulated finger's contact resistance from
Eq. 5 at the 2.5 N it presses, not 2 N, through the scene planner) and what a trial logs changed
(delivery checks, what the participant sees), so the
reference was regenerated, on the durable path, at the commit named in its ``_comment``; and
again when the simulated participant's real-sample percept took the contact force the display
measured in each trial (``contact_force_N``) instead of the scripted 2.5 N; and again when the
simulated participant began to draw each press and skin temperature from the one lab model of
the Figure 9 Monte Carlo (2.5 ± 0.25 N, clipped to 2.05-3 N).
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
    now = session_answers(durable=False)
    assert sorted(now) == sorted(reference)
    for pid in reference:
        assert len(now[pid]) == len(reference[pid]) == 28
        for got, want in zip(now[pid], reference[pid]):
            assert got == want, (pid, got["trial_index"])
