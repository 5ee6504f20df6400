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


def main(args: list[str] | None = None) -> int:
    """Parse ``args`` (default ``sys.argv[1:]``), run the subcommand, return the exit status."""
    parser = build_parser()
    ns = parser.parse_args(args)
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
