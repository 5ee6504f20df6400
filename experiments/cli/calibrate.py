"""`thermocue calibrate` (placeholder until its issue lands; the owner replaces this module)."""
from __future__ import annotations


def register(sub) -> None:
    p = sub.add_parser("calibrate", help="(not yet implemented)")
    p.set_defaults(func=_run)


def _run(ns) -> int:
    raise SystemExit("thermocue calibrate: not implemented yet")
