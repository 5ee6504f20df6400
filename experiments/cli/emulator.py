"""`thermocue emulator`: serve the display protocol on a pseudo-terminal, print its path."""
from __future__ import annotations


def register(sub) -> None:
    p = sub.add_parser(
        "emulator",
        help="serve the emulated thermal display on a pty (prints the path; SIGINT/SIGTERM stops)",
        description="Serve the emulated thermal display on a real pseudo-terminal. The first line "
                    "printed is the pty's path; open it with --display PATH. Runs until SIGINT "
                    "or SIGTERM.")
    p.add_argument("--link", metavar="PATH", help="also make PATH a symbolic link to the pty")
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
    p.set_defaults(func=_run)


def _run(ns) -> int:
    from experiments.hardware.faults import parse_faults
    from experiments.hardware.pty_server import serve
    specs = parse_faults(ns.faults, where="--faults")          # UserInputError -> exit 2
    return serve(faults=specs, clock=ns.clock, seed=ns.seed, link=ns.link, log=ns.log,
                 sim=not ns.no_sim)
