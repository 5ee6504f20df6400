"""`thermocue run`: run one participant through a protocol (new session)."""
from __future__ import annotations

import argparse
import ctypes
import ctypes.util
import os
import sys
from pathlib import Path

from sessionfiles.logformat import read_events
from stimuli.paper import RESPONDER_NAMES as RESPONDERS


def register(sub) -> None:
    p = sub.add_parser(
        "run", help="run one participant through a protocol",
        description="Run one participant through a protocol and write DATA/<participant>/<session>/ "
                    "(session.json, events.jsonl, trials.csv, traces/).")
    p.add_argument("protocol", metavar="PROTOCOL",
                   help="protocol file (TOML) or packaged protocol name, e.g. roughness_recognition")
    p.add_argument("--participant", required=True, metavar="FILE", help="participant record (JSON)")
    p.add_argument("--display", required=True, metavar="URL",
                   help="display: emulator://[?clock=virtual&seed=N&faults=...], a pty or /dev/ttyUSB0")
    p.add_argument("--responder", required=True, choices=RESPONDERS,
                   help="who answers: PsychoPy window, console, or simulated participant")
    p.add_argument("--data", required=True, metavar="DIR", help="data folder (DATA)")
    p.add_argument("--seed", type=int, default=None, metavar="N", help="schedule seed (default: random, stored)")
    p.add_argument("--session", default=None, metavar="NAME", help="session name (default: S01, S02, ...)")
    p.add_argument("--allow-second-session", action="store_true",
                   help="run even though the participant has an unfinished session (running now, "
                        "or interrupted: `thermocue resume` continues it)")
    add_common(p)
    p.set_defaults(func=_run)


def add_common(p) -> None:
    """Options shared with `thermocue resume`."""
    p.add_argument("--clock", choices=("auto", "real", "virtual"), default=None,
                   help="virtual: no waiting (rewarming), for simulated sessions; auto: virtual "
                        "iff the display URL has clock=virtual (the default of run; resume's "
                        "default: the clock the URL names, else the session's own)")
    p.add_argument("--responder-option", action="append", default=[], metavar="KEY=VALUE",
                   help="option passed to the responder (repeatable), e.g. fullscr=true")
    p.add_argument("--max-faults", type=int, default=None, metavar="N",
                   help="stop cleanly after N consecutive display faults (default 3)")
    p.add_argument("--experimenter-screen", type=int, default=None, metavar="N",
                   help="show the experimenter's lines (sample to place, progress, warnings) in "
                        "a PsychoPy window on screen N too (default: the terminal only)")
    p.add_argument("--monitor", action="store_true",
                   help="also serve the experimenter's live view of the session as a local web "
                        "page (thermocue monitor, in a process of its own; its URL is printed)")
    # SUPPRESS: absent here, ``thermocue --quiet run`` (the top-level option) stands
    p.add_argument("--quiet", action="store_true", default=argparse.SUPPRESS,
                   help="no progress lines on stderr (errors and why a run stopped are still printed)")


def responder_options(items) -> dict:
    """Parse KEY=VALUE strings (true/false/numbers converted)."""
    from experiments.errors import UserInputError
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise UserInputError(f"--responder-option: expected KEY=VALUE, got {item!r}")
        v: object = value
        low = value.strip().lower()
        if low in ("true", "yes", "on"):
            v = True
        elif low in ("false", "no", "off"):
            v = False
        elif low in ("none", "null"):
            v = None
        else:
            for kind in (int, float):
                try:
                    v = kind(value)
                    break
                except ValueError:
                    pass
        out[key.strip().replace("-", "_")] = v
    return out


def check_common(ns) -> None:
    """Check the options of :func:`add_common` (UserInputError naming the option)."""
    from experiments.errors import UserInputError
    if ns.max_faults is not None and ns.max_faults < 1:
        raise UserInputError(f"--max-faults: expected an integer ≥ 1, got {ns.max_faults}")
    if ns.experimenter_screen is not None:
        if ns.experimenter_screen < 0:
            raise UserInputError(f"--experimenter-screen: expected a screen number ≥ 0, got "
                                 f"{ns.experimenter_screen}")
        check_window("psychopy", option="--experimenter-screen")


def experimenter_for(ns):
    """The experimenter's channel the options ask for (terminal, or a window on a screen)."""
    from experiments.responders.experimenter import make_experimenter
    return make_experimenter(ns.experimenter_screen)


def check_window(responder: str, option: str = "--responder psychopy") -> None:
    """Refuse the PsychoPy responder up front when there is no display to open a window on."""
    from experiments.errors import UserInputError
    if responder == "psychopy" and sys.platform.startswith("linux") \
            and not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        raise UserInputError(f"{option}: expected a display for the window (DISPLAY), "
                             "got none set (start Xvfb, or use --responder console)")
    if responder == "psychopy" and os.environ.get("DISPLAY") and not _x_display_opens():
        raise UserInputError(f"{option}: expected a display to open the window on, got "
                             f"DISPLAY={os.environ['DISPLAY']!r}, which does not answer (is the X "
                             f"server running?)")


def _x_display_opens() -> bool:
    """Whether Xlib can connect to ``$DISPLAY`` (True when Xlib itself is not found: PsychoPy
    will then say what is wrong)."""
    name = ctypes.util.find_library("X11")
    if name is None:
        return True
    try:
        xlib = ctypes.CDLL(name)
    except OSError:
        return True
    xlib.XOpenDisplay.restype = ctypes.c_void_p
    xlib.XOpenDisplay.argtypes = [ctypes.c_char_p]
    xlib.XCloseDisplay.argtypes = [ctypes.c_void_p]
    handle = xlib.XOpenDisplay(None)
    if not handle:
        return False
    xlib.XCloseDisplay(handle)
    return True


def _run(ns) -> int:
    from experiments.errors import UserInputError
    from experiments.responders import get_responder
    from experiments.session import plan_session

    from experiments.cli.paths import check_writable_dir

    if ns.seed is not None and ns.seed < 0:
        raise UserInputError(f"--seed: expected an integer ≥ 0, got {ns.seed}")
    check_common(ns)
    check_window(ns.responder)
    check_writable_dir(ns.data, "--data")      # before the display and the window are opened
    responder = get_responder(ns.responder, **responder_options(ns.responder_option))
    # Everything is checked (files, schedule, every simulated profile) and the display opened
    # before the session folder is written: a bad input or an unreachable display leaves nothing.
    plan = plan_session(ns.protocol, ns.participant, ns.data, ns.display, seed=ns.seed,
                        session_name=ns.session, responder_name=ns.responder,
                        clock=ns.clock or "auto", max_consecutive_faults=ns.max_faults or 3)
    refuse_second_live_session(plan, ns.allow_second_session, experimenter_for(ns))
    if not confirm_another_session(plan, experimenter_for(ns)):
        return 1
    display = open_display_or_report("run", plan.protocol, ns.display, "--display",
                                     "no session was written")
    if display is None:
        return 1
    with display:
        plan.check_display(display)
        session = plan.write()
        session.experimenter = experimenter_for(ns)
        print(session.directory, file=sys.stdout, flush=True)
        beside = start_monitor(ns, session.directory)
        try:
            return session.run(responder, display=display)
        finally:
            stop_monitor(beside, session.directory)
            remove_if_unused(session.directory)


def start_monitor(ns, folder):
    """``--monitor``: thermocue monitor beside the session (its own process), or None."""
    if not getattr(ns, "monitor", False):
        return None
    from experiments.cli.monitor import start_beside
    return start_beside(folder)


def stop_monitor(proc, folder) -> None:
    if proc is not None:
        from experiments.cli.monitor import stop_beside
        stop_beside(proc, folder)


def refuse_second_live_session(plan, allowed: bool, experimenter) -> None:
    """Refuse a new session while the participant has one that started and did not finish
    (running in another terminal, or interrupted); with ``--allow-second-session``, warn only.

    Raises
    ------
    SessionError
        Naming the unfinished session(s) and how to go on (exit 2, nothing written).
    """
    from experiments.errors import SessionError
    from experiments.session import unfinished_sessions

    live = [d for d in unfinished_sessions(plan.directory.parent) if d != plan.directory]
    if not live:
        return
    names = ", ".join(str(d) for d in live)
    what = (f"participant {plan.participant_id} has {len(live)} unfinished session(s): {names} "
            f"(running now, or interrupted: `thermocue resume {live[0]}` continues it)")
    if not allowed:
        raise SessionError(f"{what}; not starting another (give --allow-second-session to run "
                           f"{plan.directory.name} anyway)")
    experimenter.tell(f"warning: {what}; starting {plan.directory} as asked "
                      f"(--allow-second-session)")


def confirm_another_session(plan, experimenter) -> bool:
    """Tell the experimenter when the participant already has a finished session, and ask
    (on a terminal) whether to run another; False when they say no (nothing is written)."""
    from experiments.session import finished_sessions

    done = finished_sessions(plan.directory.parent)
    if not done:
        return True
    names = ", ".join(str(d) for d in done)
    experimenter.tell(f"warning: participant {plan.participant_id} already has "
                      f"{len(done)} finished session(s): {names}; this one would be "
                      f"{plan.directory} (analysis uses the first complete session by default)")
    answer = experimenter.confirm(f"run another session for {plan.participant_id}?")
    if answer is False:
        experimenter.tell("no session was written")
        return False
    return True


def remove_if_unused(directory) -> bool:
    """Remove a session folder in which no trial was started (e.g. the window did not open).

    Only the files a new session writes are removed (``session.json``, ``events.jsonl``,
    ``trials.csv`` with no rows, an empty ``traces/``), then the folder and an emptied participant folder: a failure before the
    first trial leaves no empty session behind. Returns whether it was removed.
    """
    directory = Path(directory)
    try:
        events, report = read_events(directory / "events.jsonl", on_damage="stop", warn=False)
    except FileNotFoundError:
        events, report = [], None
    except OSError:
        return False
    if report is not None and (not report.ok or report.n_events != report.n_lines):
        return False              # a log it cannot read whole (damage, blank lines): keep everything
    if any(e["event"] == "trial_started" for e in events):
        return False
    known = {"session.json", "events.jsonl", "trials.csv", "traces"}
    if any(p.name not in known for p in directory.iterdir()) or \
            ((directory / "traces").is_dir() and any((directory / "traces").iterdir())):
        return False
    for name in ("session.json", "events.jsonl", "trials.csv"):
        (directory / name).unlink(missing_ok=True)
    for folder in (directory / "traces", directory, directory.parent):
        try:
            folder.rmdir()
        except OSError:
            break
    return True


def open_display_or_report(command: str, protocol, url: str, option: str, outcome: str, source=None):
    """Open the session's display; None (reason printed on stderr) if it cannot be reached.

    Bad input (a malformed URL, an unknown emulator option, a path that is not a serial device,
    a protocol range the device does not allow) raises a UserInputError naming ``option`` or the
    protocol field (exit 2).
    """
    from experiments.errors import DisplayError, UserInputError
    from experiments.session import open_session_display

    try:
        return open_session_display(protocol, url, option=option, source=source)
    except DisplayError as exc:
        if isinstance(exc, UserInputError):
            raise
        print(f"thermocue {command}: {exc}; {outcome}", file=sys.stderr, flush=True)
        return None
