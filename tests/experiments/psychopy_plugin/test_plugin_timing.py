"""Contact onset on PsychoPy's timeline, measured over a real pty.

The emulator (a separate process serving a pty) records, for every 10 ms tick, its device time
and PsychoPy's clock (``psychopy.clock.getTime()``) when the tick ran. Its schedule, the line
through the ticks that ran on time (:func:`_plugin_helpers.on_time_host_s`), gives the true
PsychoPy time of any device time stamp, as a display's own timer would keep it. The device maps
the contact's stamp with heartbeat bursts before and after the trial (:mod:`..clock_sync`); the
error against that truth is printed (``pytest -s``); it must stay within the mapping's own
stated uncertainty plus 0.5 ms (the emulator's own wake-up delay on a loaded machine), and
below 1 ms in every trial whose stated uncertainty is below 0.8 ms (at least 6 of the 8, less
those whose wide burst the emulator's log explains: its loop ran a tick over 1 ms late). A
trial whose map refused (the emulator's loop starved so long that its replies carried stale
ticks) counts among those 6 only when the emulator's own log shows the lateness that explains
the refusal (:func:`_plugin_helpers.unexplained_refusal`). The error against the log's stamp of
the contact tick itself (late when the emulator was starved) is printed too.
"""
from __future__ import annotations

import json
import statistics
import time

import numpy as np
import pytest

from _plugin_helpers import on_time_host_s, read_log, serve_stamped, unexplained_refusal

pytestmark = pytest.mark.slow

T = np.arange(0, 1.0001, 0.01)
PROFILE = np.round(32.0 - 1.0 * (T / 1.0), 2)
TRIALS = 8
#: The emulator's loop wakes up to this late for a tick on a busy machine (not starved), s.
WAKE_UP_S = 0.5e-3


def test_contact_onset_is_placed_on_psychopy_time_within_1_ms(tmp_path):
    from experiments.psychopy_plugin.device import ThermalCueDevice
    rng = np.random.default_rng(20261124)
    trials = []          # (device stamp, mapped, mapped with the first burst only, uncertainty,
                         #  the device times the trial's two bursts read)
    rtts = []
    unmapped = []        # the reasons of maps that refused
    with serve_stamped(tmp_path) as (link, log):
        dev = ThermalCueDevice(url=link, protocol="roughness_recognition")
        try:
            dev.uploadProfile(T, PROFILE)
            for _ in range(TRIALS):
                dev.resetClockMap()
                dev.syncClock()
                dev.arm(forceThreshold_N=2.0, maxDuration_s=5.0)
                dev.display.sim_finger(press_after_s=float(rng.uniform(0.05, 0.3)), force_N=2.5,
                                       hold_s=3.0)
                deadline = time.monotonic() + 10
                while not dev.responses and time.monotonic() < deadline:
                    dev.dispatchMessages()
                    time.sleep(1 / 60)                  # a frame of PsychoPy's loop
                assert dev.responses, "no contact within 10 s"
                contact = dev.responses[0]
                dev.neutral()
                rec = dev.finishTrial()
                dev.syncClock()                         # the second burst: drift
                assert rec.contact_time_s == contact.device_time_s
                if dev.clockMap.unmapped is not None:    # said so: no number (checked below)
                    unmapped.append(dev.clockMap.unmapped)
                    continue
                trials.append((contact.device_time_s, dev.toPsychopyTime(contact.device_time_s),
                               contact.t, dev.clockMap.uncertainty_s,
                               [d for b in (dev.firstBurst, dev.lastBurst) for _, d, _ in b.samples]))
                rtts.append(dev.firstBurst.rtt_median_s)
        finally:
            dev.close()
    records = read_log(log)
    # A map may refuse only what the emulator's clock really did on a loaded host: replies
    # stamped by a starved loop, as late as its worst tick, or time lost beyond catching up
    for why in unmapped:
        assert unexplained_refusal(why, records[-1]["max_late_ms"]) is None, unmapped
    ticks = json.loads((tmp_path / "ticks.json").read_text())
    logged = {round(r["t_s"], 6): r["host_s"] for r in records if r.get("why") == "contact"}
    errors, first_only, late = [], [], []
    for stamp, mapped, mapped_first, width, read in trials:
        truth = on_time_host_s(ticks, stamp)
        # how stale a burst's replies could be: the latest its loop ran a tick meanwhile
        stale = max(h - on_time_host_s(ticks, d * 1e-6) for d, h in ticks
                    if min(read) - 0.01 <= d * 1e-6 <= max(read) + 0.02)
        errors.append((mapped - truth, width, max(WAKE_UP_S, stale)))
        first_only.append(mapped_first - truth)
        late.append(logged[round(stamp, 6)] - truth)    # how late the contact tick itself ran
    assert len(errors) + len(unmapped) == TRIALS
    if not errors:
        return                                   # every map refused, each for a shown cause
    abs_ms = [abs(e) * 1e3 for e, _, _ in errors]
    print(f"\ncontact onset on PsychoPy's clock over a pty, {TRIALS} trials, {len(unmapped)} "
          f"refused: "
          f"|error| median {statistics.median(abs_ms):.3f} ms, max {max(abs_ms):.3f} ms "
          f"(first burst only: max {max(abs(e) for e in first_only) * 1e3:.3f} ms); "
          f"stated uncertainty max {max(w for _, w, _ in errors) * 1e3:.3f} ms; heartbeat round "
          f"trip median {statistics.median(rtts) * 1e6:.0f} µs; contact ticks ran up to "
          f"{max(late) * 1e3:.2f} ms late (emulator's worst tick: "
          f"{records[-1].get('max_late_ms')} ms)")
    # the stated bound holds, always, up to the emulator's own lateness: on a loaded machine
    # its loop runs a tick a few hundred µs (WAKE_UP_S) or, starved, some ms after the
    # schedule, and heartbeat replies carry the previous tick's time that much longer (a
    # hardware timer does not)
    for e, w, stale in errors:
        assert abs(e) <= w + stale, (e, w, stale)
    # within 1 ms whenever the mapping says it got a tight burst (< 0.8 ms); on a machine loaded
    # to a load average of 8-10 on 2 cores an odd burst stays wide (its rows say so in
    # clock_uncertainty_s), but most must be tight -- except those whose bursts the emulator's
    # own log shows starved (a tick over 1 ms late in the bursts' window: its replies then carry
    # stale times and the burst is honestly wide; a hardware timer does not starve. CI once
    # had 5 tight and 3 wide with the emulator's worst tick 14.4 ms late)
    tight = [(e, stale) for e, w, stale in errors if w < 0.8e-3]
    starved_wide = [w for e, w, stale in errors if w >= 0.8e-3 and stale > 1e-3]
    assert len(tight) + len(starved_wide) >= 6 - len(unmapped), (errors, unmapped)
    for e, stale in tight:
        assert abs(e) < 1e-3 + (stale - WAKE_UP_S), (e, stale)
