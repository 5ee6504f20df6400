"""Host-side safety limits: every setpoint and profile is checked *before* anything is sent.

The device enforces its own limits as well (it clamps; see ``docs/display-protocol.md``); this
module is the first of the two layers and refuses instead of clamping, so that a protocol error is
found at the desk and never becomes a temperature on a finger.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from experiments.errors import SafetyLimitError, UserInputError

__all__ = ["SafetyLimits", "check_profile", "profile_max_rate", "LIMIT_BOUNDS"]

#: Smallest profile time step the protocol carries, s.
MIN_DT_S = 1e-3
#: Profile resolution on the wire, °C.
RESOLUTION_C = 0.01
#: Bounds of every :class:`SafetyLimits` field, and why (``docs/display-protocol.md`` §6).
#: The range: the skin-safe range a protocol file may name (a backend narrows it further at its
#: handshake). The rate: the protocol's largest setpoint step (1 °C a 10 ms tick). The window:
#: at most the device's own (10 ticks, 0.1 s), so that a profile the host passes is one the
#: device plays as uploaded (a longer window averages a step away: a 1000 s window let a 12 °C
#: step within 0.1 s through); at least one 10 ms device tick (the 0.01 °C resolution allowed
#: over every window is 0.01 °C / w: 1 °C/s at 10 ms, as much as the default limit at 1 ms).
LIMIT_BOUNDS = {
    "min_C": (5.0, 45.0), "max_C": (5.0, 45.0), "neutral_C": (5.0, 45.0),
    "max_rate_C_per_s": (0.0, 100.0), "rate_window_s": (0.01, 0.1),
}


def _num(v) -> str:
    """A value for a message: numbers (numpy's too) as plain Python numbers, others as repr."""
    if isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool):
        return repr(int(v) if isinstance(v, (int, np.integer)) else float(v))
    return repr(v)


@dataclass(frozen=True)
class SafetyLimits:
    """The safe range and rate of the pad temperature, as the protocol allows them.

    Parameters
    ----------
    min_C, max_C : float, °C
        Every setpoint must lie in ``[min_C, max_C]``.
    max_rate_C_per_s : float, °C/s
        Largest allowed rate of change, measured as ``|T(t + w) - T(t)| / w`` over the window
        ``w = rate_window_s`` (see Notes).
    neutral_C : float, °C
        The temperature the display holds between trials and returns to on any failure.
    rate_window_s : float, s
        Window of the rate measurement.

    Every field is bounded (:data:`LIMIT_BOUNDS`): the range within 5–45 °C, the rate
    0 < r ≤ 100 °C/s, the window 0.01–0.1 s; anything else raises :class:`UserInputError`.

    Notes
    -----
    The rate is measured over a window rather than between consecutive samples because the
    paper's interface profiles rise like :math:`\\sqrt{t}` after contact: their sample-to-sample
    rate grows without bound as the time step shrinks (32.6 °C/s in the first 10 ms of the 1.6 µm
    profile, 8.1 °C/s over its first 0.1 s), while the heat delivered to the skin does not.
    """

    min_C: float = 15.0
    max_C: float = 42.0
    max_rate_C_per_s: float = 10.0
    neutral_C: float = 32.0
    rate_window_s: float = 0.1

    def __post_init__(self):
        for name in ("min_C", "max_C", "max_rate_C_per_s", "neutral_C", "rate_window_s"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise UserInputError(f"SafetyLimits: {name}: expected a finite number, got {_num(v)}")
        for name in ("min_C", "max_C", "max_rate_C_per_s", "rate_window_s"):
            lo, hi = LIMIT_BOUNDS[name]
            v = getattr(self, name)
            low_ok = v > lo if name == "max_rate_C_per_s" else v >= lo
            if not (low_ok and v <= hi):
                rel = "<" if name == "max_rate_C_per_s" else "≤"
                raise UserInputError(f"SafetyLimits: {name}: expected {_num(lo)} {rel} value ≤ "
                                     f"{_num(hi)}, got {_num(v)}")
        if not self.min_C < self.max_C:
            raise UserInputError(f"SafetyLimits: min_C, max_C: expected min_C < max_C, got "
                                 f"{_num(self.min_C)}, {_num(self.max_C)}")
        self.check_setpoint(self.neutral_C, "neutral_C")

    def check_setpoint(self, value_C: float, field: str = "setpoint") -> float:
        """Return ``value_C`` as a float if it lies in the safe range, else raise.

        Raises
        ------
        SafetyLimitError
            If the value is not finite or lies outside ``[min_C, max_C]``.
        """
        try:
            v = float(value_C)
        except (TypeError, ValueError):
            raise SafetyLimitError(f"display: {field}: expected a temperature {self.min_C} ≤ T ≤ "
                                   f"{self.max_C} °C, got {value_C!r}") from None
        if not (math.isfinite(v) and self.min_C <= v <= self.max_C):
            raise SafetyLimitError(f"display: {field}: expected {self.min_C} ≤ T ≤ {self.max_C} °C, "
                                   f"got {v!r}")
        return v


def profile_max_rate(target_C, dt_s: float, window_s: float) -> float:
    """Largest span of the profile over any window of length ``w``, divided by ``w``, °C/s.

    The span of a window is ``max T - min T`` over all its samples, i.e. the largest
    ``|T(t + k dt) - T(t)|`` for every lag ``0 < k dt ≤ w``, not only at the lag ``w``: a
    profile alternating 15↔42 °C every 10 ms has equal ends on every 0.1 s window and is still
    27 °C/0.1 s fast. The device limits its setpoints exactly so (the setpoints of any
    ``RATE_WINDOW_TICKS`` + 1 ticks span at most the rate times the window), so a profile this
    check passes is one the device plays as uploaded.

    ``w`` is ``window_s`` rounded to a whole number (≥ 1) of samples; a profile shorter than the
    window is measured over its full length.
    """
    y = np.asarray(target_C, dtype=float)
    if y.size < 2:
        return 0.0
    w = max(1, min(int(round(window_s / dt_s)), y.size - 1))
    span = max(float(np.max(np.abs(y[k:] - y[:-k]))) for k in range(1, w + 1))
    return span / (w * dt_s)


def check_profile(times_s, target_C, limits: SafetyLimits, *, start_C: float | None = None,
                  max_points: int | None = None) -> tuple[float, np.ndarray]:
    """Validate a target profile; return ``(dt_s, target_C as float array)``.

    Parameters
    ----------
    times_s : array_like, s
        Uniform sample times starting at 0, step ≥ 1 ms.
    target_C : array_like, °C
        Same length as ``times_s``.
    limits : SafetyLimits
    start_C : float, °C, optional
        Temperature the pad holds before the profile starts (not checked for rate: the device
        approaches the first sample at the limited rate while armed).
    max_points : int, optional
        The device's capacity.

    Raises
    ------
    UserInputError
        Malformed times (not uniform, not from 0, step < 1 ms, length mismatch).
    SafetyLimitError
        A sample outside the range, or a rate above the limit.
    """
    t = np.asarray(times_s, dtype=float)
    y = np.asarray(target_C, dtype=float)
    if t.ndim != 1 or y.ndim != 1 or t.size != y.size or t.size < 2:
        raise UserInputError(f"display: profile: expected times_s and target_C of the same length "
                             f"≥ 2, got {t.shape} and {y.shape}")
    if max_points is not None and t.size > max_points:
        raise UserInputError(f"display: profile: expected at most {max_points} points, got {t.size}")
    if not np.all(np.isfinite(t)) or abs(t[0]) > 1e-9:
        raise UserInputError(f"display: profile.times_s: expected finite times from 0, got first "
                             f"{float(t[0])!r}")
    dt = (t[-1] - t[0]) / (t.size - 1)
    if dt < MIN_DT_S - 1e-12:
        raise UserInputError(f"display: profile.times_s: expected a step ≥ {MIN_DT_S} s, got "
                             f"{float(dt):.6g} s")
    if np.max(np.abs(np.diff(t) - dt)) > 1e-6 * max(dt, 1e-3):
        raise UserInputError("display: profile.times_s: expected uniform steps, got steps from "
                             f"{float(np.min(np.diff(t))):.6g} to {float(np.max(np.diff(t))):.6g} s")
    bad = ~np.isfinite(y) | (y < limits.min_C) | (y > limits.max_C)
    if bad.any():
        i = int(np.argmax(bad))
        raise SafetyLimitError(f"display: profile.target_C[{i}]: expected {limits.min_C} ≤ T ≤ "
                               f"{limits.max_C} °C, got {float(y[i])!r}")
    rate = profile_max_rate(y, dt, limits.rate_window_s)
    if rate > limits.max_rate_C_per_s * (1 + 1e-9) + RESOLUTION_C / limits.rate_window_s:
        raise SafetyLimitError(f"display: profile.target_C: expected a rate ≤ "
                               f"{limits.max_rate_C_per_s} °C/s over {limits.rate_window_s} s, "
                               f"got {rate:.3g} °C/s")
    if start_C is not None:
        limits.check_setpoint(start_C, "start_C")
    return float(dt), y
