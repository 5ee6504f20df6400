"""The display benchmark: link latency over a real pty, telemetry loss, and tracking error.

``thermocue bench display --out DIR`` calls :func:`run_display_benchmark`, which prints a table and
writes ``DIR/bench.json`` (the unit in every field name). Figures:

- command round trip (acknowledged HEARTBEAT) over a real pty to the emulator in its own process,
  1,000 trips after 50 warm-up ones: p50, p99, max;
- telemetry frames lost per 10,000: at least 10,000 frames over the pty on the virtual clock
  (the emulator streams as fast as the host reads) plus one 20 s trial in wall-clock time;
- tracking error (contact sensor minus target; RMS and max over the playback) of the emulated
  display on the paper's simulated profiles: stainless steel 1#-4# (1.6, 12.5, 50, 100 µm), skin
  650 and 1000 µm (groups A and B), skin 35.5 °C, sample 20 °C, 20 s at 100 Hz, from
  ``stimuli.target_profile`` (exact), played to a scripted finger of the same skin;
- the cost of one simulated 20 s trial on the in-process virtual clock.
"""
from __future__ import annotations

import json
import os
import platform
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from experiments.display.children import popen_tied
from experiments.responders.hand import press
from stimuli.paper import GROUP_TARGET_THICKNESS_UM, SAMPLE_ROUGHNESS_UM

__all__ = ["run_display_benchmark", "CONTROLLER"]

ROUGHNESS_UM = dict(enumerate(SAMPLE_ROUGHNESS_UM, start=1))
SKIN_UM = tuple(GROUP_TARGET_THICKNESS_UM.values())

CONTROLLER = (
    "Device-side loop at 200 Hz (5 ms) on the contact sensor: feed-forward of the profile's "
    "derivative (the firmware knows the next sample) and of the modelled leak to the heat sink, "
    "a proportional term (40 W/K), and a disturbance observer (20 ms) that estimates the "
    "unmodelled heat flow -- mostly the finger's load -- from the measured temperature change "
    "and cancels it; the desired heat flow becomes a current by inverting the Peltier equation "
    "with a firmware model that is deliberately 5 % wrong, clamped to ±3 A.")


def _target(roughness_um, skin_um):
    import stimuli
    skin = stimuli.Skin(skin_um * 1e-6)
    if hasattr(stimuli, "target_profile"):
        p = stimuli.target_profile(material="stainless_steel", roughness=roughness_um * 1e-6,
                                   skin=skin, skin_temperature=35.5, material_temperature=20.0,
                                   duration=20.0, rate=100.0, resolution=0.01)
        return np.asarray(p.times), np.asarray(p.temperature), "stimuli.target_profile (exact)"
    steel = stimuli.material("stainless_steel")
    R = stimuli.contact_resistance(roughness_um * 1e-6, skin=skin, material=steel)
    c = stimuli.Contact(skin, steel, resistance=R, skin_temperature=35.5, material_temperature=20.0)
    t = np.arange(2001) * 0.01
    return t, np.round(c.interface_temperature(t, side="material"), 2), \
        "stimuli.Contact.interface_temperature (exact, material side)"


def _start_emulator(*args):
    # SIGTERM when the benchmark dies: the server ends its pty and its lock file
    proc = popen_tied([sys.executable, "-m", "experiments.emulators.pty_server", *args],
                      death_signal=signal.SIGTERM,
                      stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    r, _, _ = select.select([proc.stdout], [], [], 60)
    if not r:
        proc.kill()
        raise RuntimeError("the emulator printed no pty path")
    return proc, proc.stdout.readline().strip()


def _stop(proc):
    proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout=10)
    except subprocess.TimeoutExpired:
        proc.kill()


def _rtt(path, n=1000):
    from experiments.display import open_display
    with open_display(path) as d:
        d.stop_heartbeat()          # time the link, not contention with the background thread
        for _ in range(50):
            d.heartbeat()
        rtt = np.empty(n)
        for i in range(n):
            t0 = time.perf_counter()
            d.heartbeat()
            rtt[i] = time.perf_counter() - t0
    return rtt * 1e3


def _loss(path, trials, hold_s=20.0):
    from experiments.display import open_display
    t, y, _ = _target(1.6, 650.0)
    frames = lost = 0
    with open_display(path) as d:
        d.upload_profile(t, y)
        for _ in range(trials):
            d.arm("playback", max_duration_s=20.0)
            press(d, sample=None, press_after_s=0.2, hold_s=hold_s)
            rec = d.run_trial(timeout_s=60.0)
            frames += rec.frames
            lost += rec.frames_lost
    return frames, lost


def _tracking():
    from experiments.display import open_display
    rows = []
    with open_display("emulator://?clock=virtual&seed=20261122") as d:
        for skin_um in SKIN_UM:
            for rid, ra in ROUGHNESS_UM.items():
                t, y, source = _target(ra, skin_um)
                d.upload_profile(t, y)
                d.arm("playback", max_duration_s=20.0)
                press(d, sample=None, press_after_s=0.3, hold_s=25.0, skin_thickness_m=skin_um * 1e-6,
                      skin_temperature_C=35.5)
                t0 = time.perf_counter()
                rec = d.run_trial(timeout_s=60.0)
                cost = time.perf_counter() - t0
                rows.append(dict(roughness_id=rid, roughness_um=ra, skin_thickness_um=skin_um,
                                 status=rec.status, tracking_rms_C=round(rec.tracking_rms_C, 4),
                                 tracking_max_C=round(rec.tracking_max_C, 4),
                                 target_start_C=float(y[0]), target_end_C=float(y[-1]),
                                 frames=rec.frames, wall_time_s=round(cost, 3)))
    return rows, source


def run_display_benchmark(out_dir) -> dict:
    """Run the display benchmark, print a table, write ``out_dir/bench.json``; return the dict."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    result = dict(benchmark="display", machine=dict(
        platform=platform.platform(), python=platform.python_version(), cpus=os.cpu_count(),
        load_average_1min=os.getloadavg()[0]))
    proc, path = _start_emulator()
    try:
        rtt = _rtt(path)
        rt_frames, rt_lost = _loss(path, 1)
    finally:
        _stop(proc)
    result.update(rtt_method="acknowledged HEARTBEAT over an os.openpty pair to the emulator in "
                             "another process (thermocue emulator), 1000 trips after 50 warm-up, "
                             "background heartbeat paused",
                  rtt_trips=int(rtt.size), rtt_p50_ms=round(float(np.percentile(rtt, 50)), 4),
                  rtt_p99_ms=round(float(np.percentile(rtt, 99)), 4),
                  rtt_max_ms=round(float(rtt.max()), 4), rtt_goal_p99_ms=1.0)
    proc, path = _start_emulator("--clock", "virtual")
    try:
        v_frames, v_lost = _loss(path, 5)
    finally:
        _stop(proc)
    frames, lost = v_frames + rt_frames, v_lost + rt_lost
    result.update(telemetry_frames=frames, telemetry_frames_lost=lost,
                  telemetry_lost_per_10000=round(1e4 * lost / max(1, frames + lost), 3),
                  telemetry_frames_realtime=rt_frames, telemetry_lost_realtime=rt_lost,
                  telemetry_rate_Hz=100)
    rows, source = _tracking()
    rms = np.array([r["tracking_rms_C"] for r in rows])
    result.update(tracking_profiles=rows, tracking_source=source,
                  tracking_rms_max_over_profiles_C=float(rms.max()),
                  tracking_rms_mean_over_profiles_C=round(float(rms.mean()), 4),
                  tracking_max_abs_C=float(max(r["tracking_max_C"] for r in rows)),
                  tracking_goal_rms_C=0.05, controller=CONTROLLER,
                  simulated_trial_wall_time_s=round(float(np.median([r["wall_time_s"] for r in rows])), 3),
                  simulated_trial_device_time_s=round(float(np.median([r["frames"] for r in rows])) / 100, 2))
    (out / "bench.json").write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    print(f"display benchmark ({result['machine']['platform']}, {result['machine']['cpus']} cpus, "
          f"load {result['machine']['load_average_1min']:.2f})")
    print(f"  round trip over a pty: p50 {result['rtt_p50_ms']:.3f} ms, p99 "
          f"{result['rtt_p99_ms']:.3f} ms, max {result['rtt_max_ms']:.3f} ms (goal p99 ≤ 1 ms)")
    print(f"  telemetry: {lost} of {frames + lost} frames lost "
          f"({result['telemetry_lost_per_10000']} per 10,000)")
    print(f"  tracking ({source}):")
    print("    skin_um  roughness  rms_C   max_C   start_C  end_C")
    for r in rows:
        print(f"    {r['skin_thickness_um']:7.0f}  {r['roughness_id']}# {r['roughness_um']:5.1f}  "
              f"{r['tracking_rms_C']:.4f}  {r['tracking_max_C']:.3f}   {r['target_start_C']:.2f}   "
              f"{r['target_end_C']:.2f}")
    print(f"  one simulated 20 s trial: {result['simulated_trial_wall_time_s']} s of wall time")
    print(f"  controller: {CONTROLLER}")
    print(f"  wrote {out / 'bench.json'}")
    return result
