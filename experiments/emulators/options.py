"""The options of ``thermocue emulator`` and ``python -m experiments.emulators.pty_server``.

Standard library only, so that the command line can offer them without importing the emulator
(``thermocue --help`` stays fast); :func:`experiments.emulators.pty_server.run` acts on them.
"""
from __future__ import annotations

__all__ = ["add_arguments"]


def add_arguments(p) -> None:
    """The options of ``thermocue emulator`` (and ``python -m experiments.emulators.pty_server``)."""
    p.add_argument("--link", metavar="PATH",
                   help="also make PATH a symbolic link to the pty (refused while another running "
                        "emulator holds PATH)")
    p.add_argument("--faults", metavar="SPEC", default=None,
                   help="fault injection, e.g. 'drop=0.001,overtemp@30' (see docs/display-protocol.md)")
    p.add_argument("--clock", choices=("real", "virtual"), default="real",
                   help="real: 10 ms ticks of wall time; virtual: as fast as the host reads "
                        "during trials (default: real)")
    p.add_argument("--seed", type=int, default=0, help="noise and fault seed (default 0)")
    p.add_argument("--log", metavar="PATH", default=None,
                   help="append state changes, faults and watchdog trips as JSON lines")
    p.add_argument("--no-sim", action="store_true",
                   help="refuse the emulator-only 'sim' commands, like a real device")
