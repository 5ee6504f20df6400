"""Which checks run is decided by the backend's declared capabilities: a check they rule out is
not applicable (not run, named with the capability missing, not failing the run); a check whose
parts are declared runs and fails with the reason when it cannot."""
from __future__ import annotations


import pytest

from experiments.display import open_display
from experiments.display.base import Capabilities
from experiments.qualification.bench import Bench
from experiments.qualification.report import render_report
from experiments.qualification.runner import run_checks
from experiments.qualification.safety_checks import check_limits, check_overtemp, check_watchdog
from experiments.qualification.sensors import check_force


def test_the_tcs2_emulator_declares_what_it_lacks_and_those_checks_are_not_run(tmp_path):
    d = open_display("tcs2://emulator")
    try:
        results = run_checks(Bench(d, "tcs2://emulator", tmp_path),
                             [(check_force, 1), (check_limits, 1), (check_overtemp, 1),
                              (check_watchdog, 1)])
    finally:
        d.close()
    assert [(r.name, r.not_applicable, r.failed) for r in results] == [
        ("force", "force_sensing", False), ("limits", "raw_setpoint", False),
        ("overtemp", "trip_test", False), ("watchdog", "host_watchdog", False)]
    text = render_report("tcs2://emulator", {}, results)
    # nothing ran: that is no pass
    assert "result: **FAIL** (0 of 0 checks passed; 4 not applicable to this backend, not run)" in text
    assert "- **watchdog** (the watchdog cuts heating when the host goes silent): not applicable " \
           "to this backend: it lacks host_watchdog (no host-silence watchdog the host can test)." in text


class _Claims:
    """A display that declares every part of the thermocue display (a plugin that says nothing
    lacking) and offers none of the extras the safety checks use."""

    capabilities = Capabilities(contact_detection="force", force_sensing=True, telemetry_hz=100.0,
                                max_profile_points=10, min_profile_step_s=0.01,
                                safe_range_C=(10.0, 42.0), max_rate_C_per_s=10.0)
    info = None


def test_a_check_whose_parts_are_declared_and_that_cannot_run_fails_with_the_reason(tmp_path):
    (res,) = run_checks(Bench(_Claims(), "x://", tmp_path), [(check_watchdog, 1)])
    assert res.failed and not res.not_applicable
    assert res.reason.startswith("cannot run here:"), res.reason
    assert "**FAIL**" in render_report("x://", {}, [res])


def test_lacks_takes_only_known_parts():
    with pytest.raises(ValueError, match="Capabilities.lacks"):
        Capabilities(contact_detection="force", force_sensing=True, telemetry_hz=1.0,
                     max_profile_points=1, min_profile_step_s=0.01, safe_range_C=(10, 42),
                     max_rate_C_per_s=1.0, lacks=("thermometer",))
