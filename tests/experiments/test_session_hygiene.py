"""Session hygiene: a second session for a participant is told and asked about,
a record's id must match its file's name, an out-of-range skin temperature is the
experimenter's to confirm.
"""
from __future__ import annotations

import fcntl
import json
import os
import re
import select
import subprocess
import sys
import termios
import time

from _session_helpers import P01, write_protocol
from experiments.cli import main


def _run_args(proto, data, participant=P01):
    return ["run", str(proto), "--participant", str(participant), "--display",
            "emulator://?clock=virtual", "--responder", "simulated", "--data", str(data), "--quiet"]


def test_a_record_whose_id_is_not_its_file_name_is_refused(tmp_path, capsys):
    record = json.loads(P01.read_text())
    path = tmp_path / "P09.json"
    path.write_text(json.dumps(record))
    proto = write_protocol(tmp_path, real_samples=(), sim_samples=(4,), contact_s=0.5)
    assert main(_run_args(proto, tmp_path / "data", path)) == 2
    assert capsys.readouterr().err == (f"thermocue run: {path}: id: expected 'P09' (the file's "
                                       f"name), got 'P01': rename the file or correct the id\n")
    assert not (tmp_path / "data").exists()


def _on_a_terminal(argv, answer: str):
    """Run thermocue with a pty as its controlling terminal; answer its question with ``answer``."""
    master, slave = os.openpty()

    def claim_terminal():
        os.setsid()
        fcntl.ioctl(slave, termios.TIOCSCTTY, 0)

    proc = subprocess.Popen([sys.executable, "-m", "experiments", *argv], stdin=slave,
                            stdout=slave, stderr=subprocess.PIPE, text=True,
                            preexec_fn=claim_terminal, pass_fds=(slave,))
    os.close(slave)
    seen = b""
    deadline = time.monotonic() + 120
    try:
        while time.monotonic() < deadline and proc.poll() is None:   # answer every question
            if select.select([master], [], [], 0.2)[0]:
                try:
                    chunk = os.read(master, 4096)
                except OSError:
                    break
                seen += chunk
                for _ in range(chunk.count(b"[y/N]")):
                    os.write(master, answer.encode() + b"\n")
                for _ in range(chunk.count(b"Which roughness")):   # the console responder
                    os.write(master, b"1\n")
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        os.close(master)
    return proc.returncode, seen.decode(errors="replace"), err


def test_a_second_session_is_told_and_asked_about(tmp_path):
    proto = write_protocol(tmp_path, real_samples=(), sim_samples=(4,), contact_s=0.5)
    data = tmp_path / "data"
    assert main(_run_args(proto, data)) == 0
    # Saying no on the terminal: nothing written.
    status, asked, err = _on_a_terminal(_run_args(proto, data), "n")
    assert status == 1, err
    assert f"warning: participant P01 already has 1 finished session(s): {data / 'P01' / 'S01'}" in err
    assert "run another session for P01? [y/N]" in asked
    assert sorted(p.name for p in (data / "P01").iterdir()) == ["S01"]
    # Saying yes: S02 is run.
    status, asked, err = _on_a_terminal(_run_args(proto, data), "y")
    assert status == 0, err
    assert sorted(p.name for p in (data / "P01").iterdir()) == ["S01", "S02"]


def _cold_finger(tmp_path):
    record = json.loads(P01.read_text())
    record["initial_skin_temperature_C"] = 30.0          # the protocol wants 35.5-36 °C
    path = tmp_path / "P01.json"
    path.write_text(json.dumps(record))
    return path


def _console_args(proto, data, participant):
    args = _run_args(proto, data, participant)
    args[args.index("simulated")] = "console"
    return args + ["--responder-option", "bell=false"]


def test_an_out_of_range_skin_temperature_must_be_confirmed_to_go_on(tmp_path):
    proto = write_protocol(tmp_path, real_samples=(), sim_samples=(4, 2), contact_s=0.5)
    data = tmp_path / "data"
    status, asked, err = _on_a_terminal(_console_args(proto, data, _cold_finger(tmp_path)), "n")
    assert status == 1, err
    # (the emulated thermometer reads the 30 °C finger with its noise)
    assert re.search(r"thermocue: warning: trial 1: skin temperature (29|30)\.\d\d °C, outside 35\.5-36 °C", err)
    assert re.search(r"trial 1: skin temperature (29|30)\.\d\d °C is out of range; keep this trial and go "
                     r"on\? \[y/N\]", asked)
    events = [json.loads(line) for line in (data / "P01" / "S01" / "events.jsonl").read_text().splitlines()]
    kinds = [e["event"] for e in events]
    assert [e["answer"] for e in events if e["event"] == "skin_temperature_confirmation"] == ["no"]
    assert "session_interrupted" in kinds and "trial_completed" not in kinds    # resumable
    # Confirmed: the trials are kept, flagged in trials.csv.
    data2 = tmp_path / "data2"
    status, asked, err = _on_a_terminal(_console_args(proto, data2, _cold_finger(tmp_path)), "y")
    assert status == 0, err
    rows = (data2 / "P01" / "S01" / "trials.csv").read_text().splitlines()
    header = rows[0].split(",")
    flags = [r.split(",")[header.index("skin_temperature_in_range")] for r in rows[1:]]
    assert flags == ["0", "0"]


def test_without_a_terminal_the_warning_is_logged_as_unanswered(tmp_path, capsys):
    proto = write_protocol(tmp_path, real_samples=(), sim_samples=(4,), contact_s=0.5)
    data = tmp_path / "data"
    argv = _console_args(proto, data, _cold_finger(tmp_path))
    run = subprocess.run([sys.executable, "-m", "experiments", *argv], capture_output=True,
                         text=True, timeout=120, input="1\n", start_new_session=True)
    assert run.returncode == 0, run.stderr
    assert re.search(r"skin temperature (29|30)\.\d\d °C, outside 35\.5-36 °C", run.stderr)
    events = [json.loads(line) for line in (data / "P01" / "S01" / "events.jsonl").read_text().splitlines()]
    assert [e["answer"] for e in events if e["event"] == "skin_temperature_confirmation"] == \
        ["unasked (no terminal)"]


def test_a_simulated_participant_is_never_held_up_by_the_question(tmp_path):
    """On a terminal, the paper's reproduction (simulated participants) must not wait for y/N."""
    proto = write_protocol(tmp_path, real_samples=(), sim_samples=(4,), contact_s=0.5)
    data = tmp_path / "data"
    status, asked, err = _on_a_terminal(_run_args(proto, data, _cold_finger(tmp_path)), "n")
    assert status == 0 and "[y/N]" not in asked, err
    events = [json.loads(line) for line in (data / "P01" / "S01" / "events.jsonl").read_text().splitlines()]
    assert [e["answer"] for e in events if e["event"] == "skin_temperature_confirmation"] == \
        ["unasked (simulated participant)"]
