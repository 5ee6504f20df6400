"""Slowing a target profile down to the display's rate limit (``[simulation] rate_limit = "slew"``).

The display refuses a profile whose rate ``|T(t + w) - T(t)| / w`` exceeds
``[display] max_rate_C_per_s`` (:mod:`experiments.display.safety`). A compensated target
(``target_side = "compensated"``) starts with a fast fall for rough samples (13.5 °C/s over
0.1 s for 50 µm), so a protocol may ask the session to limit it: :func:`limit_rate` returns the
mean of the profile slew-limited forwards and backwards (each sample moves at most ``rate * dt``
from its neighbour), which halves the largest deviation of a one-sided limiter, quantised back to
the display's resolution. Profiles within the limit are returned unchanged.
"""
from __future__ import annotations

import numpy as np

from experiments.display.safety import profile_max_rate

__all__ = ["limit_rate", "window_rate"]

#: Largest ``|T(t + w) - T(t)| / w`` of a uniformly sampled profile, °C/s: the display's own
#: check (:func:`experiments.display.safety.profile_max_rate`), so "within the limit" here and
#: at upload cannot disagree.
window_rate = profile_max_rate


def _slew(x: np.ndarray, step: float) -> np.ndarray:
    y = x.copy()
    for i in range(1, y.size):
        lo, hi = y[i - 1] - step, y[i - 1] + step
        y[i] = lo if y[i] < lo else hi if y[i] > hi else y[i]
    return y


def limit_rate(target_C, dt_s: float, max_rate_C_per_s: float, *, window_s: float = 0.1,
               resolution_C: float = 0.01) -> tuple[np.ndarray, float]:
    """The profile slowed to ``max_rate_C_per_s``, and its largest change.

    Parameters
    ----------
    target_C : array_like, °C
        Uniformly sampled profile.
    dt_s : float, s
        Its time step.
    max_rate_C_per_s : float, °C/s
        The display's limit.
    window_s : float, s
        The display's rate window (``SafetyLimits.rate_window_s``).
    resolution_C : float, °C
        The profile's resolution; the result is rounded to it, with the slew rate lowered by
        ``resolution_C / window_s`` so that the rounding cannot push it over the limit.

    Returns
    -------
    limited : ndarray, °C
        ``target_C`` itself (as floats) if its :func:`window_rate` is within the limit.
    max_change_C : float, K
        ``max |limited - target_C|`` (0.0 when unchanged).
    """
    x = np.asarray(target_C, dtype=float)
    if not (max_rate_C_per_s > 0 and dt_s > 0 and window_s > 0 and resolution_C > 0):
        raise ValueError(f"limit_rate: expected positive dt_s, max_rate_C_per_s, window_s and "
                         f"resolution_C, got {dt_s!r}, {max_rate_C_per_s!r}, {window_s!r}, "
                         f"{resolution_C!r}")
    if window_rate(x, dt_s, window_s) <= max_rate_C_per_s:
        return x, 0.0
    rate = max_rate_C_per_s - resolution_C / window_s
    if rate <= 0:
        raise ValueError(f"limit_rate: max_rate_C_per_s: expected more than the rounding's "
                         f"{resolution_C / window_s:g} °C/s, got {max_rate_C_per_s!r}")
    step = rate * dt_s
    mean = 0.5 * (_slew(x, step) + _slew(x[::-1], step)[::-1])
    limited = np.round(mean / resolution_C) * resolution_C
    return limited, float(np.max(np.abs(limited - x)))
