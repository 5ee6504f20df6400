"""The ``thermocue`` command line (also ``python -m experiments``).

Thin over the library: each subcommand lives in its own module of this package
and exposes ``register(subparsers)`` (adds its parser, sets ``func``) and keeps
heavy imports inside the function that runs it, so ``thermocue --help`` stays fast.

Exit status: 0 on success, 2 on bad input (one line naming the file and the
field, no traceback), 1 otherwise.
"""
from __future__ import annotations

import argparse
import importlib
import sys

__all__ = ["main", "SUBCOMMANDS", "USER_ERRORS"]

#: Subcommand name -> module (in this package) that registers it.
SUBCOMMANDS = {
    "run": "run",
    "resume": "resume",
    "emulator": "emulator",
    "analyze": "analyze",
    "reproduce": "reproduce",
    "bench": "bench",
    "power": "power",
    "calibrate": "calibrate",
    "explain": "explain",
}


def _user_errors():
    """Exception classes that mean "bad input": reported in one line, exit 2."""
    from experiments.errors import UserInputError
    classes = [UserInputError]
    try:
        from participants_schema import ParticipantError
        classes.append(ParticipantError)
    except ImportError:  # pragma: no cover - package always present when installed
        pass
    try:
        from stimuli import ModelInputError
        classes.append(ModelInputError)
    except ImportError:  # pragma: no cover
        pass
    try:
        from analysis import LogError
        classes.append(LogError)
    except ImportError:  # pragma: no cover
        pass
    return tuple(classes)


USER_ERRORS = None  # filled lazily by main()


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="thermocue",
        description="Thermal-tactile roughness perception: model, display, sessions, analysis.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, module in SUBCOMMANDS.items():
        mod = importlib.import_module(f"{__name__}.{module}")
        mod.register(sub)
    return parser


def main(args: list[str] | None = None) -> int:
    """Parse ``args`` (default ``sys.argv[1:]``), run the subcommand, return the exit status."""
    parser = build_parser()
    ns = parser.parse_args(args)
    user_errors = _user_errors()
    try:
        status = ns.func(ns)
    except user_errors as exc:
        print(f"thermocue {ns.command}: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"thermocue {ns.command}: interrupted", file=sys.stderr)
        return 1
    return int(status or 0)
