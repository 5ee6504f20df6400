"""The ``thermocue`` command line (also ``python -m experiments``).

Thin over the library: each subcommand lives in its own module of this package
and exposes ``register(subparsers)`` (adds its parser, sets ``func``) and keeps
heavy imports inside the function that runs it, so ``thermocue --help`` stays fast.

Exit status: 0 on success, 2 on bad input (one line naming the file and the
field, no traceback), 1 otherwise; a file-system failure is one line naming the path
(``thermocue run: /data/P01: Permission denied``), exit 1, or exit 2 when it is caught before
any work (a ``--data`` or ``--out`` that cannot be written, :mod:`experiments.cli.paths`).

Progress lines (the library's ``thermocue.*`` loggers) go to stderr while a command runs
(:func:`experiments.cli.logs.configure_logging`); ``--quiet``, before or after the command name,
keeps only warnings and errors.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys

from experiments import thermocue_version
from experiments.cli.logs import configure_logging

__all__ = ["main", "SUBCOMMANDS", "thermocue_version"]

#: Subcommand name -> module (in this package) that registers it.
SUBCOMMANDS = {
    "run": "run",
    "resume": "resume",
    "emulator": "emulator",
    "displays": "displays",
    "clear-fault": "clear_fault",
    "tcs2": "tcs2",
    "check": "check",
    "analyze": "analyze",
    "reproduce": "reproduce",
    "bench": "bench",
    "power": "power",
    "calibrate": "calibrate",
    "explain": "explain",
    "export-bids": "export_bids",
    "psyexp": "psyexp",
    "monitor": "monitor",
}


def _user_errors():
    """Exception classes that mean "bad input": reported in one line, exit 2.

    Evaluated when an exception reaches :func:`main`: a package that was never imported raised
    none of its errors, so only those already imported are looked up (``import analysis`` for
    its LogError alone took seconds on a loaded machine, and ``thermocue monitor`` carried
    pandas and scipy in memory for it).
    """
    from experiments.errors import UserInputError
    classes = [UserInputError]
    for module, name in (("participants_schema", "ParticipantError"),
                         ("stimuli", "ModelInputError"), ("analysis.errors", "LogError")):
        cls = getattr(sys.modules.get(module), name, None)
        if cls is not None:
            classes.append(cls)
    return tuple(classes)


QUIET_HELP = "no progress lines on stderr (warnings, errors and results are still printed)"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="thermocue",
        description="Thermal-tactile roughness perception: model, display, sessions, analysis.",
    )
    parser.add_argument("--version", action="version", version=f"thermocue {thermocue_version()}")
    parser.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, module in SUBCOMMANDS.items():
        mod = importlib.import_module(f"{__name__}.{module}")
        mod.register(sub)
    for command in sub.choices.values():
        if "--quiet" not in command._option_string_actions:   # run/resume have their own
            # SUPPRESS: absent after the command name, the value before it stands
            command.add_argument("--quiet", action="store_true", default=argparse.SUPPRESS,
                                 help=QUIET_HELP)
    return parser


#: Commands that, run as a program, skip the interpreter's teardown once they succeed: they
#: hold files and numbers only (every output closed and renamed before they return, their
#: workers and clusters stopped), and tearing down pandas, SciPy, statsmodels and matplotlib
#: module by module took 0.57 s of a ~6 s ``thermocue analyze`` (measured from the last
#: ``atexit`` function to process exit; benchmarks/README.md). ``atexit`` functions still run
#: (logging's flush, temporary folders), then stdout and stderr are flushed. Not for
#: ``run``/``resume`` and the other device commands, whose libraries (PsychoPy, pyglet, serial
#: ports) may do work in finalizers. Taken only when no other non-daemon thread is alive (:func:`_only_thread`).
SKIP_TEARDOWN = frozenset({"analyze", "reproduce", "power"})


def _only_thread() -> bool:
    """Whether no other non-daemon thread is alive: the interpreter's own exit waits for those
    (a thread pool's workers, a writer), and ``os._exit`` would not, so with one alive the
    ordinary exit is taken. Daemon threads (dask's offload thread) are not waited for by either."""
    import threading
    main = threading.main_thread()
    return not any(t is not main and not t.daemon and t.is_alive() for t in threading.enumerate())


def exit_without_teardown(status: int):
    """Run the ``atexit`` functions, flush stdout and stderr, and end the process with
    ``status`` without the interpreter's module-by-module teardown."""
    import atexit
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):     # closed, or a pipe that went away: nothing to keep
            pass
    os._exit(status)


def main(args: list[str] | None = None) -> int:
    """Parse ``args`` (default ``sys.argv[1:]``), run the subcommand, return the exit status.

    Run as a program (``args`` None: the ``thermocue`` script, ``python -m experiments``), a
    command of :data:`SKIP_TEARDOWN` that succeeds ends the process here
    (:func:`exit_without_teardown`)."""
    parser = build_parser()
    ns = parser.parse_args(args)
    status = _run(ns)
    if args is None and status == 0 and ns.command in SKIP_TEARDOWN and _only_thread():
        exit_without_teardown(0)
    return status


def _run(ns: argparse.Namespace) -> int:
    try:
        with configure_logging(quiet=ns.quiet):
            status = ns.func(ns)
    except _user_errors() as exc:
        print(f"thermocue {ns.command}: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"thermocue {ns.command}: interrupted", file=sys.stderr)
        return 1
    except BrokenPipeError:
        # stdout went away (`thermocue displays | head -1`): what was asked is done or
        # cannot be shown; no traceback, and nothing more written to the closed pipe
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:
            pass
        print(f"thermocue {ns.command}: output closed early (broken pipe)", file=sys.stderr)
        return 1
    except OSError as exc:
        # A file-system failure (not a device fault: those are DisplayError and handled by
        # the subcommands): one line naming the path, exit 1.
        from experiments.errors import DisplayError
        if isinstance(exc, DisplayError) or exc.filename is None:
            raise
        from experiments.cli.paths import os_error_line
        print(f"thermocue {ns.command}: {os_error_line(exc)}", file=sys.stderr)
        return 1
    return int(status or 0)
