"""Tests of the console responder."""
from __future__ import annotations

import io

import pytest

from experiments.responders import ConsoleResponder, ResponderClosed, TrialStimulus
from experiments.schedule import TrialSpec

TRIAL = TrialSpec(trial_index=3, block="real", mode="real", roughness_id=2, roughness_um=12.5, repetition=1)
STIM = TrialStimulus("real", 2, 12.5)


def test_reads_a_valid_answer_after_rejecting_bad_ones():
    out = io.StringIO()
    r = ConsoleResponder(stdin=io.StringIO("5\nx\n\n 3 \n"), stdout=out)
    resp = r.respond(TRIAL, STIM)
    assert resp.response_id == 3 and resp.source == "console" and resp.rt_s >= 0
    text = out.getvalue()
    assert text.count("Which roughness (1, 2, 3, 4)?") == 4
    assert "got '5'" in text and "got 'x'" in text and "got ''" in text


def test_end_of_input_closes_the_responder():
    r = ConsoleResponder(stdin=io.StringIO("7\n"), stdout=io.StringIO())
    with pytest.raises(ResponderClosed, match="end of input"):
        r.respond(TRIAL, STIM)
    with pytest.raises(ResponderClosed):
        ConsoleResponder(stdin=io.StringIO(""), stdout=io.StringIO()).prompt_experimenter("place 2#")


def test_prompt_waits_for_enter_and_cue_rings_the_bell():
    out = io.StringIO()
    stdin = io.StringIO("\n4\n")
    r = ConsoleResponder(stdin=stdin, stdout=out)
    r.prompt_experimenter("place sample 2#")
    assert stdin.tell() == 1                       # exactly the confirmation line was read
    assert "[experimenter] place sample 2#" in out.getvalue()
    assert r.cue() is True and "\a" in out.getvalue()
    assert ConsoleResponder(stdin=stdin, stdout=io.StringIO(), bell=False).cue() is False
