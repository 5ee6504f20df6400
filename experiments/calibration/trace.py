"""One measured contact trace, ready to fit, and the checks that keep bad traces out.

A :class:`ContactTrace` holds the samples *after* contact (time 0 = contact onset), the
initial temperatures it is modelled with, and which sample it was taken on.  Its
constructor rejects what no fit can use: non-finite or non-increasing times, too short a
record (truncated), a flat record (no information), readings outside the range a passive
contact can produce (non-physical).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from experiments.calibration.errors import CalibrationError

__all__ = ["ContactTrace", "MIN_DURATION_S", "MIN_SAMPLES", "MIN_TEMPERATURE_DIFFERENCE_C",
           "white_noise_estimate"]

#: A trace shorter than this after contact (s) is "truncated".
MIN_DURATION_S = 2.0
#: ... or with fewer samples after contact than this.
MIN_SAMPLES = 20
#: |T_S0 - T_M0| below this (K) carries too little signal to calibrate anything.
MIN_TEMPERATURE_DIFFERENCE_C = 2.0


def white_noise_estimate(y) -> float:
    """Robust standard deviation of the white noise on a smooth signal, same unit as ``y``.

    The median absolute successive difference / (√2 · 0.6745): insensitive to the smooth
    trend and to a few outliers.
    """
    d = np.diff(np.asarray(y, dtype=float))
    if d.size == 0:
        return 0.0
    return float(np.median(np.abs(d - np.median(d))) / (math.sqrt(2.0) * 0.6744897501960817))


@dataclass(frozen=True)
class ContactTrace:
    """A contact-temperature record on one sample.

    Parameters
    ----------
    time_s : array_like, s
        Times since contact onset; only samples with t > 0 are kept.
    temperature_C : array_like, °C
        Sensor readings at those times.
    skin_temperature_C : float, °C
        Initial skin temperature T_S0 (for this trace).
    material_temperature_C : float, °C
        Initial sample temperature T_M0.
    sample : str
        Key of the sample (one contact resistance is fitted per key).
    roughness_um : float or None, µm
        The sample's R_a, if known (start value of R, report).
    source : str
        Where the trace came from (file name), used in every message.
    roughness_id : int or None
        The protocol's sample id.

    Raises
    ------
    CalibrationError
        Truncated, flat or non-physical traces; the message names ``source`` and the field.
    """

    time_s: np.ndarray
    temperature_C: np.ndarray
    skin_temperature_C: float
    material_temperature_C: float
    sample: str
    roughness_um: float | None = None
    source: str = "trace"
    roughness_id: int | None = None
    meta: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        src = self.source
        t = np.asarray(self.time_s, dtype=float).ravel()
        y = np.asarray(self.temperature_C, dtype=float).ravel()
        if t.shape != y.shape:
            raise CalibrationError(f"{src}: time_s: expected as many values as contact_C "
                                   f"({y.size}), got {t.size}")
        if not np.all(np.isfinite(t)):
            raise CalibrationError(f"{src}: time_s: expected finite numbers, got a NaN or infinity")
        if not np.all(np.isfinite(y)):
            bad = int(np.flatnonzero(~np.isfinite(y))[0])
            raise CalibrationError(f"{src}: contact_C: expected finite readings, got {y[bad]!r} "
                                   f"at time_s = {t[bad]:g}")
        if t.size > 1 and not np.all(np.diff(t) > 0):
            raise CalibrationError(f"{src}: time_s: expected strictly increasing times")
        keep = t > 0
        t, y = t[keep], y[keep]
        for name in ("skin_temperature_C", "material_temperature_C"):
            v = getattr(self, name)
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise CalibrationError(f"{src}: {name}: expected a temperature in °C, got {v!r}") from None
            if not (math.isfinite(v) and -20.0 <= v <= 60.0):
                raise CalibrationError(f"{src}: {name}: expected a temperature between -20 and 60 °C, "
                                       f"got {v!r}")
            object.__setattr__(self, name, v)
        ts0, tm0 = self.skin_temperature_C, self.material_temperature_C
        if abs(ts0 - tm0) < MIN_TEMPERATURE_DIFFERENCE_C:
            raise CalibrationError(
                f"{src}: material_temperature_C: expected a sample at least "
                f"{MIN_TEMPERATURE_DIFFERENCE_C:g} K away from the skin ({ts0:g} °C), got {tm0!r}: "
                f"such a contact carries no usable signal")
        duration = float(t[-1]) if t.size else 0.0
        if t.size < MIN_SAMPLES or duration < MIN_DURATION_S:
            raise CalibrationError(
                f"{src}: time_s: expected a trace of at least {MIN_DURATION_S:g} s and {MIN_SAMPLES} "
                f"samples after contact, got {duration:.3g} s and {t.size} samples (truncated)")
        sigma = white_noise_estimate(y)
        lo, hi = min(ts0, tm0), max(ts0, tm0)
        tol = max(0.5, 6.0 * sigma)
        bad = np.flatnonzero((y < lo - tol) | (y > hi + tol))
        if bad.size:
            i = int(bad[0])
            raise CalibrationError(
                f"{src}: contact_C: expected readings between the sample ({tm0:g} °C) and the skin "
                f"({ts0:g} °C) temperatures (a passive contact cannot leave that range), got "
                f"{y[i]:.4g} °C at time_s = {t[i]:g} (non-physical)")
        w = max(1, t.size // 20)                       # block means: noise SD sigma / sqrt(w)
        means = y[: (t.size // w) * w].reshape(-1, w).mean(axis=1)
        span = float(np.ptp(means))
        if span < max(0.005 * (hi - lo), 6.0 * sigma / math.sqrt(w)):
            raise CalibrationError(
                f"{src}: contact_C: expected the reading to change after contact, got a flat trace "
                f"(range of {w}-sample means {span:.3g} K, noise {sigma:.2g} K, skin-sample "
                f"difference {hi - lo:.3g} K)")
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "temperature_C", y)
        object.__setattr__(self, "sample", str(self.sample))

    @property
    def n(self) -> int:
        """Number of samples after contact."""
        return int(self.time_s.size)

    @property
    def duration_s(self) -> float:
        """Time of the last sample, s."""
        return float(self.time_s[-1])

    @property
    def noise_C(self) -> float:
        """Robust white-noise estimate of the readings, °C."""
        return white_noise_estimate(self.temperature_C)
