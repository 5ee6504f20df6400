"""Every text the participant reads stays up at least the protocol's minimum, on the real clock.

A whole session in the PsychoPy window under Xvfb (``thermocue emulator`` on a real pty, real X
keys), with instructions, a real and a feedback block, rewarming between trials (the real
clock's countdown) and the final "Thank you" screen. The durations are computed from the flip
times the window logged (``text_on`` / ``text_off`` events, ``core.getTime()`` seconds): each
text from its first frame to the frame that replaced it.
"""
from __future__ import annotations

import os
import shutil
import sys

import pytest

from _session_helpers import P01, write_protocol
from test_session_gui import THERMOCUE, _events, _run_answering, emulator_pty  # noqa: F401

pytestmark = [pytest.mark.gui, pytest.mark.slow,
              pytest.mark.skipif(shutil.which("xdotool") is None, reason="xdotool is not installed")]

TEXT_MIN_S = 1.0
INSTRUCTIONS_MIN_S = 1.5


def on_screen_times(events):
    """``[(state, text, seconds)]`` for every text shown, from its ``text_on`` flip to the flip
    of the ``text_off`` that follows it (None when it never came down)."""
    out, on = [], None
    for e in events:
        if e["event"] == "text_on":
            assert on is None, f"{e['state']} went up while {on['state']} was still on screen"
            on = e
        elif e["event"] == "text_off":
            assert on is not None and on["state"] == e["state"], (on, e)
            out.append((on["state"], on["text"], e["flip_s"] - on["flip_s"]))
            on = None
    if on is not None:
        out.append((on["state"], on["text"], None))
    return out


@pytest.mark.parametrize("during_contact", [False, True], ids=["after_contact", "during_contact"])
def test_every_text_stays_up_its_minimum_on_the_real_clock(tmp_path, xvfb, emulator_pty, during_contact):
    proto = write_protocol(tmp_path, contact_s=2.0, rewarm_s=1.2, real_samples=(2,), sim_samples=(3, 1))
    text = proto.read_text()
    text = text.replace('name = "simulated"', 'name = "practice"\nfeedback = true\nscored = false\n'
                        'instructions = "Touch the pad when you hear the tone."')
    text = text.replace("[[blocks]]", f"[presentation]\ntext_min_s = {TEXT_MIN_S}\n"
                        f"instructions_min_s = {INSTRUCTIONS_MIN_S}\nfeedback_s = 0.2\n"
                        f"answer_during_contact = {str(during_contact).lower()}\n\n[[blocks]]", 1)
    proto.write_text(text)
    data = tmp_path / "data"
    events_path = data / "P01" / "S01" / "events.jsonl"
    run, sent, resent, err = _run_answering(
        THERMOCUE + ["run", str(proto), "--participant", str(P01), "--display", emulator_pty,
                     "--responder", "psychopy", "--data", str(data), "--seed", "5", "--session", "S01",
                     "--responder-option", "max_wait_s=40"], {**os.environ, **xvfb}, events_path,
        timeout_s=150)
    assert run.returncode == 0, err[-2000:]
    events = _events(events_path)
    assert any(e["event"] == "session_finished" for e in events)
    shown = on_screen_times(events)
    states = [s for s, _, _ in shown]
    # Every state of this session was on screen, and the goodbye came down (the window closed).
    assert {"welcome", "instructions", "please_wait", "cue", "question", "feedback", "rewarm",
            "finished"} <= set(states), states
    assert states[-1] == "finished"
    short = [(s, t, d) for s, t, d in shown
             if d is None or d < (INSTRUCTIONS_MIN_S if s == "instructions" else TEXT_MIN_S) - 1e-4]
    assert not short, short
    # The logged shown_s says the same as the flip times (4-decimal rounding of both).
    offs = [e for e in events if e["event"] == "text_off"]
    assert [e["shown_s"] for e in offs] == pytest.approx([d for _, _, d in shown], abs=2e-4)
    if during_contact:
        early = [e for e in events if e["event"] == "awaiting_key" and e.get("during_contact")]
        assert early, "the question never went up during the contact"
