"""Which checks a backend's declared capabilities offer at all.

A check needs parts of the display; a backend that declares it lacks one (``Capabilities.lacks``,
``force_sensing=False``, no ``playback`` mode) is not asked to run that check: it is listed as
not applicable, naming the missing capability, and does not fail the run. A check whose parts
are all declared runs, and fails with the reason if it cannot (never skipped): a device that
claims a watchdog and does not answer the test fails it.
"""
from __future__ import annotations

from experiments.display.base import LACKABLE

__all__ = ["NEEDS", "TITLES", "missing_capability"]

#: check name -> the capabilities it needs whole (names of ``Capabilities.lacks``, or
#: ``force_sensing`` / ``playback`` for the fields of the same meaning). The sensors check runs
#: everywhere on the thermometers a backend has (it leaves out the ones it lacks).
NEEDS = {
    "force": ("force_sensing",),
    "limits": ("raw_setpoint",),
    "overtemp": ("trip_test",),
    "watchdog": ("host_watchdog",),
    "clock": ("device_clock",),
    "tracking": ("playback",),
}
#: The titles of the checks NEEDS names (as each check states it).
TITLES = {
    "force": "force sensors at zero unloaded and answering a known weight",
    "limits": "rate limit and safe range hold when the host asks for more",
    "overtemp": "over-temperature latches a fault and opens the relay",
    "watchdog": "the watchdog cuts heating when the host goes silent",
    "clock": "device time maps to host time",
    "tracking": "tracking of the paper's profiles (1#–4#, groups A and B)",
}
_FIELDS = {"force_sensing": "no force sensors on the pad",
           "playback": "plays no profiles (no playback mode)"}


def missing_capability(check: str, caps) -> tuple[str, str] | None:
    """``(capability, what that means)`` the backend lacks for ``check``, or None."""
    for need in NEEDS.get(check, ()):
        if need == "force_sensing" and not caps.force_sensing:
            return need, _FIELDS[need]
        if need == "playback" and "playback" not in caps.modes:
            return need, _FIELDS[need]
        if need in LACKABLE and need in caps.lacks:
            return need, LACKABLE[need]
    return None
