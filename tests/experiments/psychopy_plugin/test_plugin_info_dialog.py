"""PsychoPy's experiment-info dialog ("Show info dlg") without wxPython.

PsychoPy draws the dialog with PyQt6 (a PsychoPy requirement); under Xvfb it opens once Qt's
X11 libraries are installed (scripts/setup), and
``test_plugin_builder.py::test_builder_experiment_runs_against_the_emulator_on_a_pty`` fills it
in with real keys. Here: where Qt cannot start (``QT_QPA_PLATFORM`` naming no platform stands
for any reason, e.g. a missing xcb library), PsychoPy's own call aborts the process; with the
plugin activated (as every Builder script does on its first lines) the same fields are asked on
the terminal, or, with no terminal, the script stops with one line naming the fixes.
"""
from __future__ import annotations

import os
import select
import subprocess
import sys
import time

import pytest

from _plugin_helpers import gui_env

pytestmark = [pytest.mark.gui]

SCRIPT = """
import sys
if sys.argv[1] == "plugin":
    from psychopy import plugins
    plugins.activatePlugins()
from psychopy import gui
info = {"participant": "123456", "session": "001", "group": ["A", "B"]}
dlg = gui.DlgFromDict(dictionary=info, sortKeys=False, title="thermal_cue_demo", alwaysOnTop=True)
print("OK" if dlg.OK else "CANCEL", sorted(info.items()), flush=True)
"""


def _no_qt(xvfb):
    return {**gui_env(xvfb), "QT_QPA_PLATFORM": "no-such-platform"}


def test_where_qt_cannot_start_psychopys_own_dialog_aborts_the_process(tmp_path, xvfb):
    """The problem itself: no Python error to catch, the process is killed by SIGABRT."""
    run = subprocess.run([sys.executable, "-c", SCRIPT, "psychopy"], env=_no_qt(xvfb),
                         stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=120)
    assert run.returncode == -6, (run.returncode, run.stderr[-1000:])
    assert "no Qt platform plugin could be initialized" in run.stderr


def test_with_no_terminal_the_script_stops_with_one_line_naming_the_fixes(tmp_path, xvfb):
    run = subprocess.run([sys.executable, "-c", SCRIPT, "plugin"], env=_no_qt(xvfb),
                         stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=120)
    assert run.returncode == 1, run.stderr[-2000:]
    assert "OK" not in run.stdout and "CANCEL" not in run.stdout     # stopped at the dialog
    last = run.stderr.strip().splitlines()[-1]
    assert last.startswith("thermocue: ") and "PsychoPy's experiment-info dialog ('thermal_cue_demo') "\
        "cannot open: Qt cannot start (qt.qpa.plugin: Could not find the Qt platform plugin " \
        "\"no-such-platform\"" in last
    assert "apt-get install libxcb-cursor0 libxcb-icccm4" in last
    assert "turn off \"Show info dlg\"" in last and "Traceback" not in run.stderr


def _run_on_a_terminal(xvfb, answers: list[bytes]):
    """The script with a pty as its stdin (someone at a terminal); ``answers`` typed once each
    prompt (a line ending in ': ') has appeared on stderr."""
    master, slave = os.openpty()
    proc = subprocess.Popen([sys.executable, "-c", SCRIPT, "plugin"], env=_no_qt(xvfb),
                            stdin=slave, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    os.close(slave)
    err = b""
    try:
        deadline = time.monotonic() + 120
        for answer in answers:
            prompts = err.count(b"]: ")
            while err.count(b"]: ") == prompts and time.monotonic() < deadline:
                ready, _, _ = select.select([proc.stderr], [], [], 0.2)
                if ready:
                    chunk = os.read(proc.stderr.fileno(), 4096)
                    if not chunk:
                        break
                    err += chunk
            os.write(master, answer)
        out, rest = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        os.close(master)
    return proc.returncode, out.decode(), (err + rest).decode()


def test_on_a_terminal_the_fields_are_asked_there(tmp_path, xvfb):
    # participant typed, session kept (Enter), a wrong choice asked again, then B
    rc, out, err = _run_on_a_terminal(xvfb, [b"P07\n", b"\n", b"C\n", b"B\n"])
    assert rc == 0, err[-2000:]
    assert "PsychoPy's dialog cannot open (qt.qpa.plugin: Could not find the Qt platform " \
           "plugin \"no-such-platform\"" in err
    assert "participant [123456]: " in err and "expected one of A, B" in err
    assert out.strip().splitlines()[-1] == "OK [('group', 'B'), ('participant', 'P07'), ('session', '001')]"


def test_on_a_terminal_end_of_input_is_cancel(tmp_path, xvfb):
    rc, out, err = _run_on_a_terminal(xvfb, [b"P07\n", b"\x04"])
    assert rc == 0, err[-2000:]
    # Cancel leaves the dictionary as it was (PsychoPy's own dialog does the same)
    assert out.strip().splitlines()[-1] == "CANCEL [('group', ['A', 'B']), ('participant', '123456'), ('session', '001')]"


def test_a_list_field_with_no_choices_is_asked_as_text(monkeypatch):
    """An empty list (a Builder field left without choices) raised IndexError; it is free text.
    PsychoPy's own gui.util builds the fields; standard input holds the two typed lines."""
    import io
    from experiments.psychopy_plugin.component.info_dialog import TerminalDlgFromDict
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(b"P07\nleft\n")))
    info = {"participant": "123456", "hand": []}
    dlg = TerminalDlgFromDict(info, title="t", sortKeys=False, reason="no Qt here")
    assert dlg.OK and info == {"participant": "P07", "hand": "left"}
