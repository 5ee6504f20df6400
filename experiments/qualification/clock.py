"""The clock mapping: device time to host time, from heartbeat round trips (the PsychoPy
plugin's :class:`~experiments.psychopy_plugin.clock_sync.ClockMap`), two bursts 2 s apart."""
from __future__ import annotations

import time

from .bench import Bench
from .result import CheckResult, cannot_run

__all__ = ["check_clock"]

#: Time between the two bursts, s.
SPAN_S = 2.0
#: Largest mapping uncertainty, s (a contact time mapped to the host to within it).
MAX_UNCERTAINTY_S = 0.005
#: Measurements of the map before the check fails (the first that holds is kept).
ATTEMPTS = 3


def check_clock(bench: Bench) -> CheckResult:
    """Two heartbeat bursts 2 s apart map device time to host time: a plausible drift
    (≤ 2000 ppm), round trips consistent with the map, and an uncertainty ≤ 5 ms, in one of
    up to :data:`ATTEMPTS` measurements."""
    from experiments.psychopy_plugin.clock_sync import MAX_DRIFT_PPM, ClockMap, sync_burst
    name, title = "clock", "device time maps to host time"
    limit = (f"drift ≤ {MAX_DRIFT_PPM:g} ppm, every round trip within the map, uncertainty ≤ "
             f"{MAX_UNCERTAINTY_S * 1e3:g} ms")
    d = bench.display
    if not bench.has("heartbeat"):
        return cannot_run(name, title, limit, "the backend has no acknowledged heartbeat")
    scheme = getattr(type(d), "scheme", None)    # (a backend without a device clock declares
    #                                                it lacks one: not applicable, not run here)
    if scheme == "qemu-firmware":
        return _paused_clock(bench, name, title)
    if bench.virtual_clock() is not None:
        # an emulator on a virtual clock: the host counts in the device's own seconds
        t0 = d.heartbeat()
        bench.pause(0.5)
        t1 = d.heartbeat()
        ok = 0.49 <= t1 - t0 <= 0.52
        return CheckResult(name, title, ok, "virtual clock: 0.5 s of the host's wait is 0.5 s of "
                           "device time (± 20 ms)", f"{t1 - t0:.3f} s",
                           "" if ok else "device time does not follow the host's wait",
                           "" if ok else "the emulator's clock option",
                           board_only="the drift of a real crystal against the host")
    # a host held off by its own machine's load delays round trips (and an in-process
    # emulator's clock ticks): the map is measured again, up to ATTEMPTS times, and the first
    # one that holds is kept; a device whose clock really jumps fails every attempt
    for attempt in range(1, ATTEMPTS + 1):
        first = sync_burst(d.heartbeat, time.monotonic)
        bench.pause(SPAN_S)
        last = sync_burst(d.heartbeat, time.monotonic)
        cmap = ClockMap.from_bursts(first, last)
        if not cmap.unmapped and cmap.uncertainty_s <= MAX_UNCERTAINTY_S:
            break
    measured = (f"offset {cmap.offset_s:.4f} s, drift {cmap.drift * 1e6:.0f} ppm, uncertainty "
                f"{cmap.uncertainty_s * 1e3:.2f} ms (measurement {attempt} of at most {ATTEMPTS})")
    if cmap.unmapped:
        return CheckResult(name, title, False, limit, measured, f"unmapped: {cmap.unmapped}",
                           "the device's crystal and timer set-up (a QEMU image's clock pauses "
                           "when the host machine is loaded)")
    if cmap.uncertainty_s > MAX_UNCERTAINTY_S:
        return CheckResult(name, title, False, limit, measured,
                           f"uncertainty {cmap.uncertainty_s * 1e3:.1f} ms",
                           "the link's latency (USB serial adapter, baud rate)")
    return CheckResult(name, title, True, limit, measured)


def _paused_clock(bench: Bench, name: str, title: str) -> CheckResult:
    """The sim image under QEMU: its clock is the timer less QEMU's stalls (it pauses while the
    host machine holds QEMU off), so no real-time mapping exists. What the image promises: its
    device time never goes back, advances while it answers, and never runs ahead of wall time.
    How far it falls behind is the host machine's load, not the image's (a loaded host paused
    it for more than half of the wall time, measured), so no lower share is asked."""
    d = bench.display
    limit = ("device time monotonic, advancing, by at most 100.5 % of wall time over 2 s "
             "(the sim image pauses with QEMU)")
    w0, t0 = time.monotonic(), d.heartbeat()
    times = [t0]
    while time.monotonic() - w0 < SPAN_S:
        time.sleep(0.2)
        times.append(d.heartbeat())
    w1 = time.monotonic()
    share = (times[-1] - t0) / (w1 - w0)
    mono = all(b >= a for a, b in zip(times, times[1:]))
    ok = mono and 0.0 < share <= 1.005
    return CheckResult(name, title, ok, limit,
                       f"device time advanced {share:.1%} of wall time, "
                       f"{'monotonic' if mono else 'went back'}",
                       "" if ok else "device time does not advance as the sim image's should",
                       "" if ok else "the image's timer set-up (TIM2) and its stall rule",
                       board_only="the drift of the board's crystal against the host "
                                  "(a real-time mapping)")
