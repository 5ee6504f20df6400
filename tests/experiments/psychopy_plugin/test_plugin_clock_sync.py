"""Clock mapping from heartbeat round trips (:mod:`experiments.psychopy_plugin.clock_sync`).

A synthetic device clock with a known offset, drift and step answers round trips with random
delays (seeded); the true offset is known by construction, so each estimate is checked against
it and against its own stated bound.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from experiments.psychopy_plugin.clock_sync import ClockMap, estimate_burst, sync_burst


class FakeLink:
    """Host clock + a device clock ``device = host + offset + drift (host - h0)``, floored to ``step``."""

    def __init__(self, offset, drift=0.0, step=0.01, h0=5000.0, rng=None, mean_delay=150e-6):
        self.offset, self.drift, self.step, self.h0 = offset, drift, step, h0
        self.now = h0
        self.rng = rng or np.random.default_rng(20261124)
        self.mean_delay = mean_delay

    def true_device(self, host):
        return host + self.offset + self.drift * (host - self.h0)

    def clock(self):
        self.now += 1e-6                          # reading the clock takes a microsecond
        return self.now

    def heartbeat(self):
        self.now += self.rng.exponential(self.mean_delay)    # request on its way
        d = self.true_device(self.now)
        if self.step:
            d = math.floor(d / self.step) * self.step
        self.now += self.rng.exponential(self.mean_delay)    # reply on its way
        return d


@pytest.mark.parametrize("step", [0.01, 0.001, 1e-6])
def test_burst_bounds_hold_the_true_offset_and_are_tight(step):
    link = FakeLink(offset=-1234.5678, step=step)
    b = sync_burst(link.heartbeat, link.clock, spacing_s=0)
    assert b.consistent
    assert b.resolution_s == pytest.approx(step, rel=1e-6)
    assert abs(b.offset_s - link.offset) <= b.half_width_s + 1e-9
    # ~0.3 ms round trips over > 3 steps: the bounds close to within a round trip
    assert b.half_width_s < 0.5e-3


def test_a_burst_that_spans_no_step_says_so_in_its_width():
    link = FakeLink(offset=10.0, step=0.01, h0=5000.0005)
    samples = []
    for _ in range(5):                            # 5 trips, well inside one 10 ms step
        t0 = link.clock(); d = link.heartbeat(); t1 = link.clock()
        samples.append((t0, d, t1))
    b = estimate_burst(samples, fallback_resolution_s=0.01)
    assert abs(b.offset_s - 10.0) <= b.half_width_s
    assert b.half_width_s > 3e-3                  # cannot be better than most of a step


def test_a_clock_that_jumps_is_reported_inconsistent():
    samples = [(0.0, 100.0, 0.001), (0.002, 200.0, 0.003)]      # 100 s jump within 2 ms
    b = estimate_burst(samples)
    assert not b.consistent


def test_two_bursts_give_the_drift_and_map_within_the_bound():
    drift = 80e-6                                 # 80 ppm, a poor crystal
    link = FakeLink(offset=42.0, drift=drift, step=0.01)
    first = sync_burst(link.heartbeat, link.clock, spacing_s=0)
    link.now += 20.0                              # a 20 s trial
    contact_host = link.now - 7.0
    last = sync_burst(link.heartbeat, link.clock, spacing_s=0)
    cmap = ClockMap.from_bursts(first, last)
    assert cmap.drift == pytest.approx(drift, abs=2 * (first.half_width_s + last.half_width_s) / 20)
    contact_dev = link.true_device(contact_host)
    assert abs(cmap.to_host(contact_dev) - contact_host) <= cmap.uncertainty_s + 1e-6
    assert cmap.uncertainty_s < 0.5e-3
    # with one burst only, the 80 ppm drift over 13 s (1 ms) is not accounted for
    single = ClockMap.from_bursts(first)
    assert abs(single.to_host(contact_dev) - contact_host) > 0.8e-3


def test_map_round_trip():
    cmap = ClockMap(host_ref_s=100.0, offset_s=-50.0, drift=1e-4, uncertainty_s=0.0)
    for h in (90.0, 100.0, 133.3):
        assert cmap.to_host(cmap.to_device(h)) == pytest.approx(h, abs=1e-9)


def test_no_round_trip_is_an_error():
    with pytest.raises(ValueError, match="at least one round trip"):
        estimate_burst([])


def test_a_clock_running_at_another_rate_is_unmapped_with_the_drift_in_the_reason():
    """The rate the issue's virtual-clock emulator showed (858,517 ppm), with tight bursts: the
    map refuses to map rather than state a sub-millisecond uncertainty."""
    link = FakeLink(offset=3.0, step=0.01)     # each burst steady, as a virtual clock between steps
    first = sync_burst(link.heartbeat, link.clock, spacing_s=0)
    link.now += 7.0
    link.offset += 0.858517 * (link.now - first.host_s)
    last = sync_burst(link.heartbeat, link.clock, spacing_s=0)
    assert first.consistent and last.consistent and max(first.half_width_s, last.half_width_s) < 4e-4
    cmap = ClockMap.from_bursts(first, last)
    assert cmap.unmapped is not None and cmap.unmapped.startswith("drift 85")
    assert "beyond the plausible 2000 ppm" in cmap.unmapped
    with pytest.raises(ValueError, match="device time not mapped: drift 85"):
        cmap.to_host(10.0)
    # the same bursts with a plausible drift map
    good = FakeLink(offset=3.0, drift=80e-6, step=0.01)
    first = sync_burst(good.heartbeat, good.clock, spacing_s=0)
    good.now += 7.0
    ok = ClockMap.from_bursts(first, sync_burst(good.heartbeat, good.clock, spacing_s=0))
    assert ok.unmapped is None and ok.max_residual_s <= ok.uncertainty_s


def test_a_burst_whose_clock_jumped_is_unmapped_and_small_jitter_widens_the_uncertainty():
    jumped = estimate_burst([(0.0, 100.0, 0.001), (0.002, 100.02, 0.003)])   # 20 ms jump in 2 ms
    cmap = ClockMap.from_bursts(jumped)
    assert cmap.unmapped.startswith("a burst's round trips disagree by ")
    # 0.4 ms of crossing (a late tick): mapped, uncertain by the whole crossing
    jitter = estimate_burst([(0.0, 10.0004, 0.0001), (0.0002, 10.0, 0.0003)], fallback_resolution_s=1e-6)
    assert not jitter.consistent
    cmap = ClockMap.from_bursts(jitter)
    assert cmap.unmapped is None and cmap.uncertainty_s == pytest.approx(2 * jitter.half_width_s)


def test_residuals_off_the_map_make_it_unmapped():
    """A device clock that runs at twice the host's rate inside each burst but whose bursts'
    offsets happen to agree: the round trips lie off the map by far more than it claims."""
    samples = lambda h: [(h + i * 1e-3, 50.0 + 2 * i * 1e-3, h + i * 1e-3 + 1e-4) for i in range(30)]  # noqa: E731
    first, last = estimate_burst(samples(0.0)), estimate_burst(samples(10.0))
    cmap = ClockMap.from_bursts(first, last)
    assert cmap.unmapped is not None


def test_the_pty_tests_explain_each_refusal_by_the_emulators_lateness_and_nothing_else():
    """The plugin's pty tests accept a refusal only when the emulator's worst tick was late
    enough to cause it (``_plugin_helpers.unexplained_refusal``): each reason the map gives
    must be one that helper reads, with the lateness it needs."""
    from _plugin_helpers import unexplained_refusal
    jumped = ClockMap.from_bursts(estimate_burst([(0.0, 100.0, 0.001), (0.002, 100.02, 0.003)]))
    crossed_ms = float(jumped.unmapped.split("disagree by ")[1].split(" ms")[0])
    assert crossed_ms > 5
    assert unexplained_refusal(jumped.unmapped, crossed_ms) is None
    assert unexplained_refusal(jumped.unmapped, 200.0) is None               # time was lost
    assert "worst tick was 2.0 ms late" in unexplained_refusal(jumped.unmapped, 2.0)
    samples = lambda h: [(h + i * 1e-3, 50.0 + 2 * i * 1e-3, h + i * 1e-3 + 1e-4) for i in range(30)]  # noqa: E731
    off = ClockMap.from_bursts(estimate_burst(samples(0.0)), estimate_burst(samples(10.0)))
    (residual,) = [p for p in off.unmapped.split("; ") if "outside the map's bounds" in p]
    excess_ms = (off.max_residual_s - off.uncertainty_s) * 1e3
    assert unexplained_refusal(residual, excess_ms / 2) is None
    assert unexplained_refusal(residual, 0.4) is not None
    assert unexplained_refusal(off.unmapped, excess_ms / 2) is not None    # it crossed, too
    link = FakeLink(offset=3.0, step=0.01)
    first = sync_burst(link.heartbeat, link.clock, spacing_s=0)
    link.now += 7.0
    link.offset += 0.01 * (link.now - first.host_s)
    drifting = ClockMap.from_bursts(first, sync_burst(link.heartbeat, link.clock, spacing_s=0))
    assert drifting.unmapped.startswith("drift ")
    assert unexplained_refusal(drifting.unmapped, 0.6) is None
    assert unexplained_refusal(drifting.unmapped, 0.3) is not None            # an on-time clock
    assert "unknown reason" in unexplained_refusal("no clock burst", 50.0)
