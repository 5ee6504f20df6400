"""`thermocue emulator`: serve the display protocol on a pseudo-terminal, print its path.

The options live in :mod:`experiments.emulators.options`, the server in
:mod:`experiments.emulators.pty_server` (the emulators never import the CLI); this module only
registers the sub-command. ``--model tcs2`` serves the QST.Lab TCS II emulator instead
(:func:`~experiments.emulators.pty_server.run_tcs2`; open it with ``--display tcs2://PATH``).
"""
from __future__ import annotations


def register(sub) -> None:
    from experiments.emulators.options import add_arguments   # stdlib only: fast
    p = sub.add_parser(
        "emulator",
        help="serve the emulated thermal display on a pty (prints the path; SIGINT/SIGTERM stops)",
        description="Serve the emulated thermal display on a real pseudo-terminal. The first line "
                    "printed is the pty's path; open it with --display PATH (--model tcs2: "
                    "--display tcs2://PATH). Runs until SIGINT or SIGTERM.")
    add_arguments(p)
    p.add_argument("--model", choices=("thermocue", "tcs2"), default="thermocue",
                   help="thermocue: the thermocue display (default); tcs2: a QST.Lab TCS II "
                        "(its ASCII protocol; --faults as in docs/tcs2.md)")
    p.add_argument("--speed", type=float, default=1.0, metavar="K",
                   help="--model tcs2 only: run K times faster than wall time (default 1)")
    p.set_defaults(func=_run)


def _run(ns) -> int:
    if ns.model == "tcs2":
        from experiments.emulators.pty_server import run_tcs2
        return run_tcs2(ns)   # UserInputError (bad --faults, --clock virtual) -> exit 2
    if ns.speed != 1.0:
        from experiments.errors import UserInputError
        raise UserInputError(f"--speed: expected it only with --model tcs2 (the thermocue "
                             f"emulator has --clock virtual), got {ns.speed:g}")
    from experiments.emulators.pty_server import run
    return run(ns)          # UserInputError (bad --faults, --link held) -> exit 2
