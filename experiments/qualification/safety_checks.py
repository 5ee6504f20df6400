"""Safety checks: the rate limit and the safe range hold when the host asks for more; over-
temperature latches a fault and opens the relay; the watchdog cuts heating on host silence."""
from __future__ import annotations

import time

import numpy as np

from .bench import Bench
from .result import CheckResult, cannot_run

__all__ = ["check_limits", "check_overtemp", "check_watchdog"]

#: The test trip, above neutral, °C; and the set-point that crosses it.
TRIP_ABOVE_NEUTRAL_C, PAST_TRIP_C = 2.0, 2.0
#: The trip must latch within this after the set-point crosses it, s.
TRIP_WITHIN_S = 3.0
#: With the relay open the pad must not rise above the trip by more than this, °C.
TRIP_OVERRUN_C = 0.5
#: How far the pad must fall after the trip, within RELAX_S, to show the relay open, °C.
RELAX_C, RELAX_S = 0.3, 1.5


def _raw_neutral(d, value_C: float) -> float:
    """SET_NEUTRAL past the host's own check (the device's clamp is what is tested)."""
    from experiments.display.thermocue import messages as m
    p = d.link.transact(m.Cmd.SET_NEUTRAL, m.CENTI.pack(int(round(value_C * 100))))
    return m.CENTI.unpack(p)[0] / 100.0


def check_limits(bench: Bench) -> CheckResult:
    """The host refuses a set-point outside the safe range; the device clamps one sent past the
    host to its limits, and slews a 6 °C jump at no more than the rate limit (every 0.1 s)."""
    name, title = "limits", "rate limit and safe range hold when the host asks for more"
    d = bench.display
    lim = d.limits
    limit = (f"host refuses > {lim.max_C:g} °C; device holds ≤ {lim.max_C:g} °C; set-point "
             f"change over every 0.1 s ≤ {lim.max_rate_C_per_s:g} °C/s × 0.1 s + 0.01 °C")
    from experiments.errors import SafetyLimitError, UserInputError
    try:
        d.set_neutral(lim.max_C + 5.0)
        host = "host sent it"
    except (SafetyLimitError, UserInputError):
        host = "host refused"
    from experiments.display.thermocue.link import ProtocolLink
    if not isinstance(getattr(d, "link", None), ProtocolLink):      # a thermocue protocol link
        return cannot_run(name, title, limit, f"{host}; the backend has no way to send a "
                          "set-point past the host's check, so the device's clamp is untested",
                          board_only="")
    held = _raw_neutral(d, lim.max_C + 5.0)
    d.set_neutral(bench.neutral_C)
    bench.pause(1.0)
    st = d.status()
    d.set_neutral(bench.neutral_C + 6.0)
    tr = bench.watch(1.2, period_s=0.01)
    d.set_neutral(bench.neutral_C)
    bench.pause(1.0)
    t, sp = np.array(tr.t_s), np.array(tr.setpoint_C)
    worst = 0.0
    for i in range(len(t)):           # every pair within 0.1 s (STATUS: not every tick)
        j = np.nonzero((t > t[i]) & (t - t[i] <= 0.1 + 1e-6))[0]
        if j.size:
            worst = max(worst, float(np.max(np.abs(sp[j] - sp[i]))))
    allowed = lim.max_rate_C_per_s * 0.1 + 0.01 + 1e-6
    measured = (f"{host} {lim.max_C + 5:g} °C; device held {held:g} °C when sent; largest set-point "
                f"change within 0.1 s {worst:.3f} °C (allowed {allowed:.3f} °C), from {st.setpoint_C:.2f} °C")
    fails = []
    if host != "host refused":
        fails.append("the host sent a set-point above its safe range")
    if held > lim.max_C + 1e-6:
        fails.append(f"the device held {held:g} °C, above the limit {lim.max_C:g} °C")
    if worst > allowed:
        fails.append(f"the set-point moved {worst:.2f} °C within 0.1 s")
    plot = bench.plot("rate_limit", "set-point slew at the rate limit", t - t[0],
                      {"setpoint": tr.setpoint_C, "contact": tr.contact_C})
    return CheckResult(name, title, not fails, limit, measured, "; ".join(fails),
                       "" if not fails else "the firmware's limits (config.h) and the image flashed",
                       plots=[plot])


def check_overtemp(bench: Bench) -> CheckResult:
    """A trip lowered for the test (SET_TRIP) to 2 °C above neutral, the set-point 2 °C past it:
    FAULT OVER_TEMPERATURE latches and the relay opens (the pad falls). The device's own trip
    is restored however the check ends."""
    name, title = "overtemp", "over-temperature latches a fault and opens the relay"
    n = bench.neutral_C
    trip = n + TRIP_ABOVE_NEUTRAL_C
    limit = (f"FAULT OVER_TEMPERATURE within {TRIP_WITHIN_S:g} s; pad ≤ trip + {TRIP_OVERRUN_C:g} °C; "
             f"pad falls ≥ {RELAX_C:g} °C within {RELAX_S:g} s (relay open)")
    d = bench.display
    if not bench.has("set_trip"):
        return cannot_run(name, title, limit, "the backend has no command to lower its "
                          "over-temperature trip for a test",
                          board_only="the trip at the real 44.8 °C on the real pad")
    restored = None
    try:
        d.set_neutral(n)
        bench.pause(1.0)
        held = d.set_trip(trip)
        d.set_neutral(trip + PAST_TRIP_C)
        tr = bench.watch(TRIP_WITHIN_S + trip / 10.0, until=lambda s: s.state == "FAULT")
        st = d.status()
        if st.state == "FAULT":
            tr = bench.watch(RELAX_S, trace=tr)
    finally:
        restored = d.set_trip(99.0)
        if d.status().state == "FAULT":
            d.clear_fault()              # the check caused it: the operator asked for the check
        d.set_neutral(n)
    t = np.array(tr.t_s) - tr.t_s[0]
    y = np.array(tr.contact_C)
    plot = bench.plot("overtemp", f"over-temperature at a test trip of {held:g} °C", t,
                      {"contact": tr.contact_C, "setpoint": tr.setpoint_C}, hlines={"trip": held})
    fault_at = next((i for i, s in enumerate(tr.states) if s == "FAULT"), None)
    measured = f"trip held {held:g} °C, restored to {restored:g} °C; "
    if fault_at is None or st.fault != "OVER_TEMPERATURE":
        return CheckResult(name, title, False, limit, measured + f"state {st.state}, fault {st.fault}",
                           "no OVER_TEMPERATURE fault latched past the trip",
                           "the firmware's trip (image flashed) and the contact sensor's "
                           "calibration constant", plots=[plot], board_only="the trip at 44.8 °C")
    peak = float(y[fault_at:].max())
    after = y[fault_at:]
    fall = peak - float(after[-1])
    measured += (f"FAULT {st.fault} at {t[fault_at]:.2f} s; peak {peak:.2f} °C; fell {fall:.2f} °C "
                 f"in {t[-1] - t[fault_at]:.2f} s")
    fails = []
    if peak > held + TRIP_OVERRUN_C:
        fails.append(f"the pad rose to {peak:.2f} °C after the trip")
    if fall < RELAX_C:
        fails.append(f"the pad fell only {fall:.2f} °C after the trip: the relay did not open")
    if restored < 44.0:
        fails.append(f"the device's trip was not restored ({restored:g} °C)")
    return CheckResult(name, title, not fails, limit, measured, "; ".join(fails),
                       "" if not fails else "the Peltier relay and its driver's wiring (it must "
                       "open on a fault)", plots=[plot],
                       board_only="the trip at the real 44.8 °C on the real pad")


def check_watchdog(bench: Bench) -> CheckResult:
    """Armed at 2 °C above neutral, the host falls silent: the device reports WATCHDOG within
    its stated time + one tick and returns the set-point to neutral."""
    name, title = "watchdog", "the watchdog cuts heating when the host goes silent"
    d = bench.display
    info = getattr(d, "info", None)
    watchdog_s = getattr(info, "watchdog_s", None)
    stated = None if watchdog_s is None else int(round(watchdog_s * 1000))   # ms
    limit = (f"WATCHDOG within the stated {stated} ms + one 10 ms tick of the last host frame; "
             f"set-point back to neutral" if stated else "WATCHDOG within the stated time")
    if not (bench.has("stop_heartbeat") and stated):
        return cannot_run(name, title, limit, "the backend states no host-silence watchdog the "
                          "host can test")
    from experiments.display.thermocue import messages as m
    from experiments.display.thermocue.framing import FrameParser
    n = bench.neutral_C
    d.set_neutral(n)
    t = np.arange(0.0, 2.0, 0.01)
    d.upload_profile(t, np.full_like(t, n + 2.0))
    d.arm("playback", 2.0, 5.0)
    bench.pause(0.3)
    parser, frames = FrameParser(), []
    d.stop_heartbeat()
    try:
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline and not any(
                f.type == m.Msg.EVENT and f.payload[0] == m.Event.WATCHDOG for f in frames):
            frames += parser.feed(d.port.read(4096))
    finally:
        d.start_heartbeat()
    events = [m.DeviceEvent.decode(f.payload) for f in frames
              if f.type == m.Msg.EVENT and len(f.payload) >= m.EVENT_HEAD.size]
    wd = [e for e in events if e.kind == "WATCHDOG"]
    st = d.status()
    t0 = st.device_time_s
    tr = bench.watch(0.6)
    back = abs(tr.setpoint_C[-1] - n) <= 0.01
    d.abort()
    d.set_neutral(n)
    allowed = stated + 10
    if not wd:
        return CheckResult(name, title, False, limit, f"no WATCHDOG within 10 s; state {st.state}",
                           "the device did not trip on host silence",
                           "the firmware's watchdog (image flashed)")
    ms = wd[0].arg
    measured = (f"WATCHDOG {ms} ms after the last host frame; state {st.state}, fault "
                f"{st.fault}; set-point {tr.setpoint_C[-1]:.2f} °C {tr.t_s[-1] - t0:.2f} s later")
    fails = []
    if ms > allowed:
        fails.append(f"the watchdog tripped {ms} ms after the last host frame (> {allowed} ms)")
    if st.state != "IDLE" or st.fault != "WATCHDOG":
        fails.append(f"after the trip: state {st.state}, fault {st.fault}")
    if not back:
        fails.append("the set-point did not return to neutral")
    plot = bench.plot("watchdog", "after the watchdog trip", np.array(tr.t_s) - t0,
                      {"setpoint": tr.setpoint_C, "contact": tr.contact_C})
    return CheckResult(name, title, not fails, limit, measured, "; ".join(fails),
                       "" if not fails else "the firmware's watchdog timeout (image flashed)",
                       plots=[plot])
