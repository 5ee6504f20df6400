"""File-system failures are one line naming the path, before any work.

On the old code: ``--out`` naming a file was a FileExistsError traceback in analyze and power and
NotADirectoryError in calibrate; an unwritable ``--data`` a PermissionError after the display was
opened; a bad DISPLAY left an empty session folder.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from importlib.metadata import version

import pytest

from _session_helpers import P01, write_protocol
from experiments.cli import main


@pytest.fixture
def a_file(tmp_path):
    path = tmp_path / "results.txt"
    path.write_text("not a folder\n")
    return path


@pytest.mark.parametrize("argv", [
    ["analyze", "{data}", "--out", "{file}"],
    ["power", "--out", "{file}"],
    ["calibrate", "{data}", "--out", "{file}"],
])
def test_out_naming_a_file_is_one_line(tmp_path, a_file, capsys, argv):
    (tmp_path / "data").mkdir()
    args = [a.format(data=tmp_path / "data", file=a_file) for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err == (f"thermocue {argv[0]}: --out {a_file}: expected a folder (or a new name), "
                   f"got an existing file\n")
    assert a_file.read_text() == "not a folder\n"


@pytest.mark.parametrize("data", ["{file}/sub", "/proc/thermocue-data"])
def test_run_refuses_an_unusable_data_folder_before_opening_the_display(tmp_path, a_file, capsys, data):
    proto = write_protocol(tmp_path, sim_samples=())
    data = data.format(file=a_file)
    # The display URL would fail if it were opened: the data folder is refused first.
    assert main(["run", str(proto), "--participant", str(P01), "--display", "/dev/null/nothing",
                 "--responder", "console", "--data", data]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"thermocue run: --data {data}: expected a folder")


def test_os_errors_during_a_command_are_one_line_naming_the_path(tmp_path, capsys, monkeypatch):
    # A file-system failure after the checks (here: session.json cannot be written because
    # the participant's folder is a file) is one line naming the path, exit 1, no traceback.
    proto = write_protocol(tmp_path, real_samples=(), sim_samples=(4,), contact_s=0.5)
    data = tmp_path / "data"
    data.mkdir()
    (data / "P01").write_text("in the way\n")
    status = main(["run", str(proto), "--participant", str(P01), "--display",
                   "emulator://?clock=virtual", "--responder", "simulated", "--data", str(data)])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 1 and len(err) == 1, err
    assert err[0].startswith(f"thermocue run: {data / 'P01'}") and "Traceback" not in err[0]


@pytest.mark.gui
def test_a_display_that_does_not_answer_leaves_no_session_folder(tmp_path):
    proto = write_protocol(tmp_path, sim_samples=())
    data = tmp_path / "data"
    env = {**os.environ, "DISPLAY": ":93"}        # no X server there
    run = subprocess.run([sys.executable, "-m", "experiments", "run", str(proto), "--participant",
                          str(P01), "--display", "emulator://?clock=virtual", "--responder",
                          "psychopy", "--data", str(data)], env=env, capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 2, run.stderr
    assert run.stderr.strip().splitlines()[-1] == (
        "thermocue run: --responder psychopy: expected a display to open the window on, got "
        "DISPLAY=':93', which does not answer (is the X server running?)")
    assert not data.exists() or not any(data.rglob("*"))


def test_a_failure_before_the_first_trial_removes_the_session_folder(tmp_path):
    from experiments.cli.run import remove_if_unused
    from experiments.session import create_session

    proto = write_protocol(tmp_path, sim_samples=())
    s = create_session(proto, P01, tmp_path / "data", "emulator://?clock=virtual", seed=1)
    (s.directory / "events.jsonl").write_text('{"event":"session_started","seq":1}\n')
    assert remove_if_unused(s.directory) and not (tmp_path / "data" / "P01").exists()
    s = create_session(proto, P01, tmp_path / "data", "emulator://?clock=virtual", seed=1)
    (s.directory / "events.jsonl").write_text('{"event":"trial_started","seq":1}\n')
    assert not remove_if_unused(s.directory) and (s.directory / "session.json").exists()


def test_the_unused_session_check_reads_the_log_as_the_writer_wrote_it(tmp_path):
    # the writer (logformat.dumps) keeps U+2028 raw inside strings: not a line break, so a log
    # of a session that never started a trial still reads whole and its folder goes
    from experiments.cli.run import remove_if_unused
    from sessionfiles.logformat import dumps
    from experiments.session import create_session

    proto = write_protocol(tmp_path, sim_samples=())
    s = create_session(proto, P01, tmp_path / "data", "emulator://?clock=virtual", seed=1)
    line = dumps({"event": "session_started", "seq": 1, "note": "first\u2028second"})
    assert "\u2028" in line
    (s.directory / "events.jsonl").write_text(line + "\n", encoding="utf-8")
    assert remove_if_unused(s.directory) and not (tmp_path / "data" / "P01").exists()


def test_a_damaged_log_keeps_the_session_folder(tmp_path):
    from experiments.cli.run import remove_if_unused
    from experiments.session import create_session

    proto = write_protocol(tmp_path, sim_samples=())
    for text in ('{"event":"session_started","seq":1}\n{"event":"trial_sta',       # torn last line
                 '{"event":"session_started","seq":1}\nnot json\n',                 # undecodable line
                 '{"event":"session_started","seq":1}\n\n'):                        # a blank line
        s = create_session(proto, P01, tmp_path / "data", "emulator://?clock=virtual", seed=1)
        (s.directory / "events.jsonl").write_text(text)
        assert not remove_if_unused(s.directory) and (s.directory / "session.json").exists(), text


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out == f"thermocue {version('thermocue')}\n"
    assert shutil.which("thermocue") is None or subprocess.run(
        ["thermocue", "--version"], capture_output=True, text=True).stdout.startswith("thermocue ")
