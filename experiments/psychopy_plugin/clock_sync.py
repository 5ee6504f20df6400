"""Device time ↔ host (PsychoPy) time, from acknowledged heartbeat round trips.

A HEARTBEAT reply carries the device's clock (µs) at the moment it handled the command, which
lies between the host times ``t0`` (before the write) and ``t1`` (after the reply was read). A
device clock that counts in steps of ``resolution`` (the emulator's 10 ms tick; 1 µs on a
device that stamps with its microsecond timer) reports the last step *before* that moment. So
each round trip bounds the offset ``o = device − host``::

    r − t1  ≤  o  <  r + resolution − t0

and a burst of round trips narrows the interval to about one round trip once it spans a step
boundary (the samples just after a boundary bound ``o`` from below, those just before one from
above). This is the bounds intersection of NTP-style clock filters, exact rather than averaged:
it holds whatever the delays, and an empty intersection says the device's clock jumped.

Two bursts (before a trial and after it) give the offset at each end and the drift between.
The resolution is learned from the replies themselves (the greatest common divisor of their
differences), so nothing about the device needs configuring. Standard library only.

A map checks its own plausibility (:meth:`ClockMap.from_bursts`): a burst whose bounds cross
by more than :data:`MAX_CROSSING_S` (a smaller crossing is the device clock's jitter and counts
in the uncertainty), a drift beyond :data:`MAX_DRIFT_PPM` by more than its own uncertainty (a crystal drifts well under 100 ppm; a clock
that runs at another rate, such as an emulator on a virtual clock, does not keep real time), or
a round trip the map puts outside its own bounds by more than the map's uncertainty (the
residuals) makes the map *unmapped*, with the reason in :attr:`ClockMap.unmapped`: no time is
mapped through it.
"""
from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field
from functools import reduce
from statistics import median

__all__ = ["SyncBurst", "ClockMap", "sync_burst", "estimate_burst", "MAX_DRIFT_PPM"]

#: Largest plausible drift of a device clock against the host's, ppm: 20 times a poor crystal's
#: 100 ppm (a ceramic resonator's 0.5 % is not a clock to time a contact with).
MAX_DRIFT_PPM = 2000.0
#: Largest crossing of a burst's bounds still taken as the device clock's jitter (an in-process
#: emulator's tick thread woken late on a busy host: up to about 2 ms), s; beyond it the clock
#: jumped. A crossing's full width counts in the map's uncertainty.
MAX_CROSSING_S = 5e-3


@dataclass(frozen=True)
class SyncBurst:
    """The device-minus-host offset over one burst of round trips.

    Attributes
    ----------
    host_s : float, s
        Host time the offset refers to (the middle of the burst).
    offset_s : float, s
        Device time minus host time (the middle of the bounds).
    half_width_s : float, s
        Half the width of the bounds: the offset is within ``offset_s ± half_width_s``.
    resolution_s : float, s
        The device clock's step, as learned from the replies.
    rtt_median_s : float, s
        Median round trip.
    n : int
        Round trips in the burst.
    consistent : bool
        False if the bounds did not intersect (a clock that jumped, or a reply stamped outside
        its round trip); ``offset_s`` is then the middle of the crossed bounds.
    """

    host_s: float
    offset_s: float
    half_width_s: float
    resolution_s: float
    rtt_median_s: float
    n: int
    consistent: bool = True
    samples: tuple = field(default=(), repr=False, compare=False)


def _resolution_us(device_us: list[int], fallback_us: int) -> int:
    diffs = [abs(d - device_us[0]) for d in device_us[1:] if d != device_us[0]]
    if not diffs:
        return fallback_us
    return max(1, reduce(math.gcd, diffs))


def estimate_burst(samples, *, fallback_resolution_s: float = 1e-6) -> SyncBurst:
    """Intersect the bounds of round trips ``(t0_s, device_s, t1_s)``.

    Parameters
    ----------
    samples : sequence of (float, float, float)
        Host time before the request, device time in the reply, host time after the reply (s).
    fallback_resolution_s : float, s
        Device clock step to assume when all replies carry the same time.

    Returns
    -------
    SyncBurst

    Examples
    --------
    A device 100 s ahead of the host whose clock steps every 10 ms, probed every 0.3 ms:

    >>> trips = []
    >>> for i in range(80):
    ...     t0 = 1000.0 + i * 0.0003
    ...     w = t0 + 0.0001                       # the device handles it 0.1 ms later
    ...     dev = math.floor((w + 100.0) / 0.01) * 0.01
    ...     trips.append((t0, dev, t0 + 0.0002))
    >>> b = estimate_burst(trips)
    >>> round(b.resolution_s, 6), abs(b.offset_s - 100.0) < 2e-4, b.half_width_s < 2e-4
    (0.01, True, True)
    """
    if not samples:
        raise ValueError("estimate_burst: expected at least one round trip, got none")
    dev_us = [int(round(d * 1e6)) for _, d, _ in samples]
    res_us = _resolution_us(dev_us, max(1, int(round(fallback_resolution_s * 1e6))))
    # a device clock cannot step by more than the burst lasted: a larger step is a jump
    span = max(s[2] for s in samples) - min(s[0] for s in samples)
    res = min(res_us * 1e-6, max(span, fallback_resolution_s))
    lo = max(d - t1 for t0, d, t1 in samples)
    hi = min(d + res - t0 for t0, d, t1 in samples)
    consistent = lo <= hi
    host = 0.5 * (min(s[0] for s in samples) + max(s[2] for s in samples))
    return SyncBurst(host_s=host, offset_s=0.5 * (lo + hi), half_width_s=0.5 * abs(hi - lo),
                     resolution_s=res, rtt_median_s=median(t1 - t0 for t0, _, t1 in samples),
                     n=len(samples), consistent=consistent,
                     samples=tuple((float(a), float(b), float(c)) for a, b, c in samples))


def sync_burst(heartbeat, clock, *, duration_s: float = 0.03, min_samples: int = 8,
               max_samples: int = 1000, spacing_s: float = 1e-4, target_half_width_s: float = 2e-4,
               max_duration_s: float = 0.15, fallback_resolution_s: float = 1e-6) -> SyncBurst:
    """Run acknowledged heartbeats back to back and intersect their bounds.

    The burst lasts ``duration_s``, and longer (up to ``max_duration_s``) while the bounds are
    wider than ``2 * target_half_width_s``: on a loaded machine a round trip delayed by the
    scheduler only loosens its own bounds, so probing on finds the tight ones.

    Parameters
    ----------
    heartbeat : callable
        One acknowledged heartbeat, returning the device time, s
        (:meth:`experiments.display.ThermalDisplay.heartbeat`).
    clock : callable
        The host clock, s (PsychoPy's ``psychopy.clock.getTime``).
    duration_s : float, s
        Shortest burst: at least three steps of a 10 ms device clock.
    min_samples, max_samples : int
    spacing_s : float, s
        Least time between the starts of two round trips (an in-process emulator answers in
        10 µs: unpaced, the burst would end before it spans a step of the device clock).
    target_half_width_s, max_duration_s : float, s
        Probe on, up to ``max_duration_s``, until the half-width is at most this.

    Returns
    -------
    SyncBurst
    """
    samples = []
    start = clock()
    burst = None
    while len(samples) < max_samples:
        elapsed = clock() - start
        if len(samples) >= min_samples and elapsed >= duration_s:
            if elapsed >= max_duration_s:
                break
            if len(samples) % 8 == 0:
                burst = estimate_burst(samples, fallback_resolution_s=fallback_resolution_s)
                if burst.half_width_s <= target_half_width_s:
                    break
        t0 = clock()
        d = heartbeat()
        t1 = clock()
        samples.append((t0, d, t1))
        while clock() - t0 < spacing_s:
            time.sleep(spacing_s / 4)
    return estimate_burst(samples, fallback_resolution_s=fallback_resolution_s)


@dataclass(frozen=True)
class ClockMap:
    """A linear map from device time to host time, from one or two bursts.

    ``host = device − (offset_s + drift · (host − host_ref_s))``, solved exactly.

    Attributes
    ----------
    host_ref_s : float, s
        Host time of the first burst.
    offset_s : float, s
        Device minus host at ``host_ref_s``.
    drift : float
        Rate of change of the offset (s per s; 0 with a single burst).
    uncertainty_s : float, s
        Largest half-width of the bursts used: the bound on the error of a mapped time between
        them, if the drift is linear.
    unmapped : str or None
        Why the map is not plausible (then :meth:`to_host` refuses); None for a usable map.
    max_residual_s : float or None, s
        Largest distance of a round trip's bounds from the map (0 when every round trip of the
        bursts agrees with it).
    """

    host_ref_s: float
    offset_s: float
    drift: float
    uncertainty_s: float
    unmapped: str | None = None
    max_residual_s: float | None = None

    @classmethod
    def from_bursts(cls, first: SyncBurst, last: SyncBurst | None = None, *,
                    max_drift_ppm: float = MAX_DRIFT_PPM) -> "ClockMap":
        """The map through one burst (offset) or two (offset and drift), checked.

        Parameters
        ----------
        first, last : SyncBurst
        max_drift_ppm : float, ppm
            Largest plausible drift (:data:`MAX_DRIFT_PPM`).
        """
        bursts = (first,) if last is None or last.host_s - first.host_s < 1e-3 else (first, last)
        # a burst whose bounds crossed: its offset is known only to the crossing's full width
        uncertainty = max(b.half_width_s if b.consistent else 2 * b.half_width_s for b in bursts)
        drift = 0.0 if len(bursts) == 1 else \
            (last.offset_s - first.offset_s) / (last.host_s - first.host_s)
        cmap = cls(first.host_s, first.offset_s, drift, uncertainty)
        residual = max(cmap._residual(b) for b in bursts)
        why = []
        crossed = max((2 * b.half_width_s for b in bursts if not b.consistent), default=0.0)
        if crossed > MAX_CROSSING_S:
            why.append(f"a burst's round trips disagree by {crossed * 1e3:.2f} ms (the device "
                       "clock jumped, or a reply was stamped outside its round trip)")
        # the drift is known to within the bursts' uncertainties over the time between them
        drift_err = 0.0 if len(bursts) == 1 else 2 * uncertainty / (last.host_s - first.host_s)
        if (abs(drift) - drift_err) * 1e6 > max_drift_ppm:
            why.append(f"drift {drift * 1e6:.0f} ppm, beyond the plausible {max_drift_ppm:g} ppm "
                       "(the device clock does not keep real time: an emulator on a virtual "
                       "clock?)")
        if residual > uncertainty + 1e-4:
            why.append(f"round trips up to {residual * 1e3:.2f} ms outside the map's bounds "
                       f"(stated uncertainty {uncertainty * 1e3:.2f} ms): the clocks do not run "
                       "at a steady rate")
        return cls(cmap.host_ref_s, cmap.offset_s, drift, uncertainty,
                   "; ".join(why) or None, residual)

    def _residual(self, burst: SyncBurst) -> float:
        """How far, at most, the map's offset lies outside a round trip's bounds, s."""
        worst = 0.0
        for t0, d, t1 in burst.samples:
            lo, hi = d - t1, d + burst.resolution_s - t0
            o = self.to_device(0.5 * (t0 + t1)) - 0.5 * (t0 + t1)
            worst = max(worst, lo - o, o - hi)
        return worst

    def to_host(self, device_s: float) -> float:
        """Host time at which the device's clock read ``device_s``.

        Raises
        ------
        ValueError
            When the map is :attr:`unmapped` (the reason in the message).
        """
        if self.unmapped is not None:
            raise ValueError(f"device time not mapped: {self.unmapped}")
        # device = host + offset + drift (host - ref)  =>  host = (device - offset + drift ref) / (1 + drift)
        return (device_s - self.offset_s + self.drift * self.host_ref_s) / (1.0 + self.drift)

    def to_device(self, host_s: float) -> float:
        """Device time at host time ``host_s``."""
        return host_s + self.offset_s + self.drift * (host_s - self.host_ref_s)

    def to_dict(self) -> dict:
        return asdict(self)
