"""`thermocue resume`: continue an interrupted session at its first incomplete trial."""
from __future__ import annotations

import sys


def register(sub) -> None:
    from experiments.cli.run import RESPONDERS, add_common
    p = sub.add_parser(
        "resume", help="continue an interrupted session",
        description="Continue a session at its first incomplete trial with the same schedule; an "
                    "attempt cut off mid-way is logged as aborted and run again; trials.csv is "
                    "rebuilt from events.jsonl.")
    p.add_argument("session_dir", metavar="SESSION_DIR", help="DATA/<participant>/<session>")
    p.add_argument("--display", default=None, metavar="URL",
                   help="display URL (default: the one in session.json); with --clock auto the "
                        "clock follows this URL")
    p.add_argument("--responder", default=None, choices=RESPONDERS,
                   help="responder (default: the one in session.json)")
    add_common(p)
    p.set_defaults(func=_run)


def _run(ns) -> int:
    from experiments.cli.run import (check_common, check_window, experimenter_for,
                                     open_display_or_report, responder_options, start_monitor,
                                     stop_monitor)
    from experiments.errors import SessionError
    from experiments.responders import get_responder
    from experiments.session import open_session

    check_common(ns)
    # the one reader of session folders first: a FIFO or device in a file's place, another
    # encoding or a session.json of another session is refused by name before anything opens it
    from sessionfiles.session_reader import read_session_folder
    read_session_folder(ns.session_dir)
    session = open_session(ns.session_dir, display_url=ns.display, clock=ns.clock)
    if session.finished:       # first: before the responder, its window or the display
        print(f"thermocue: session {session.directory} is already finished; nothing to do",
              file=sys.stderr)
        return 0
    name = ns.responder
    if name is None:
        name = session.responder_name
        if not name:
            raise SessionError(f"{session.directory / 'session.json'}: responder: expected a name, "
                               f"got {name!r} (give --responder)")
    if ns.max_faults is not None:
        session.max_consecutive_faults = ns.max_faults
    session.experimenter = experimenter_for(ns)
    check_window(name)
    responder = get_responder(name, **responder_options(ns.responder_option))
    option = "--display" if ns.display else f"{session.directory / 'session.json'}: display_url"
    display = open_display_or_report("resume", session.protocol, session.display_url, option,
                                     f"nothing was run; resume with `thermocue resume "
                                     f"{session.directory} --display URL`",
                                     source=session.protocol_source)
    if display is None:
        return 1
    with display:
        session.check_display(display)
        beside = start_monitor(ns, session.directory)
        try:
            return session.run(responder, display=display)
        finally:
            stop_monitor(beside, session.directory)
