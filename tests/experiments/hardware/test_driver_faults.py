"""Fault injection through the in-process emulator: every fault ends reported and safe."""
import numpy as np
import pytest

from experiments.errors import DisplayError
from experiments.hardware import SafetyLimits, open_display

T = np.arange(0, 4.0001, 0.01)
PROFILE = np.round(24.0 + 3.0 * np.sqrt(T / 4.0), 2)
LIMITS = SafetyLimits(min_C=18.0, max_C=40.0, max_rate_C_per_s=10.0, neutral_C=32.0)


def watch_setpoints(disp):
    """Record every setpoint the emulated firmware commands, tick by tick."""
    dev = disp.port.device
    seen = []
    step = dev.step

    def spy():
        step()
        seen.append(dev.sp)
    dev.step = spy
    return seen


def run_one(disp, fault=None, after_s=1.0):
    disp.upload_profile(T, PROFILE)
    disp.arm("playback")
    disp.sim_finger(press_after_s=0.1, hold_s=10.0)
    if fault:
        disp.sim_fault(f"{fault}@{after_s}")
    return disp.run_trial(timeout_s=15.0)


@pytest.mark.parametrize("fault, code", [
    ("overtemp", "OVER_TEMPERATURE"),
    ("sensor_range", "SENSOR_FAILURE"),
    ("stuck_sensor", "SENSOR_STUCK"),
    ("stall", "LINK_TIMEOUT"),
])
def test_every_faulted_trial_is_reported(fault, code):
    with open_display("emulator://?clock=virtual&seed=11", limits=LIMITS) as d:
        seen = watch_setpoints(d)
        rec = run_one(d, fault, after_s=2.0)
        assert rec.status == "fault" and rec.fault_code == code, rec
        assert rec.fault_message
        dev = d.port.device
        if fault == "stall":
            assert dev.stalled                 # firmware hung ...
            for _ in range(20):
                dev.step()
            assert dev.plant.current == 0.0    # ... and its hardware watchdog opened the relay
        else:
            assert dev.state.name == "FAULT" and dev.sp == LIMITS.neutral_C
            assert d.status().state == "FAULT"
            d.abort()                          # the session acknowledges the fault
            assert d.status().last_fault == code
        assert min(seen) >= LIMITS.min_C and max(seen) <= LIMITS.max_C


def test_disconnect_mid_trial_is_reported_and_the_device_goes_neutral():
    with open_display("emulator://?clock=virtual&seed=12", limits=LIMITS) as d:
        seen = watch_setpoints(d)
        rec = run_one(d, "disconnect", after_s=2.5)
        assert rec.status == "fault" and rec.fault_code == "LINK_LOST"
        with pytest.raises(DisplayError):
            d.status()
        dev = d.port.device
        for _ in range(12):                    # 120 ms more of device life without its host
            dev.step()
        assert dev.state.name == "IDLE" and dev.last_fault == 20      # WATCHDOG
        for _ in range(200):
            dev.step()
        assert dev.sp == LIMITS.neutral_C
        assert min(seen) >= LIMITS.min_C and max(seen) <= LIMITS.max_C


def test_a_noisy_line_costs_frames_not_trials():
    url = "emulator://?clock=virtual&seed=13&faults=drop=0.00005,corrupt=0.00005,garbage=0.02"
    with open_display(url, limits=LIMITS) as d:
        seen = watch_setpoints(d)
        recs = [run_one(d) for _ in range(3)]
        for rec in recs:
            assert rec.status == "ok", rec
            assert rec.tracking_rms_C < 0.05
        assert sum(r.frames_lost for r in recs) > 0            # the faults did bite ...
        assert sum(r.bad_frames for r in recs) > 0             # ... and were caught by the CRC
        assert min(seen) >= LIMITS.min_C and max(seen) <= LIMITS.max_C


def test_heavy_loss_marks_the_trial():
    url = "emulator://?clock=virtual&seed=14&faults=drop=0.002"
    with open_display(url, limits=LIMITS, retries=8) as d:
        rec = run_one(d)
        assert rec.status == "fault" and rec.fault_code == "TELEMETRY_LOSS"
        assert rec.frames_lost > 0.01 * (rec.frames + rec.frames_lost)


def test_delayed_bytes_still_make_a_trial():
    with open_display("emulator://?clock=virtual&seed=15&faults=delay=0.05", limits=LIMITS) as d:
        rec = run_one(d)
        assert rec.status == "ok" and rec.frames_lost == 0
