"""Sensor checks: each thermometer plausible and not stuck; the force sensors at zero unloaded
and answering a known weight."""
from __future__ import annotations

from experiments.responders.hand import press

from .bench import Bench, finite
from .result import CheckResult, cannot_run

__all__ = ["check_sensors", "check_force"]

#: A plausible reading of a thermometer on a bench at room temperature, °C.
PLAUSIBLE_C = (5.0, 60.0)
#: How long the sensors are watched, s (the device's stuck-sensor rule needs 0.1 s).
WATCH_S = 1.0
#: An unloaded force sensor reads zero within this, N (each) and their sum.
ZERO_EACH_N, ZERO_SUM_N = 0.05, 0.1
#: A known weight reads within this share of itself.
WEIGHT_TOLERANCE = 0.10

_LATCHED_SENSOR = {"SENSOR_STUCK": "stuck (20 identical raw readings in a row)",
                   "SENSOR_FAILURE": "out of range (open or shorted)"}


def check_sensors(bench: Bench) -> CheckResult:
    """Contact, ambient, finger (IR) and heat sink read plausibly and the contact sensor is not
    stuck: the device's own stuck-sensor rule (20 identical raw readings, 0.1 s) has not
    latched a fault while it was watched."""
    name, title = "sensors", "thermometers plausible and not stuck"
    limit = (f"each reading within {PLAUSIBLE_C[0]:g}–{PLAUSIBLE_C[1]:g} °C; no SENSOR_STUCK or "
             f"SENSOR_FAILURE over {WATCH_S:g} s")
    d = bench.display
    readings = {"contact": [], "ambient": [], "finger (IR)": [], "heat sink": []}
    faults = set()
    st = d.status()
    t_end = st.device_time_s + WATCH_S
    while True:
        for key, v in zip(readings, (st.contact_C, st.ambient_C, st.finger_C, st.heatsink_C)):
            readings[key].append(v)
        if st.state == "FAULT" and st.fault:
            faults.add(st.fault)
        if st.device_time_s >= t_end:
            break
        bench.pause(0.05)
        st = d.status()
    lacks = set(d.capabilities.lacks)
    for key, part in (("finger (IR)", "finger_thermometer"), ("heat sink", "heat_sink_thermometer")):
        if part in lacks:                  # a thermometer the backend declares it has not
            del readings[key]
    missing = [k for k, v in readings.items() if not all(finite(x) for x in v)]
    bad = {k: (min(v), max(v)) for k, v in readings.items()
           if k not in missing and not all(PLAUSIBLE_C[0] <= x <= PLAUSIBLE_C[1] for x in v)}
    measured = "; ".join(f"{k} {min(v):.2f}–{max(v):.2f} °C" for k, v in readings.items()
                         if k not in missing)
    if faults & set(_LATCHED_SENSOR):
        code = sorted(faults & set(_LATCHED_SENSOR))[0]
        return CheckResult(name, title, False, limit, measured,
                           f"the device latched {code}: the contact sensor is {_LATCHED_SENSOR[code]}",
                           "the contact thermistor's wiring and its ADC channel (a loose or "
                           "shorted lead reads constant or out of range)")
    if bad:
        k, (lo, hi) = next(iter(bad.items()))
        return CheckResult(name, title, False, limit, measured,
                           f"{k} reads {lo:.2f}–{hi:.2f} °C, outside {PLAUSIBLE_C[0]:g}–"
                           f"{PLAUSIBLE_C[1]:g} °C",
                           f"the {k} sensor's wiring and its calibration constant")
    if missing:
        return cannot_run(name, title, limit,
                          f"the device reports no {', '.join(missing)} reading (measured: {measured})",
                          "a device with every thermometer of the protocol's §4")
    not_here = [part for part in ("finger_thermometer", "heat_sink_thermometer") if part in lacks]
    if "stuck_sensor_rule" in lacks:       # plausible is all this device lets the host see
        return CheckResult(name, title, True, f"each reading within {PLAUSIBLE_C[0]:g}–"
                           f"{PLAUSIBLE_C[1]:g} °C over {WATCH_S:g} s", measured,
                           _partial(not_here + ["stuck_sensor_rule"]),
                           board_only="a stuck or drifting probe sensor (the device latches no "
                                      "stuck-sensor fault the host could see)")
    if not bench.has("set_trip"):
        return cannot_run(name, title, limit, "the backend has no stuck-sensor rule of its own "
                          f"to test (readings plausible: {measured})")
    return CheckResult(name, title, True, limit, measured, _partial(not_here))


def _partial(parts) -> str:
    """What of the sensors check this backend's declared capabilities left out ("" if none)."""
    if not parts:
        return ""
    from experiments.display.base import LACKABLE
    return ("not applicable to this backend, which lacks "
            + "; ".join(f"{p} ({LACKABLE[p]})" for p in parts))


def check_force(bench: Bench) -> CheckResult:
    """Unloaded, each force sensor reads zero; a known weight (the operator's, or the scripted
    finger's press on an emulator) reads as itself."""
    name, title = "force", "force sensors at zero unloaded and answering a known weight"
    d = bench.display
    w = bench.weight_N
    limit = (f"unloaded |each| ≤ {ZERO_EACH_N:g} N and |sum| ≤ {ZERO_SUM_N:g} N; a {w:.2f} N "
             f"weight within {WEIGHT_TOLERANCE:.0%}")
    if not d.capabilities.force_sensing:
        return cannot_run(name, title, limit, "the device has no force sensors "
                          f"({d.capabilities.notes})")
    zero = [d.status().forces_N for _ in range(5)]
    worst = max(abs(f) for fs in zero for f in fs)
    worst_sum = max(abs(sum(fs)) for fs in zero)
    measured = f"unloaded: max |each| {worst:.3f} N, max |sum| {worst_sum:.3f} N"
    if worst > ZERO_EACH_N or worst_sum > ZERO_SUM_N:
        return CheckResult(name, title, False, limit, measured,
                           "a force sensor reads off zero with nothing on the pad",
                           "the force sensors' zero (tare) calibration constants and their wiring")
    if bench.scripted:
        press(d, sample=None, press_after_s=0.0, force_N=w, hold_s=1.5)
        bench.pause(1.0)                       # pressed, settled (τ 0.2 s)
        loaded = sum(d.status().forces_N)
        bench.pause(1.0)                       # released
        source = "the scripted finger's press"
    elif bench.prompt is None:
        return CheckResult(name, title, False, limit, measured,
                           "the known-weight test needs the operator; it was not run (--no-prompt)",
                           "run thermocue check without --no-prompt, with the weight at hand")
    else:
        bench.prompt(f"Place the {w / 9.80665 * 1000:.0f} g weight on the pad, then press Enter: ")
        loaded = sum(d.status().forces_N)
        bench.prompt("Take the weight off the pad, then press Enter: ")
        source = "the operator's weight"
    measured += f"; {source}: {loaded:.3f} N of {w:.3f} N"
    if abs(loaded - w) > WEIGHT_TOLERANCE * w:
        return CheckResult(name, title, False, limit, measured,
                           f"the known weight reads {loaded:.2f} N, not {w:.2f} N",
                           "the force sensors' gain calibration constants and their wiring")
    return CheckResult(name, title, True, limit, measured)
