"""``thermocue tcs2 probe PORT [--capture FILE]``: a QST.Lab TCS II's bring-up as a command.

Runs the steps of ``docs/tcs2.md`` ("Set-up on a real device") on the port with a protocol's
limits (default the packaged ``roughness_recognition_tcs2``): identify, set and read back the
maximum and the neutral, read the temperatures and the errors, one line per step; exit 0 when
all passed, 1 when one failed (the line says which and why). ``--capture FILE`` writes every
byte both ways with time stamps (JSON lines), which a lab can send so that its device's reply
formats are checked against the host's (:mod:`experiments.display.tcs2.capture`).
"""
from __future__ import annotations


def register(sub) -> None:
    p = sub.add_parser("tcs2", help="QST.Lab TCS II tools (probe: the bring-up)",
                       description="QST.Lab TCS II tools.")
    tsub = p.add_subparsers(dest="tcs2_command", metavar="COMMAND", required=True)
    q = tsub.add_parser("probe", help="run the TCS II bring-up on PORT and report each step",
                        description="Identify the TCS II on PORT, set and read back its maximum "
                                    "and neutral, read its temperatures and errors (the probe "
                                    "in its holder, not on skin); one line per step.")
    q.add_argument("port", metavar="PORT", help="the device's port (/dev/ttyACM0, COM3, a pty, "
                                                "or a tcs2:// URL)")
    q.add_argument("--capture", metavar="FILE", default=None,
                   help="write every byte both ways with time stamps to FILE (JSON lines)")
    q.add_argument("--protocol", metavar="PROTOCOL", default="roughness_recognition_tcs2",
                   help="the protocol whose limits (maximum, neutral, range) are used "
                        "(default: roughness_recognition_tcs2)")
    q.set_defaults(func=_probe)


def _probe(ns) -> int:
    from experiments.display.tcs2.probe import probe
    from experiments.protocol import load_protocol

    limits = load_protocol(ns.protocol).display.safety_limits()
    ok = probe(ns.port, limits, capture=ns.capture)
    if ns.capture:
        print(f"capture: {ns.capture}")
    return 0 if ok else 1
