"""A ContactTrace keeps truncated, flat and non-physical records out of the fit."""
import numpy as np
import pytest

from experiments.calibration import CalibrationError, ContactTrace, synthetic_trace
from experiments.calibration.trace import white_noise_estimate


def _good(n=200, rate=20.0):
    t = np.arange(1, n + 1) / rate
    return t, 24.0 + 2.0 * (1 - np.exp(-t))


def test_a_good_trace_is_kept_and_only_after_contact():
    t, y = _good()
    tr = ContactTrace(np.r_[-0.2, -0.1, 0.0, t], np.r_[24.0, 24.0, 24.0, y], 35.0, 24.0, "1.6", 1.6, "x.csv")
    assert tr.n == t.size and tr.time_s[0] > 0 and tr.duration_s == pytest.approx(10.0)


def test_truncated_trace():
    t, y = _good(n=30)          # 1.5 s
    with pytest.raises(CalibrationError, match=r"x\.csv: time_s: .*truncated"):
        ContactTrace(t, y, 35.0, 24.0, "1", source="x.csv")


def test_flat_trace():
    rng = np.random.default_rng(1)
    t, _ = _good()
    with pytest.raises(CalibrationError, match=r"x\.csv: contact_C: .*flat trace"):
        ContactTrace(t, 24.0 + 0.02 * rng.standard_normal(t.size), 35.0, 24.0, "1", source="x.csv")


def test_non_physical_trace_outside_the_initial_temperatures():
    t, y = _good()
    y = y.copy()
    y[50] = 41.0                # hotter than the skin: a passive contact cannot do that
    with pytest.raises(CalibrationError, match=r"x\.csv: contact_C: .*non-physical"):
        ContactTrace(t, y, 35.0, 24.0, "1", source="x.csv")


def test_nan_reading_and_bad_times_and_too_small_difference():
    t, y = _good()
    y2 = y.copy()
    y2[3] = np.nan
    with pytest.raises(CalibrationError, match="contact_C: expected finite readings"):
        ContactTrace(t, y2, 35.0, 24.0, "1")
    with pytest.raises(CalibrationError, match="time_s: expected strictly increasing"):
        ContactTrace(t[::-1], y, 35.0, 24.0, "1")
    with pytest.raises(CalibrationError, match="material_temperature_C: expected a sample at least 2 K"):
        ContactTrace(t, y, 25.0, 24.0, "1")
    with pytest.raises(CalibrationError, match="skin_temperature_C: expected a temperature"):
        ContactTrace(t, y, "warm", 24.0, "1")


def test_noise_estimate_of_the_stated_sensor_noise():
    tr = synthetic_trace(1e-3, 8e-4, rng=np.random.default_rng(5), duration_s=25.0)
    assert 0.018 < white_noise_estimate(tr.temperature_C) < 0.022
    # quantised to 1 mK
    np.testing.assert_allclose(tr.temperature_C * 1000, np.round(tr.temperature_C * 1000), atol=1e-6)
