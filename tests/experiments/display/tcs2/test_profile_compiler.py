"""The TCS II profile compiler on hard profiles: segments against error, refusals, minimality."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

import stimuli
from experiments.errors import SafetyLimitError, UserInputError
from experiments.display.safety import SafetyLimits, profile_max_rate
from experiments.display.tcs2.profile_compiler import compile_profile

LIMITS = SafetyLimits(min_C=15.0, max_C=42.0, max_rate_C_per_s=10.0, neutral_C=32.0)


def _played(start_C, segments, t):
    """What the device plays, from the segments alone (independent of the compiler)."""
    kt, ky = [0.0], [start_C]
    for s in segments:
        kt.append(kt[-1] + s.steps * 0.01)
        ky.append(s.end_dC / 10)
    return np.interp(t, kt, ky)


def _check_device_rules(c, t, y, tol):
    assert 1 <= c.count <= 999
    for s in c.segments:
        assert 1 <= s.steps <= 999 and isinstance(s.end_dC, int)
        assert 150 <= s.end_dC <= 420
    assert sum(s.steps for s in c.segments) * 0.01 == pytest.approx(t[-1])
    played = _played(c.start_C, c.segments, t)
    dev = float(np.max(np.abs(played - y)))
    assert dev == pytest.approx(c.max_deviation_C, abs=1e-12)
    assert dev <= tol + 1e-9
    assert profile_max_rate(played, t[1] - t[0], 0.1) <= 10.0 + 0.1 + 1e-9
    return dev


def test_steps_at_the_rate_limit():
    # 32 -> 42 -> 32 -> 20 -> 32 °C, every ramp at exactly 10 °C/s, plateaus between
    t = np.arange(2001) * 0.01
    knots_t = [0, 1, 2, 4, 5, 7, 8.2, 12, 13.2, 20]
    knots_y = [32, 32, 42, 42, 32, 32, 20, 20, 32, 32]
    y = np.interp(t, knots_t, knots_y)
    c = compile_profile(t, y, limits=LIMITS, name="steps")
    _check_device_rules(c, t, y, 0.1)
    assert c.count == 9          # nine linear pieces, none longer than 9.99 s
    # at a tolerance below the resolution the knots (all on the device's grids) still fit
    c = compile_profile(t, y, limits=LIMITS, tolerance_C=0.01, name="steps")
    assert c.count == 9 and _check_device_rules(c, t, y, 0.01) < 1e-9


@pytest.mark.parametrize("roughness_m", [1.6e-6, 100e-6])
def test_paper_profiles_20_s_at_100_Hz(roughness_m):
    p = stimuli.target_profile(roughness=roughness_m, duration=20.0, rate=100.0)
    t, y = np.asarray(p.times), np.asarray(p.temperature)
    assert t.size == 2001
    counts = {}
    for tol in (0.1, 0.05):
        c = compile_profile(t, y, limits=LIMITS, tolerance_C=tol, name=f"{roughness_m}")
        _check_device_rules(c, t, y, tol)
        counts[tol] = c.count
    assert counts[0.05] >= counts[0.1]


def test_a_2_mK_ripple_is_three_segments_at_the_resolution_and_refused_at_1_mK():
    t = np.arange(2001) * 0.01
    y = 32.0 + 0.002 * np.sin(2 * np.pi * 5 * t)
    c = compile_profile(t, y, limits=LIMITS, name="ripple")
    _check_device_rules(c, t, y, 0.1)
    assert c.count == 3          # 20 s needs three segments of at most 9.99 s
    assert c.max_deviation_C == pytest.approx(0.002, abs=1e-6)
    with pytest.raises(UserInputError) as exc:
        compile_profile(t, y, limits=LIMITS, tolerance_C=0.001, name="ripple")
    msg = str(exc.value)
    assert "\n" not in msg and msg.startswith("ripple:") and "0.001 °C" in msg


def test_more_than_999_segments_is_refused_in_one_line():
    # a ±0.2 °C triangle of period 40 ms (4 °C/s over 0.1 s: within the rate limit)
    t = np.arange(2001) * 0.01
    y = 32.0 + np.interp(t % 0.04, [0, 0.01, 0.03, 0.04], [0, 0.2, -0.2, 0])
    with pytest.raises(UserInputError) as exc:
        compile_profile(t, y, limits=LIMITS, name="triangle")
    assert "more than 999 segments" in str(exc.value) and "\n" not in str(exc.value)


def test_the_safety_limits_apply_before_compiling():
    t = np.arange(101) * 0.01
    with pytest.raises(SafetyLimitError):
        compile_profile(t, np.full(101, 43.0), limits=LIMITS)
    with pytest.raises(SafetyLimitError):      # 20 °C in 0.1 s: 200 °C/s
        compile_profile(t, np.interp(t, [0, 0.5, 0.6, 1], [32, 32, 20, 20]), limits=LIMITS)
    # the device's maximum (Om) below the target: no segment end may exceed it
    y = np.interp(t, [0, 1], [32, 36])
    with pytest.raises(UserInputError):
        compile_profile(t, y, limits=LIMITS, max_C=35.0)


def test_start_where_the_probe_is():
    t = np.arange(101) * 0.01
    y = np.full(101, 35.5)
    c = compile_profile(t, y, limits=LIMITS, start_C=35.5)
    assert c.count == 1 and c.start_C == 35.5
    with pytest.raises(UserInputError):
        compile_profile(t, y, limits=LIMITS, start_C=32.0)


def _brute_force_min(t, y, tol):
    """Fewest segments by enumeration: breakpoints at samples, ends at 0.1 °C within tol."""
    n = len(t)
    cands = [[q for q in range(int(np.floor((v - tol) * 10)) - 1, int(np.ceil((v + tol) * 10)) + 2)
              if abs(q / 10 - v) <= tol + 1e-12] for v in y]
    s0 = int(round(y[0] * 10))
    for k in range(1, n):
        for inner in itertools.combinations(range(1, n - 1), k - 1):
            idx = (0,) + inner + (n - 1,)
            for vals in itertools.product(*[cands[i] for i in idx[1:]]):
                played = np.interp(t, t[list(idx)], [s0 / 10, *[v / 10 for v in vals]])
                if np.max(np.abs(played - y)) <= tol + 1e-12:
                    return k
    return None


@pytest.mark.parametrize("seed", [20261126, 7, 11])
def test_fewest_segments_against_brute_force(seed):
    rng = np.random.default_rng(seed)
    t = np.arange(7) * 0.01
    y = np.round(32.0 + np.cumsum(rng.uniform(-0.09, 0.09, 7)), 3)
    y[0] = 32.0
    lim = SafetyLimits(max_rate_C_per_s=100.0)
    c = compile_profile(t, y, limits=lim, tolerance_C=0.05)
    assert c.count == _brute_force_min(t, y, 0.05)
