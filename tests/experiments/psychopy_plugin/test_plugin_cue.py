"""The routine-level cue (:mod:`experiments.psychopy_plugin.cue`) and its profile sources.

On the in-process emulator (real clock): the profile comes from the protocol for the
participant or from a file, each trigger starts it as documented, and the data columns are those
the Builder component writes.
"""
from __future__ import annotations

import time

import numpy as np
import pytest

from _plugin_helpers import P01, unexplained_refusal
from experiments.errors import SafetyLimitError, UserInputError
from experiments.psychopy_plugin.profiles import file_profile, protocol_profile



@pytest.fixture(scope="module")
def device():
    from experiments.psychopy_plugin.device import ThermalCueDevice
    d = ThermalCueDevice(url="emulator://?seed=3", protocol="roughness_recognition")
    yield d
    d.close()


def _jittered(cols, name, device) -> bool:
    """Whether the in-process emulator's clock ran late enough to make the map refuse (its tick
    thread shares the GIL with the clock burst: on a loaded host a tick runs a few ms late, and
    replies carry the tick before); then the row says so, maps nothing, and the emulator's own
    worst lateness explains the reason (``_plugin_helpers.unexplained_refusal``). The
    separate-process emulator keeps its ticks (test_plugin_timing, test_plugin_builder)."""
    status = cols[f"{name}.clock_status"]
    if status == "mapped":
        return False
    max_late_ms = device.display.port.core.max_late_s * 1e3
    assert status.startswith("unmapped: ") and unexplained_refusal(
        status.removeprefix("unmapped: "), max_late_ms) is None, (status, max_late_ms)
    assert cols[f"{name}.contact_routine_s"] == "" and cols[f"{name}.clock_uncertainty_s"] == ""
    return True


def _run(cue, clock, until_contact=True, timeout_s=10.0):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        cue.poll()
        if until_contact and cue.touched:
            return
        time.sleep(1 / 60)


def test_protocol_profile_is_the_sessions_profile_for_the_participant():
    from experiments.protocol import load_protocol
    from experiments.session.setup import simulated_target_profile
    from participants_schema import Participant
    proto = load_protocol("roughness_recognition")
    prof = protocol_profile(proto, P01, 3)
    # P01: 680 µm, group A (< 800 µm); the protocol simulates group A at 650 µm
    session = simulated_target_profile(proto, Participant(id="P01", measured_skin_m=680e-6),
                                       "A", 680, 3, 50.0)
    assert prof.parameters["group"] == "A"
    np.testing.assert_array_equal(prof.target_C, np.asarray(session.temperature))
    assert prof.duration_s == pytest.approx(proto.simulation.duration_s)
    assert prof.source == "protocol:roughness_recognition sample 3 participant P01"


def test_unknown_sample_names_the_field():
    with pytest.raises(UserInputError, match=r"roughness_recognition.toml: samples.id: expected one of 1, 2, 3, 4, got 7"):
        protocol_profile("roughness_recognition", P01, 7)


def test_profile_file_and_its_errors(tmp_path):
    good = tmp_path / "cue.csv"
    good.write_text("time_s,target_C\n0,32\n0.01,31.9\n0.02,31.8\n")
    prof = file_profile(good)
    assert prof.target_C.tolist() == [32.0, 31.9, 31.8] and prof.duration_s == pytest.approx(0.02)
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,temp_C\n0,32\n")
    with pytest.raises(UserInputError, match=r"bad.csv: target_C: expected a column named 'target_C'"):
        file_profile(bad)
    bad.write_text("time_s,target_C\n0,32\n0.01,warm\n")
    with pytest.raises(UserInputError, match=r"bad.csv: row 3: target_C: expected a number, got 'warm'"):
        file_profile(bad)
    with pytest.raises(OSError, match="missing.csv"):
        file_profile(tmp_path / "missing.csv")


def test_contact_trigger_writes_the_component_columns(device):
    from psychopy import core

    from experiments.psychopy_plugin import ThermalCue
    cue = ThermalCue("thermal", device, participant=str(P01), simulate_touch=True,
                     touch_after_s=0.2)
    clock = core.Clock()
    cue.prepare(sample=1)
    cue.start(clock)
    _run(cue, clock)
    assert cue.touched and cue.contact.value is True
    time.sleep(0.3)
    cols = cue.end(clock)
    assert cols["thermal.status"] == "aborted" and cols["thermal.trigger"] == "contact force"
    assert cols["thermal.force_threshold_N"] == 2.0
    assert cols["thermal.contact_device_s"] == cue.contact.device_time_s
    assert cols["thermal.tracking_rms_C"] < 0.1
    if _jittered(cols, "thermal", device):
        return
    assert cols["thermal.armed_routine_s"] < cols["thermal.contact_routine_s"] < clock.getTime()
    assert 0 <= cols["thermal.clock_uncertainty_s"] < 0.01    # the 1 ms claim: test_plugin_timing
    assert cols["thermal.clock_status"] == "mapped" and abs(cols["thermal.clock_drift_ppm"]) < 2000
    # no fault: empty, never the text "None" PsychoPy would write for None
    assert cols["thermal.fault_code"] == "" and cols["thermal.fault_message"] == ""
    assert None not in cols.values()
    # the duration on PsychoPy's clock: contact to the routine's end at most
    assert 0 < cols["thermal.contact_duration_s"] <= clock.getTime() - cols["thermal.contact_routine_s"]
    assert device.display.status().state == "IDLE"


def test_a_virtual_clock_emulator_is_unmapped_with_the_reason_not_a_number():
    """The emulator on a virtual clock runs its device time faster than real time: the map's
    drift is implausible, so no time is mapped, the reason is in ``clock_status`` and the
    device's own duration is kept under a name that says whose clock it is."""
    from psychopy import core

    from experiments.psychopy_plugin import ThermalCue
    from experiments.psychopy_plugin.device import ThermalCueDevice
    dev = ThermalCueDevice(url="emulator://?clock=virtual&seed=3", protocol="roughness_recognition")
    try:
        cue = ThermalCue("thermal", dev, participant=str(P01), simulate_touch=True,
                         touch_after_s=0.2)
        clock = core.Clock()
        cue.prepare(sample=1)
        cue.start(clock)
        _run(cue, clock)
        assert cue.touched
        time.sleep(0.3)
        cols = cue.end(clock)
    finally:
        dev.close()
    status = cols["thermal.clock_status"]
    assert status.startswith("unmapped: "), status
    # the drift is what a quiet machine reports; a loaded one may first find a burst's round
    # trips too far apart: either way a stated reason and no mapped time
    assert ("ppm" in status or "do not agree" in status or "outside the map" in status
            or "round trips disagree" in status), status
    for k in ("contact_routine_s", "contact_global_s", "contact_duration_s", "clock_offset_s",
              "clock_drift_ppm", "clock_uncertainty_s"):
        assert cols[f"thermal.{k}"] == "", (k, cols[f"thermal.{k}"])
    assert cols["thermal.contact_duration_device_s"] > 0
    assert np.isnan(cue.contact.t)                  # the response's PsychoPy time: not a number


def test_routine_start_trigger_starts_with_a_resting_finger(device, tmp_path):
    from psychopy import core

    from experiments.psychopy_plugin import ThermalCue
    f = tmp_path / "cue.csv"
    t = np.arange(0, 1.0001, 0.01)
    f.write_text("time_s,target_C\n" + "".join(f"{a:.2f},{32 - a:.2f}\n" for a in t))
    cue = ThermalCue("cue", device, source="profile file", profile_file=str(f),
                     trigger="routine start", simulate_touch=True)
    clock = core.Clock()
    cue.prepare()
    deadline = time.monotonic() + 5.0       # the pad back at neutral = the profile's first sample
    while abs(device.display.status().contact_C - 32.0) > 0.03 and time.monotonic() < deadline:
        time.sleep(0.05)
    cue.start(clock)
    _run(cue, clock, until_contact=False, timeout_s=3.0)
    assert cue.ended                                  # the whole 1 s profile played
    cols = cue.end(clock)
    assert cols["cue.force_threshold_N"] == 0.01
    assert (cols["cue.status"], cols["cue.end_reason"]) == ("ok", "complete")
    # the pad is ready after 0.1 s at its first sample; the resting finger presses at once
    if _jittered(cols, "cue", device):
        return
    assert cols["cue.contact_routine_s"] - cols["cue.armed_routine_s"] < 0.25


def test_a_profile_outside_the_protocol_limits_is_refused_before_upload(device, tmp_path):
    from experiments.psychopy_plugin import ThermalCue
    f = tmp_path / "hot.csv"
    f.write_text("time_s,target_C\n0,32\n0.01,32\n0.02,43\n")
    cue = ThermalCue("cue", device, source="profile file", profile_file=str(f))
    with pytest.raises(SafetyLimitError, match="42"):
        cue.prepare()


def test_a_routine_that_ended_before_the_cue_started(device):
    from psychopy import core

    from experiments.psychopy_plugin import ThermalCue
    cue = ThermalCue("thermal", device, participant=str(P01))
    cue.prepare(sample=2)
    cols = cue.end(core.Clock())
    assert cols["thermal.status"] == "not_started"
    assert {v for k, v in cols.items() if k != "thermal.status"} == {""}      # empty, not "None"
    assert len(cols) == len(__import__("experiments.psychopy_plugin.cue", fromlist=["COLUMNS"]).COLUMNS)


@pytest.mark.slow   # end to end; `./scripts/test -m slow` (CI) runs it
def test_a_device_fault_during_the_cue_ends_it_and_is_recorded(tmp_path):
    from psychopy import core

    from experiments.psychopy_plugin import ThermalCue
    from experiments.psychopy_plugin.device import ThermalCueDevice
    dev = ThermalCueDevice(url="emulator://?seed=5", protocol="roughness_recognition")
    try:
        cue = ThermalCue("thermal", dev, participant=str(P01), simulate_touch=True,
                         touch_after_s=0.1)
        clock = core.Clock()
        cue.prepare(sample=1)
        cue.start(clock)
        _run(cue, clock)
        assert cue.touched
        dev.display.sim_fault("overtemp")          # the Peltier driver sticks at full heating
        _run(cue, clock, until_contact=False, timeout_s=5.0)
        assert cue.ended
        cols = cue.end(clock)
        assert (cols["thermal.status"], cols["thermal.fault_code"]) == ("fault", "OVER_TEMPERATURE")
        assert dev.display.status().state == "FAULT"     # latched: the next arm is refused
    finally:
        dev.close()


@pytest.mark.slow   # end to end; `./scripts/test -m slow` (CI) runs it
def test_a_lost_link_ends_the_cue_without_an_exception(tmp_path):
    from psychopy import core

    from experiments.psychopy_plugin import ThermalCue
    from experiments.psychopy_plugin.device import ThermalCueDevice
    dev = ThermalCueDevice(url="emulator://?seed=6", protocol="roughness_recognition")
    try:
        cue = ThermalCue("thermal", dev, participant=str(P01), simulate_touch=True,
                         touch_after_s=0.1)
        clock = core.Clock()
        cue.prepare(sample=1)
        cue.start(clock)
        _run(cue, clock)
        dev.display.sim_fault("disconnect@0.3")       # 0.3 s from now, after its reply
        _run(cue, clock, until_contact=False, timeout_s=5.0)
        assert cue.ended
        cols = cue.end(clock)
        assert cols["thermal.status"] == "fault"
        assert cols["thermal.fault_code"] in ("LINK_LOST", "LINK_TIMEOUT")
    finally:
        dev.close()
