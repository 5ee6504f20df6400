"""The compiled tick (issue 11, Speed): Device.step's steady ticks in C, the same doubles.

``experiments/hardware/_tick.c`` transcribes the ticks that change no state and hands every other
tick to the Python ``Device.step`` (the reference). Each scenario below runs twice on the same
seed, once through the compiled read loop and once through Python's ticks alone, and compares
after every read the frames handed over and the whole emulated state -- device, pad plant,
finger skin (its state vectors byte for byte), rate window and both noise streams' positions.
Floats are compared by their bits (``float.hex``), so -0.0 and 0.0 differ too.
"""
from __future__ import annotations

import itertools

import numpy as np
import pytest
import serial
from hypothesis import given, settings
from hypothesis import strategies as st

from experiments.hardware import compiled_tick
from experiments.hardware import messages as m
from experiments.hardware.device import Device
from experiments.hardware.driver import ThermalDisplay
from experiments.hardware.framing import encode_frame
from experiments.hardware.pad_physics import PadParams, normal_stream
from experiments.hardware.safety import SafetyLimits


def test_the_extension_is_built():
    # without it sessions still run, on Python's ticks, about 3 times slower
    assert compiled_tick.AVAILABLE and compiled_tick.enabled, compiled_tick.why_not


def test_the_c_files_numbers_are_checked_against_pythons():
    from experiments.hardware import _tick
    from experiments.hardware.framing import Frame
    args = (Frame, np.dot, compiled_tick.ORIGINALS)
    try:
        with pytest.raises(ValueError, match="OVERTEMP_C is 44.8, Python's is 44.9"):
            _tick.configure(*args, {**compiled_tick.CONSTANTS, "OVERTEMP_C": 44.9})
        with pytest.raises(ValueError, match="expected 27 constants"):
            _tick.configure(*args, {k: v for k, v in compiled_tick.CONSTANTS.items() if k != "KELVIN"})
    finally:
        _tick.configure(Frame, getattr(np.dot, "_implementation", np.dot), compiled_tick.ORIGINALS,
                        compiled_tick.CONSTANTS)


def test_a_replaced_method_sees_every_tick():
    """A test's spy on Device.step (or a subclass's own tick) is called for every tick."""
    port = serial.serial_for_url("emulator://?clock=virtual&seed=2", timeout=0.01)
    seen = []
    step = port.device.step

    def spy():
        step()
        seen.append(port.device.time_us)
    port.device.step = spy
    try:
        t0 = port.device.time_us
        d = ThermalDisplay(port)
        d.handshake()
        d.wait(0.5)
        assert len(seen) == (port.device.time_us - t0) // 10_000 > 0
    finally:
        port.close()


def test_the_noise_stream_is_a_cycle_of_its_values():
    from experiments.hardware._tick import NormalStream
    values = [0.5, -1.25, 3.0, float(np.float64(0.1))]
    ns = NormalStream(values)
    assert list(itertools.islice(ns, 11)) == list(itertools.islice(itertools.cycle(values), 11))
    assert ns.pos == 11 % 4
    a, b = normal_stream(7, n=5), itertools.cycle(np.random.default_rng(7).standard_normal(5).tolist())
    assert [next(a) for _ in range(12)] == [next(b) for _ in range(12)]
    with pytest.raises(ValueError):
        NormalStream([])
    bare = NormalStream.__new__(NormalStream)      # never initialised: an error, not a crash
    with pytest.raises(ValueError, match="not initialised"):
        next(bare)


# ---------------------------------------------------------------- the state, bit for bit
def _canon(v):
    if isinstance(v, float):
        return ("f", v.hex())
    if isinstance(v, (list, tuple)):
        return (type(v).__name__, tuple(_canon(x) for x in v))
    if isinstance(v, np.ndarray):
        return ("a", v.tobytes())
    return v


def _snapshot(dev: Device):
    skip = {"parser", "out", "cache", "upload", "_log", "fault_listeners", "direct", "plant", "skin",
            "noise", "_sp_window", "sample", "finger", "params", "faults", "_reboots_done",
            "curves", "profile"}
    d = {k: _canon(v) for k, v in vars(dev).items() if k not in skip}
    d["window"] = _canon(list(dev._sp_window))
    d["noise"] = dev.noise.pos
    pl = dev.plant
    d["plant"] = {k: _canon(v) for k, v in vars(pl).items() if k not in ("p", "noise", "_consts")}
    d["plant_noise"] = pl.noise.pos
    if dev.skin is not None:
        sk = dev.skin
        d["skin"] = (_canon(sk._x), _canon(sk._x_next), _canon(sk.surface_node), _canon(sk.flux))
    if dev.finger is not None:
        d["finger_start_us"] = dev.finger.start_us
    d["curves_at"] = None if dev.curves is None else dev.curves[0]
    return d


class _Recorder:
    """Wraps a port's read_frames: after every read, the frames and the device's whole state."""

    def __init__(self, port):
        self.port = port
        self.log = []
        self._read_frames = port.read_frames
        port.read_frames = self

    def __call__(self, size):
        frames = self._read_frames(size)
        self.log.append((None if frames is None else [_canon(f) for f in frames],
                         _snapshot(self.port.device)))
        return frames


def _run_both(monkeypatch, scenario, seed=5, **kw):
    """The scenario on the compiled read loop and on Python's ticks; both records, and the
    numbers of compiled and Python ticks of the first."""
    counts = [0, 0]
    read_ticks = compiled_tick.read_ticks

    def counting(dev, frames, budget):
        c, p = read_ticks(dev, frames, budget)
        counts[0] += c
        counts[1] += p
        return c, p

    logs = []
    for on in (True, False):
        monkeypatch.setattr(compiled_tick, "enabled", on)
        monkeypatch.setattr(compiled_tick, "read_ticks", counting)
        port = serial.serial_for_url(f"emulator://?clock=virtual&seed={seed}", timeout=0.01)
        rec = _Recorder(port)
        try:
            result = scenario(port, **kw)
        finally:
            port.close()
        logs.append((rec.log, result))
    return logs[0], logs[1], counts


def _assert_same(a, b):
    (log_a, res_a), (log_b, res_b) = a, b
    assert len(log_a) == len(log_b)
    for i, (x, y) in enumerate(zip(log_a, log_b)):
        assert x[0] == y[0], f"read {i}: frames differ"
        if x[1] != y[1]:
            diff = {k: (x[1].get(k), y[1].get(k)) for k in set(x[1]) | set(y[1]) if x[1].get(k) != y[1].get(k)}
            raise AssertionError(f"read {i}: state differs: {diff}")
    assert repr(res_a) == repr(res_b)


def _trial(port, mode="playback", press_after_s=0.3, force_N=2.5, hold_s=1.5, max_duration_s=1.5,
           profile_s=1.5, limits=None, finger=True, timeout_s=10.0, sample_C=20.0, start_C=32.0,
           drop_C=3.0):
    d = ThermalDisplay(port, limits)
    try:
        d.handshake()
        t = np.arange(0.0, profile_s, 0.02)
        d.upload_profile(t, start_C - drop_C * np.sqrt(t / profile_s))
        if mode == "record":
            d.sim_sample(roughness_m=50e-6, temperature_C=sample_C)
        d.arm(mode=mode, force_threshold_N=2.0, max_duration_s=max_duration_s)
        if finger:
            d.sim_finger(press_after_s=press_after_s, force_N=force_N, hold_s=hold_s)
        events = []
        rec = d.run_trial(timeout_s=timeout_s, on_event=events.append)
        return rec, [(e.kind, e.device_time_s, e.arg) for e in events], d.status()
    finally:
        d.close()


@pytest.mark.parametrize("kw", [
    dict(),                                                        # END complete
    dict(mode="record"),                                           # the sample's curves
    dict(mode="record", sample_C=30.0, hold_s=0.6),                # released, record
    dict(hold_s=0.5),                                              # END released
    dict(hold_s=5.0, profile_s=4.0, max_duration_s=1.0),           # END max duration
    dict(limits=SafetyLimits(max_rate_C_per_s=2.0), start_C=26.0, drop_C=0.5),  # a slow ramp
    dict(finger=False, timeout_s=0.6),                             # no finger: no skin, timeout
], ids=["complete", "record", "record-released", "released", "max-duration", "slow-rate", "no-finger"])
def test_a_trial_ticks_the_same_compiled_or_not(monkeypatch, kw):
    a, b, (compiled, python) = _run_both(monkeypatch, _trial, **kw)
    _assert_same(a, b)
    assert len(a[0]) > 20
    assert compiled > 5 * python          # most ticks were compiled, the rest Python's


def _watchdog(port):
    """A host that arms, then reads without a heartbeat: the watchdog ends the trial."""
    port.write(encode_frame(1, m.Cmd.HELLO, m.HELLO_REQ.pack(m.PROTOCOL_VERSION)))
    port.read(4096)
    port.device.profile = ([31.0, 30.0, 29.0], 500_000)
    port.write(encode_frame(2, m.Cmd.ARM, m.ARM.pack(m.Mode.PLAYBACK, 200, 2000)))
    port.read(4096)
    states = []
    for _ in range(40):
        port.read_frames(65536)
        states.append(port.device.state.name)
    return states


def test_the_watchdog_acts_on_the_same_tick(monkeypatch):
    a, b, (compiled, python) = _run_both(monkeypatch, _watchdog)
    _assert_same(a, b)
    assert "ARMED" in a[1] and a[1][-1] == "IDLE"
    assert python >= 1 and compiled > 0


def _stuck_sensor(port):
    """No sensor noise: the reading repeats and the firmware trips SENSOR_STUCK, then FAULT
    ticks (Python's) until an ABORT; FAULT stays latched."""
    port.device = Device(seed=3, params=PadParams(noise_sensor=0.0))
    rec = _trial(port, hold_s=3.0, profile_s=3.0, max_duration_s=3.0)
    return rec, port.device.state.name


def test_a_safety_trip_and_fault_ticks_are_the_same(monkeypatch):
    a, b, _ = _run_both(monkeypatch, _stuck_sensor)
    _assert_same(a, b)
    assert a[1][0][0].fault_code == "SENSOR_STUCK"


@settings(max_examples=12, deadline=None, derandomize=True)
@given(press=st.floats(0.0, 1.0), force=st.floats(1.0, 6.0), hold=st.floats(0.05, 3.0),
       rate=st.floats(0.2, 40.0), seed=st.integers(0, 2**16), record=st.booleans(),
       sample_C=st.floats(15.0, 40.0), start_C=st.floats(20.0, 40.0))
def test_random_trials_tick_the_same(press, force, hold, rate, seed, record, sample_C, start_C):
    with pytest.MonkeyPatch.context() as mp:
        a, b, _ = _run_both(mp, _trial, seed=seed, mode="record" if record else "playback",
                            press_after_s=press, force_N=force, hold_s=hold, sample_C=sample_C,
                            limits=SafetyLimits(max_rate_C_per_s=rate), timeout_s=6.0,
                            start_C=start_C, drop_C=min(3.0, rate / 3))
    _assert_same(a, b)


def test_a_long_wait_is_interruptible_and_keeps_the_ticks_it_did():
    """A read with no timeout on an idle device ticks until something is said (nothing, here):
    a signal handler's exception ends it, and the state is that of the ticks done."""
    import signal

    class Stop(Exception):
        pass

    def handler(signum, frame):
        raise Stop

    port = serial.serial_for_url("emulator://?clock=virtual&seed=4", timeout=None)
    old = signal.signal(signal.SIGALRM, handler)
    signal.setitimer(signal.ITIMER_REAL, 0.05)
    try:
        with pytest.raises(Stop):
            port.read_frames(65536)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    dev = port.device
    ticks = dev.time_us // 10_000
    assert ticks >= 1024 and dev.direct is None
    reference = Device(seed=4)
    for _ in range(ticks):
        reference.step()
    assert _snapshot(dev) == _snapshot(reference)
    port.close()
