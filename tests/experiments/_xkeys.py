"""Real X key presses for the GUI tests (xdotool), one helper for all of them.

``xdotool search --sync --name TITLE windowfocus --sync key --delay 30 KEY`` sends real X events
that reach PsychoPy's psychtoolbox keyboard (and Qt's dialogs). About one key in 20 is missed
on a loaded machine: callers watch for the effect and send again once.
"""
from __future__ import annotations

import subprocess

__all__ = ["send_key", "press_until", "type_text", "window_open", "wait_for_window", "PSYCHOPY_TITLE",
           "THERMOCUE_TITLE"]

#: PsychoPy's default window title (Builder and Coder scripts) and thermocue's participant window.
PSYCHOPY_TITLE = "^PsychoPy$"
THERMOCUE_TITLE = "^thermocue$"


def _xdotool(env: dict, title: str, *action: str) -> None:
    subprocess.run(["xdotool", "search", "--sync", "--name", title, "windowfocus", "--sync",
                    *action], env=env, timeout=15, check=True, capture_output=True)


def send_key(env: dict, key: str, title: str = THERMOCUE_TITLE) -> None:
    """Press and release ``key`` (an X keysym name: ``space``, ``1``, ``Escape``, ``ctrl+a``)
    in the window whose name matches the regular expression ``title``."""
    _xdotool(env, title, "key", "--delay", "30", key)


def press_until(env: dict, key: str, moved, proc, tries: int = 2, wait_s: float = 4.0,
                title: str = THERMOCUE_TITLE) -> int:
    """Press ``key`` and wait up to ``wait_s`` for ``moved()`` (the program logged what the key
    does) or for ``proc`` to end; press again if neither, ``tries`` presses at most (a missed
    key on a loaded machine). Returns the presses made."""
    import time
    for n in range(1, tries + 1):
        send_key(env, key, title)
        t0 = time.monotonic()
        while time.monotonic() - t0 < wait_s and proc.poll() is None and not moved():
            time.sleep(0.05)
        if proc.poll() is not None or moved():
            return n
    return tries


def type_text(env: dict, text: str, title: str) -> None:
    """Type ``text`` in the window whose name matches ``title``."""
    _xdotool(env, title, "type", "--delay", "30", text)


def window_open(env: dict, title: str) -> bool:
    """Whether a window whose name matches ``title`` is mapped now."""
    return subprocess.run(["xdotool", "search", "--onlyvisible", "--name", title], env=env,
                          timeout=15, capture_output=True).returncode == 0


def wait_for_window(env: dict, title: str, proc, timeout_s: float = 120.0) -> bool:
    """Wait until a window matching ``title`` is mapped; False if ``proc`` ended or time ran out."""
    import time
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and proc.poll() is None:
        if window_open(env, title):
            return True
        time.sleep(0.2)
    return False
