"""`thermocue emulator`: serve the display protocol on a pseudo-terminal, print its path.

The options live in :mod:`experiments.hardware.emulator_options`, the server in
:mod:`experiments.hardware.pty_server` (hardware never imports the CLI); this module only
registers the sub-command.
"""
from __future__ import annotations


def register(sub) -> None:
    from experiments.hardware.emulator_options import add_arguments   # stdlib only: fast
    p = sub.add_parser(
        "emulator",
        help="serve the emulated thermal display on a pty (prints the path; SIGINT/SIGTERM stops)",
        description="Serve the emulated thermal display on a real pseudo-terminal. The first line "
                    "printed is the pty's path; open it with --display PATH. Runs until SIGINT "
                    "or SIGTERM.")
    add_arguments(p)
    p.set_defaults(func=_run)


def _run(ns) -> int:
    from experiments.hardware.pty_server import run
    return run(ns)          # UserInputError (bad --faults, --link held) -> exit 2
