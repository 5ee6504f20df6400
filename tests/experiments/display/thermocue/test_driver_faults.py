"""Fault injection through the in-process emulator: every fault ends reported and safe."""
import json
import zlib

import numpy as np
import pytest

from experiments.errors import DisplayError
from experiments.display import SafetyLimits, open_display

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
            assert d.status().fault == code
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
    # the loss starts once the trial is armed: an upload chunk (~800 bytes) gets through a
    # 0.2 % per-byte loss only one time in five, and the upload is not what is tested here
    with open_display("emulator://?clock=virtual&seed=14", limits=LIMITS, retries=8) as d:
        rec = run_one(d, "drop=0.002", after_s=0.0)
        assert rec.status == "fault" and rec.fault_code == "TELEMETRY_LOSS"
        assert rec.frames_lost > 0.01 * (rec.frames + rec.frames_lost)


def test_delayed_bytes_still_make_a_trial():
    with open_display("emulator://?clock=virtual&seed=15&faults=delay=0.05", limits=LIMITS) as d:
        rec = run_one(d)
        assert rec.status == "ok" and rec.frames_lost == 0


@pytest.mark.parametrize("seed", range(6))
def test_corrupted_host_bytes_do_not_trip_the_watchdog(tmp_path, seed):
    # audit 34: one flipped bit in a heartbeat's length stalled the device's parser for
    # ~570 ms of heartbeats; with corrupt=0.001 whole sessions stopped on WATCHDOG (seeds 2, 3)
    log = tmp_path / "emu.jsonl"
    url = f"emulator://?clock=virtual&seed={seed}&faults=corrupt=0.001&log={log}"
    with open_display(url, limits=LIMITS, retries=20) as d:      # an 817-byte upload chunk
        recs = [run_one(d) for _ in range(3)]                      # gets through 44 % of tries
    assert all(r.fault_code in (None, "TELEMETRY_LOSS") for r in recs), recs
    assert sum(r.bad_frames for r in recs) > 0                  # the corruption did bite
    events = [json.loads(line)["event"] for line in log.read_text().splitlines()]
    assert "watchdog" not in events and events.count("state") >= 3 * 3


def test_a_careless_host_on_a_bad_line_never_gets_an_unsafe_setpoint():
    # the host's own checks bypassed: raw commands with out-of-range temperatures and jumps,
    # over a line with garbage, corruption and delay. The firmware must clamp every setpoint
    # to the limits and slew at the rate limits, whatever arrives.
    from experiments.display.thermocue import messages as m
    from experiments.emulators.thermocue.device import HARD_RATE_C_PER_S, TICK_US
    from experiments.display.thermocue.messages import Cmd
    url = ("emulator://?clock=virtual&seed=21"
           "&faults=garbage=0.05,corrupt=0.0003,delay=0.02")
    with open_display(url, limits=LIMITS, retries=8) as d:
        dev = d.port.device
        ticks = []
        step = dev.step

        def spy():
            before = dev.state.name
            step()
            ticks.append((before, dev.state.name, dev.sp))
        dev.step = spy
        raw = d.link.transact                                  # no SafetyLimits on this path
        assert m.CENTI.unpack(raw(Cmd.SET_NEUTRAL, m.CENTI.pack(6000)))[0] == 4000
        d.wait(1.0)                                        # slews from 32 to 40
        assert m.CENTI.unpack(raw(Cmd.SET_NEUTRAL, m.CENTI.pack(500)))[0] == 1800
        d.wait(2.5)                                        # ... and down to 18
        # a profile of 5 and 60 °C steps, 0.5 s each: out of range, and jumps of 55 °C
        vals = np.where((np.arange(400) // 50) % 2 == 0, 5.0, 60.0)
        q = np.round(vals * 100).astype("<i2")
        rawb = q.tobytes()
        raw(Cmd.UPLOAD_BEGIN, m.UPLOAD_BEGIN.pack(len(q), 10_000))
        for off in range(0, len(q), 200):
            body = rawb[2 * off:2 * (off + 200)]
            raw(Cmd.UPLOAD_CHUNK, m.UPLOAD_CHUNK_HEAD.pack(off, len(body) // 2) + body)
        ack = m.COMMIT_ACK.unpack(raw(Cmd.UPLOAD_COMMIT, m.COMMIT.pack(zlib.crc32(rawb))))
        assert ack[2] == 400                               # every sample clamped
        raw(Cmd.ARM, m.ARM.pack(0, 200, 10_000))
        d.sim_finger(press_after_s=0.1, hold_s=10.0)
        d.wait(6.0)
        assert m.Status.decode(raw(Cmd.STATUS)).trials == 1
    before, after, sp = zip(*ticks)
    sp = np.array(sp)
    steps = np.abs(np.diff(np.r_[LIMITS.neutral_C, sp]))
    playing = np.array([b == "PLAYING" or a == "PLAYING" for b, a in zip(before, after)])
    assert playing.sum() >= 300 and sp.max() == LIMITS.max_C and sp.min() == LIMITS.min_C
    assert LIMITS.min_C <= sp.min() and sp.max() <= LIMITS.max_C
    tick = TICK_US * 1e-6
    assert steps.max() <= HARD_RATE_C_PER_S * tick + 1e-9             # 1 °C a tick, ever
    assert steps[~playing].max() <= LIMITS.max_rate_C_per_s * tick + 1e-9   # slews: 0.1 °C
    assert steps[playing].max() > LIMITS.max_rate_C_per_s * tick       # the jumps were there
    # ... and over any 0.1 s window (the host's rate measure) no setpoint range beyond the rate
    # limit, playback included (one 0.01 °C resolution step of slack, as the host allows)
    from experiments.emulators.thermocue.device import RATE_WINDOW_TICKS
    track = np.r_[LIMITS.neutral_C, sp]
    windows = np.lib.stride_tricks.sliding_window_view(track, RATE_WINDOW_TICKS + 1)
    spans = windows.max(axis=1) - windows.min(axis=1)
    assert spans.max() <= LIMITS.max_rate_C_per_s * RATE_WINDOW_TICKS * tick + 0.01 + 1e-9
