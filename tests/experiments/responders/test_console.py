"""Tests of the console responder."""
from __future__ import annotations

import io
import os
import select

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


def test_prompt_waits_for_enter():
    out = io.StringIO()
    stdin = io.StringIO("\n4\n")
    r = ConsoleResponder(stdin=stdin, stdout=out)
    r.prompt_experimenter("place sample 2#")
    assert stdin.tell() == 1                       # exactly the confirmation line was read
    # The console is the participant's terminal: the sample to place is the experimenter's
    # (the session prints it on stderr), never printed here (it leaked the answer).
    assert out.getvalue() == "Please wait (experimenter: press Enter when ready)\n"


def test_feedback_and_label_are_printed_for_the_participant():
    out = io.StringIO()
    r = ConsoleResponder(stdin=io.StringIO(""), stdout=out)
    r.show_label("This is sample 2#")
    r.feedback("Correct: it was sample 2#")
    r.show_label(None)
    assert out.getvalue() == "This is sample 2#\nCorrect: it was sample 2#\n"


@pytest.fixture
def terminal():
    """A real terminal (a pty): the responder writes to its slave end, the test reads the master."""
    master, slave = os.openpty()
    tty = open(slave, "w", encoding="utf-8", closefd=True)
    yield tty, master
    tty.close()
    os.close(master)


def _read_all(fd) -> str:
    out = b""
    while select.select([fd], [], [], 0.2)[0]:
        chunk = os.read(fd, 4096)
        if not chunk:
            break
        out += chunk
    return out.decode(errors="replace")


def test_cue_rings_the_bell_on_a_terminal(terminal):
    tty, master = terminal
    r = ConsoleResponder(stdin=io.StringIO(), stdout=tty, stderr=io.StringIO())
    assert r.cue() is True
    text = _read_all(master)
    assert "\a" in text and "Touch now" in text


def test_cue_rings_on_stderr_when_only_stderr_is_a_terminal(terminal):
    tty, master = terminal
    out = io.StringIO()
    r = ConsoleResponder(stdin=io.StringIO(), stdout=out, stderr=tty)
    assert r.cue() is True
    assert _read_all(master) == "\a" and "\a" not in out.getvalue() and "Touch now" in out.getvalue()


def test_cue_without_a_terminal_is_reported_as_not_played():
    # Regression: the bell went to a pipe or file and the cue was reported played.  (What the
    # session logs: test_session_checks.py::test_console_cue_without_a_terminal_is_logged_as_not_played.)
    out, err = io.StringIO(), io.StringIO()
    r = ConsoleResponder(stdin=io.StringIO(), stdout=out, stderr=err)
    assert r.cue() is False
    assert "\a" not in out.getvalue() + err.getvalue() and "Touch now" in out.getvalue()
    assert ConsoleResponder(stdin=io.StringIO(), stdout=io.StringIO(), bell=False).cue() is False


def test_bell_off_is_not_played_even_on_a_terminal(terminal):
    tty, master = terminal
    r = ConsoleResponder(stdin=io.StringIO(), stdout=tty, stderr=tty, bell=False)
    assert r.cue() is False
    assert "\a" not in _read_all(master)


def test_spoken_answers_on_the_console_session_end_to_end(tmp_path):
    """``answer_mode = "spoken"`` with the console: the participant's terminal (stdout) gets
    nothing; the experimenter (stderr prompts) types each spoken answer, undoes a wrong one
    with ``u`` and confirms with Enter; trials.csv times the answer from the question's bell."""
    import csv
    import subprocess
    import sys

    from _session_helpers import P01, write_protocol
    proto = write_protocol(tmp_path, contact_s=0.5, real_samples=(2,), sim_samples=(3,))
    proto.write_text(proto.read_text().replace(
        "[[blocks]]", '[presentation]\nanswer_mode = "spoken"\n\n[[blocks]]', 1))
    data = tmp_path / "data"
    keys = "\n" + "1\nu\n2\n\n" + "4\n3\n\n"     # placed; 1 undone, 2 confirmed; 4 replaced by 3
    run = subprocess.run([sys.executable, "-m", "experiments", "run", str(proto), "--participant",
                          str(P01), "--display", "emulator://?clock=virtual&seed=2", "--responder",
                          "console", "--data", str(data), "--session", "S01"],
                         input=keys, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    # nothing for the participant to read: stdout holds only the CLI's closing line (the folder)
    assert run.stdout == f"{data / 'P01' / 'S01'}\n"
    assert "type the participant's spoken answer (1-4)" in run.stderr
    assert "say to the participant: 'Thank you: the session is finished.'" in run.stderr
    with open(data / "P01" / "S01" / "trials.csv", newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["status"] == "ok"]
    assert [(r["roughness_id"], r["response_id"], r["answer_mode"], r["rt_s"], r["response_source"])
            for r in rows] == [("2", "2", "spoken", "", "experimenter:console"),
                               ("3", "3", "spoken", "", "experimenter:console")]
    assert all(float(r["answer_keyed_after_cue_s"]) >= 0 for r in rows)
    events = [__import__("json").loads(line) for line in
              (data / "P01" / "S01" / "events.jsonl").read_text().splitlines()]
    assert [(e["key"], e.get("replaced_by")) for e in events if e["event"] == "answer_undone"] == \
        [("1", None), ("4", "3")]
    assert [e["played"] for e in events if e["event"] == "question_cue"] == [False, False]  # no tty
