"""The conformance suite's hardware-safe subset: the checks of ``thermocue check``, written
once in :mod:`experiments.qualification`, on every conformance backend (the Python emulator on
a real clock and the C firmware's sim image under QEMU).

The host-loss test (the watchdog) is ``check_watchdog`` here; the over-temperature check uses
the protocol's SET_TRIP, so it needs no emulator-only fault; both backends pass every check.
"""
from __future__ import annotations

import pytest

from experiments.qualification.bench import Bench
from experiments.qualification.clock import check_clock
from experiments.qualification.safety_checks import check_limits, check_overtemp, check_watchdog
from experiments.qualification.sensors import check_force, check_sensors
from experiments.qualification.thermal import check_neutral, check_step

HARDWARE_SAFE = (check_sensors, check_neutral, check_force, check_limits, check_overtemp,
                 check_watchdog, check_step, check_clock)


#: The checks that hold the pad for seconds (a settle, two steps): end-to-end, with the slow tests.
SLOW = (check_neutral, check_step)


@pytest.mark.parametrize("check", [pytest.param(c, marks=pytest.mark.slow) if c in SLOW else c
                                   for c in HARDWARE_SAFE], ids=lambda fn: fn.__name__)
def test_qualification_check(display, check, backend, tmp_path):
    res = check(Bench(display, backend, tmp_path))
    assert res.passed, f"{res.name}: {res.reason} (measured: {res.measured})"
