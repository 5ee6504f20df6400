"""`thermocue emulator`: serve the display protocol on a pseudo-terminal, print its path."""
from __future__ import annotations


def register(sub) -> None:
    p = sub.add_parser(
        "emulator",
        help="serve the emulated thermal display on a pty (prints the path; SIGINT/SIGTERM stops)",
        description="Serve the emulated thermal display on a real pseudo-terminal. The first line "
                    "printed is the pty's path; open it with --display PATH. Runs until SIGINT "
                    "or SIGTERM.")
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
    p.set_defaults(func=_run)


def _run(ns) -> int:
    from experiments.hardware.faults import parse_faults
    from experiments.hardware.pty_server import serve
    specs = parse_faults(ns.faults, where="--faults")          # UserInputError -> exit 2
    if not ns.link:
        return serve(faults=specs, clock=ns.clock, seed=ns.seed, link=None, log=ns.log,
                     sim=not ns.no_sim)
    with hold_link(ns.link):
        return serve(faults=specs, clock=ns.clock, seed=ns.seed, link=ns.link, log=ns.log,
                     sim=not ns.no_sim)


def _lock_path(link: str) -> str:
    return f"{link}.lock"


class hold_link:
    """Claim ``--link PATH`` for this emulator's lifetime (``PATH.lock``, an exclusive flock).

    A second emulator given the same PATH while the first runs is refused (the old behaviour:
    it silently replaced the first one's link and deleted it on exit). The lock dies with its
    process, so a link left by a killed emulator is simply replaced.

    Raises
    ------
    UserInputError
        ``--link PATH: expected a path no running emulator holds, got the link of process N``;
        or a path that exists and is not a symbolic link.
    """

    def __init__(self, link: str):
        self.link = link
        self.fd = None

    def __enter__(self):
        import fcntl
        import os

        from experiments.errors import UserInputError
        if os.path.lexists(self.link) and not os.path.islink(self.link):
            raise UserInputError(f"--link {self.link}: expected a new path or a symbolic link, "
                                 f"got an existing file")
        fd = os.open(_lock_path(self.link), os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(fd, 32).decode(errors="replace").strip() or "?"
            os.close(fd)
            raise UserInputError(f"--link {self.link}: expected a path no running emulator holds, "
                                 f"got the link of emulator process {holder} (stop it, or choose "
                                 f"another --link)") from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self.fd = fd
        return self

    def __exit__(self, *exc):
        import os
        try:
            os.unlink(_lock_path(self.link))
        except OSError:
            pass
        os.close(self.fd)
        return False
