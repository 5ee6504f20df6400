"""Tests of experiments.profile_rate: slowing a profile to the display's rate limit."""
from __future__ import annotations

import numpy as np
import pytest

from experiments.display.safety import SafetyLimits, check_profile, profile_max_rate
from experiments.profile_rate import limit_rate, window_rate


def test_window_rate_is_the_displays_measure():
    y = np.sqrt(np.arange(500) / 100.0) * 3.0 + 20.0
    assert window_rate(y, 0.01, 0.1) == profile_max_rate(y, 0.01, 0.1)
    # a 1 K step over one sample, measured over 10 samples: 1 K / 0.1 s
    step = np.r_[np.zeros(20), np.ones(20)]
    assert window_rate(step, 0.01, 0.1) == pytest.approx(10.0)


def test_a_profile_within_the_limit_is_returned_unchanged():
    y = 20.0 + 0.05 * np.arange(100)          # 5 °C/s at 100 Hz
    out, change = limit_rate(y, 0.01, 10.0)
    assert change == 0.0 and np.array_equal(out, y)


def test_a_fast_fall_is_slowed_to_pass_the_displays_check_with_half_the_one_sided_lag():
    # 4 K fall in 0.2 s (20 °C/s) then flat; the display allows 10 °C/s over 0.1 s.
    t = np.arange(301) * 0.01
    y = np.round(np.where(t < 0.2, 30.0 - 20.0 * t, 26.0), 2)
    out, change = limit_rate(y, 0.01, 10.0)
    assert window_rate(out, 0.01, 0.1) <= 10.0
    check_profile(t, out, SafetyLimits())            # the display's own check accepts it
    assert np.all(np.abs(np.round(out / 0.01) - out / 0.01) < 1e-6)   # on the 0.01 °C grid
    # slewing at 9.9 °C/s takes 4/9.9 = 0.404 s instead of 0.2 s; a one-sided limiter lags by
    # up to (20 - 9.9) * 0.2 = 2.02 K, the forward-backward mean by half of it
    assert change == pytest.approx(0.5 * (20.0 - 9.9) * 0.2, abs=0.02)
    assert out[-1] == pytest.approx(26.0) and out[0] < 30.0


def test_bad_arguments():
    with pytest.raises(ValueError, match="max_rate_C_per_s"):
        limit_rate(np.r_[np.zeros(20), 5.0, np.zeros(20)], 0.01, 0.05)
    with pytest.raises(ValueError, match="positive"):
        limit_rate(np.r_[0.0, 5.0], 0.0, 10.0)


def test_the_slew_enters_the_uploaded_profiles_error_bound():
    # compensated 3#/4# need the rate limit: what it changed is part of how far the uploaded
    # profile may be from the replay it names (error_bound_C of profile_uploaded)
    from experiments.protocol import load_protocol
    from experiments.session.setup import simulated_target_profile
    from experiments.simulation.replay import protocol_variant
    proto = protocol_variant(load_protocol("roughness_recognition"), "compensated")
    slewed = 0
    for sample in proto.samples:
        prof = simulated_target_profile(proto, {}, "A", None, sample.id, sample.roughness_um)
        change = prof.parameters["rate_limited_max_change_C"]
        unslewed = simulated_target_profile(proto, {}, "A", None, sample.id, sample.roughness_um)
        assert prof.error_bound == pytest.approx(unslewed._prof.error_bound + change)
        assert np.max(np.abs(prof.temperature - prof._prof.temperature)) <= prof.error_bound
        slewed += change > 0.1
    assert slewed >= 2                                        # 3# and 4#: 0.26 and 0.16 K
