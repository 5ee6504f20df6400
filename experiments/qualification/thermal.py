"""Thermal checks: the pad holds neutral; its step response; its tracking of the paper's
profiles."""
from __future__ import annotations

import numpy as np

from experiments.responders.hand import press

from .bench import Bench, Trace
from .result import CheckResult, cannot_run

__all__ = ["check_neutral", "check_step", "check_tracking", "STEP_TARGETS_C"]

#: The pad holds neutral within this, °C (after settling).
NEUTRAL_BAND_C = 0.1
SETTLE_S, HOLD_S = 2.0, 2.0
#: The two set-points of the step response, °C (from neutral, within every range).
STEP_TARGETS_C = (36.0, 28.0)
#: Settling band, °C; allowed settling time beyond the slew at the rate limit, s; overshoot, °C.
STEP_BAND_C, STEP_EXTRA_S, STEP_OVERSHOOT_C = 0.1, 1.0, 0.3


def check_neutral(bench: Bench) -> CheckResult:
    """Unloaded, the pad holds neutral within 0.1 °C over 2 s (after 2 s to settle)."""
    name, title = "neutral", "the pad holds neutral"
    n = bench.neutral_C
    limit = f"|contact − {n:g} °C| ≤ {NEUTRAL_BAND_C:g} °C over {HOLD_S:g} s"
    d = bench.display
    d.set_neutral(n)
    bench.pause(SETTLE_S)
    tr = bench.watch(HOLD_S)
    err = np.abs(np.array(tr.contact_C) - n)
    t = np.array(tr.t_s) - tr.t_s[0]
    plot = bench.plot("neutral", f"neutral hold at {n:g} °C", t,
                      {"contact": tr.contact_C, "setpoint": tr.setpoint_C})
    measured = f"max |error| {err.max():.3f} °C, mean {np.mean(tr.contact_C):.3f} °C"
    ok = bool(err.max() <= NEUTRAL_BAND_C)
    return CheckResult(name, title, ok, limit, measured,
                       "" if ok else f"the pad strays {err.max():.2f} °C from neutral",
                       "" if ok else "the Peltier's wiring and supply, the heat sink's fan, the "
                                     "contact sensor's calibration constant", plots=[plot])


def _step(bench: Bench, target: float, rate: float) -> tuple[dict, Trace]:
    d = bench.display
    start = d.status()
    t0, y0, sp0 = start.device_time_s, start.contact_C, start.setpoint_C
    d.set_neutral(target)
    slew = abs(target - y0) / rate
    limit_s = slew + STEP_EXTRA_S
    tr = bench.watch(limit_s + 1.5)
    # the step starts when the device carried out SET_NEUTRAL, not when the host sent it (a
    # slow link, QEMU's, delays the command): the set-point slews at the rate from there, so
    # the first reading's set-point dates it -- unless the slew was already over (then the
    # time before the command, the conservative start)
    moved = abs(tr.setpoint_C[0] - sp0)
    if moved < abs(target - sp0) - 0.005:
        t0 = max(t0, tr.t_s[0] - moved / rate)
    t = np.array(tr.t_s) - t0
    y = np.array(tr.contact_C)
    outside = np.nonzero(np.abs(y - target) > STEP_BAND_C)[0]
    settle = (t[outside[-1] + 1] if outside.size and outside[-1] + 1 < len(t)
              else (float("inf") if outside.size else t[0]))
    sign = 1.0 if target > y0 else -1.0
    overshoot = max(0.0, float(np.max(sign * (y - target))))
    return dict(target=target, from_C=y0, settle_s=float(settle), limit_s=limit_s,
                overshoot_C=overshoot), tr


def check_step(bench: Bench) -> CheckResult:
    """Step response to two set-points: the time to within 0.1 °C and the overshoot."""
    name, title = "step", "step response to two set-points"
    d = bench.display
    rate = min(d.capabilities.max_rate_C_per_s, getattr(getattr(d, "limits", None),
                                                        "max_rate_C_per_s", 10.0))
    limit = (f"within {STEP_BAND_C:g} °C by |ΔT|/{rate:g} °C/s + {STEP_EXTRA_S:g} s; "
             f"overshoot ≤ {STEP_OVERSHOOT_C:g} °C")
    d.set_neutral(bench.neutral_C)
    bench.pause(SETTLE_S)
    parts, plots, fails = [], [], []
    try:
        for target in STEP_TARGETS_C:
            r, tr = _step(bench, target, rate)
            t = np.array(tr.t_s) - tr.t_s[0]
            plots.append(bench.plot(f"step_{target:g}C", f"step {r['from_C']:.2f} → {target:g} °C",
                                    t, {"contact": tr.contact_C, "setpoint": tr.setpoint_C},
                                    hlines={f"±{STEP_BAND_C:g}": target + STEP_BAND_C}))
            parts.append(f"→ {target:g} °C: settled in {r['settle_s']:.2f} s (limit "
                         f"{r['limit_s']:.2f} s), overshoot {r['overshoot_C']:.3f} °C")
            if r["settle_s"] > r["limit_s"]:
                fails.append(f"to {target:g} °C: not within {STEP_BAND_C:g} °C by "
                             f"{r['limit_s']:.2f} s ({r['settle_s']:.2f} s)")
            if r["overshoot_C"] > STEP_OVERSHOOT_C:
                fails.append(f"to {target:g} °C: overshoot {r['overshoot_C']:.2f} °C")
    finally:
        d.set_neutral(bench.neutral_C)
    bench.pause(SETTLE_S)
    return CheckResult(name, title, not fails, limit, "; ".join(parts), "; ".join(fails),
                       "" if not fails else "the Peltier module and its supply (slow), the heat "
                       "sink's fan and thermal paste (slow heating), the controller's gains "
                       "(overshoot)", plots=plots)


def _paper_profiles(bench: Bench):
    """(label, times_s, target_C) of samples 1#–4# for groups A and B, the first ``profile_s``."""
    from experiments.protocol import load_protocol
    from experiments.session.setup import simulated_target_profile
    from stimuli.paper import SAMPLE_NAMES, SAMPLE_ROUGHNESS_UM
    from experiments.profile_rate import limit_rate
    proto = bench.protocol or load_protocol("roughness_recognition")   # (the CLI's default)
    sim = proto.simulation
    lim = bench.display.limits if hasattr(bench.display, "limits") else proto.display.safety_limits()
    out = []
    for group in ("A", "B"):
        for rid, (sname, rum) in enumerate(zip(SAMPLE_NAMES, SAMPLE_ROUGHNESS_UM), start=1):
            prof = simulated_target_profile(proto, {}, group, None, rid, rum)
            t = np.asarray(prof.times, float)
            y = np.asarray(prof.temperature, float)
            keep = t <= bench.profile_s + 1e-9
            y, _ = limit_rate(y[keep], 1.0 / sim.rate_Hz, lim.max_rate_C_per_s,
                              window_s=lim.rate_window_s, resolution_C=sim.resolution_C)
            out.append((f"{group} {sname}", t[keep], np.asarray(y)))
    return out


def _play(bench: Bench, t, y):
    """Upload and play one profile with a contact (scripted finger or the operator's weight)."""
    d = bench.display
    if d.capabilities.contact_detection == "stimulus_start":
        d.set_neutral(float(y[0]))            # a resting probe starts where the profile starts
        bench.pause(1.0)
    d.upload_profile(t, y)
    d.arm("playback", force_threshold_N=1.0, max_duration_s=float(t[-1]) + 2.0)
    if bench.scripted:
        press(d, sample=None, press_after_s=0.2, force_N=2.0, hold_s=float(t[-1]) + 1.0)
    else:
        bench.prompt("Place the weight on the pad (the profile plays while it rests there), "
                     "then press Enter: ")
    tel = []
    rec = d.run_trial(timeout_s=float(t[-1]) + 20.0, on_telemetry=tel.append)
    return rec, tel


def check_tracking(bench: Bench) -> CheckResult:
    """Tracking error on the paper's profiles (samples 1#–4#, groups A and B) against the
    protocol's ``[simulation] max_tracking_error_C``."""
    name, title = "tracking", "tracking of the paper's profiles (1#–4#, groups A and B)"
    lim = bench.tracking_limit_C
    limit = f"max |contact − target| ≤ {lim:g} °C (the protocol's max_tracking_error_C), each trial ok"
    d = bench.display
    if "playback" not in d.capabilities.modes:
        return cannot_run(name, title, limit, "the device does not play profiles")
    if not bench.scripted and (bench.prompt is None or not d.capabilities.force_sensing):
        return cannot_run(name, title, limit,
                          "playback starts at a contact: no scripted bench here and no operator "
                          "to place the weight (--no-prompt)",
                          "run without --no-prompt with the weight at hand",
                          board_only="tracking under a real fingertip's heat load")
    parts, fails, plots = [], [], []
    try:
        for label, t, y in _paper_profiles(bench):
            rec, tel = _play(bench, t, y)
            parts.append(f"{label}: max {rec.tracking_max_C:.3f} °C, rms {rec.tracking_rms_C:.3f} °C")
            if rec.status != "ok":
                fails.append(f"{label}: trial {rec.status} ({rec.fault_code}: {rec.fault_message})")
            elif not rec.tracking_max_C <= lim:
                fails.append(f"{label}: tracking error {rec.tracking_max_C:.2f} °C > {lim:g} °C")
            tt = [f.device_time_s for f in tel]
            tag = label.replace(" ", "_").replace("#", "")
            plots.append(bench.plot(f"profile_{tag}", f"profile {label}",
                                    np.array(tt) - (tt[0] if tt else 0),
                                    {"contact": [f.contact_C for f in tel],
                                     "setpoint": [f.setpoint_C for f in tel]}))
            bench.pause(0.5)
    finally:
        d.set_neutral(bench.neutral_C)
    look = ""
    if any("(WATCHDOG" in f or "(LINK_" in f or "(TELEMETRY_LOSS" in f for f in fails):
        look = ("the link and the host machine's load (a trial ended on host silence or a "
                "lost link, not on tracking); ")
    if fails:
        look += "the Peltier module and supply, the heat sink's fan, the controller's gains"
    return CheckResult(name, title, not fails, limit, "; ".join(parts), "; ".join(fails), look,
                       plots=plots,
                       board_only="tracking under a real fingertip's heat load")
