"""docs/screens/make_screens.py's checks, on the records of a session (no GUI run): a
participant text with a screenshot but no measured time on screen is a problem, as is one
shorter than its minimum; the checks write nothing (the screenshots are copied only after
every check passed, so a failed run leaves the docs' page and PNGs as they were)."""
from __future__ import annotations

import importlib.util
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "docs" / "screens" / "make_screens.py"


def _script():
    spec = importlib.util.spec_from_file_location("make_screens_under_test", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


GOODBYE = "Thank you: the session is finished."


def _keyed(events):
    return {"events": events, "records": [{"kind": "draw", "window": "thermocue",
                                           "text": GOODBYE, "shot": "/nowhere/finished.png",
                                           "t": 10.0}]}


def test_a_screen_with_no_measured_time_is_a_problem_not_a_dash(tmp_path):
    ms = _script()
    spoken = {"events": [], "records": []}
    # the rewarm countdown was drawn (its screenshot is found by its text) and its text_on
    # logged, its text_off was not: before, the page got "—" for it and no problem
    rewarm = "Rewarm your finger on the hot-water bag\n3"
    keyed = {"events": [{"event": "text_on", "state": "rewarm", "text": rewarm, "flip_s": 5.0}],
             "records": [{"kind": "draw", "window": "thermocue", "text": rewarm,
                          "shot": "/nowhere/rewarm.png", "t": 5.0}]}
    rows, _, copies, problems = ms.collect(keyed, spoken)
    assert any(p.startswith("rewarm: no time on screen measured") for p in problems), problems
    assert ("/nowhere/rewarm.png", "rewarm.png") in copies          # listed, not copied


def test_a_screen_shorter_than_its_minimum_is_a_problem_and_a_long_enough_one_is_not():
    ms = _script()
    spoken = {"events": [], "records": []}
    on = {"event": "text_on", "state": "finished", "text": GOODBYE, "flip_s": 10.0}
    _, _, _, problems = ms.collect(_keyed([on, {"event": "text_off", "flip_s": 10.4}]), spoken)
    assert any(p.startswith("finished shown 0.4000 s < its minimum 1.0 s") for p in problems)
    rows, _, _, problems = ms.collect(_keyed([on, {"event": "text_off", "flip_s": 11.2}]), spoken)
    assert not [p for p in problems if p.startswith("finished")], problems
    assert [r for r in rows if r[0] == "finished"][0][4] == "1.200"
