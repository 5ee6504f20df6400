"""`thermocue clear-fault URL`: the operator's reset of a display latched in FAULT.

A display that overheated or lost a sensor latches in FAULT (relay open, no arming), and a
session refuses to start on it. Only a person who has checked the pad and its sensors should
clear it; thermocue never does it on its own. The command asks for that confirmation (typed
``reset`` on a terminal, or ``--yes`` in a script), asks STATUS and, only if the display is
in FAULT, sends HELLO and CLEAR_FAULT on the thermocue display protocol, and prints the state
before and after. A display that is not in FAULT is left as it is (no HELLO).
"""
from __future__ import annotations

import sys


def register(sub) -> None:
    p = sub.add_parser(
        "clear-fault",
        help="operator reset of a thermocue display latched in FAULT (after checking the pad)",
        description="Reset a thermocue-protocol display (a serial device path, a pty or a "
                    "pyserial URL) that is latched in FAULT after an over-temperature or a "
                    "sensor fault. Check the pad, its thermometer and its wiring first: the "
                    "fault opened the Peltier relay to protect the participant.")
    p.add_argument("url", metavar="URL", help="the display's port, e.g. /dev/ttyACM0")
    p.add_argument("--yes", action="store_true",
                   help="confirm that the pad and its sensors were checked (no prompt)")
    p.set_defaults(func=_run)


def _run(ns) -> int:
    from experiments.errors import DisplayError, UserInputError
    from experiments.display.thermocue.driver import ThermalDisplay
    from experiments.display.registry import scheme_of

    if scheme_of(ns.url) != "serial":
        raise UserInputError(f"{ns.url}: clear-fault speaks the thermocue display protocol on a "
                             f"serial port (a device path, a pty or a pyserial URL), not "
                             f"{scheme_of(ns.url)}://")
    if not ns.yes:
        if not sys.stdin.isatty():
            raise UserInputError("not resetting without confirmation: check the pad and its "
                                 "sensors, then run again with --yes")
        try:
            answer = input(f"Have the pad and its sensors on {ns.url} been checked? "
                           f"Type 'reset' to clear the fault: ")
        except EOFError:                      # Ctrl-D at the prompt: no confirmation
            answer = ""
        if answer.strip().lower() != "reset":
            print("thermocue clear-fault: not reset", file=sys.stderr)
            return 1
    try:
        before, fault, after = ThermalDisplay.operator_reset(ns.url)
    except DisplayError as exc:
        print(f"thermocue clear-fault: {exc}", file=sys.stderr)
        return 1
    if before != "FAULT":
        print(f"{ns.url}: not in FAULT (state {before}); nothing to clear")
        return 0
    if after == "IDLE":
        print(f"{ns.url}: was FAULT ({fault or 'no code'}), now IDLE")
        return 0
    print(f"thermocue clear-fault: {ns.url}: was FAULT ({fault or 'no code'}) and is {after} "
          f"after the reset: the cause is still there (a sensor reading out of range or stuck, "
          f"the pad too hot); check the pad, its sensors and their wiring before trying again",
          file=sys.stderr)
    return 1
