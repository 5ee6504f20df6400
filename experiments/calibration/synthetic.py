"""Synthetic contact traces: the exact model plus a stated sensor noise (tests, benchmark).

Noise model (stated, an assumption about a thin-film Pt sensor read by a 24-bit ADC):
independent Gaussian white noise of SD ``noise_C`` (default 0.02 °C) on each sample, then
quantisation to ``resolution_C`` (default 0.001 °C = 1 mK).  Sampling at ``rate_Hz``
(default 20 Hz) from 1/rate after contact to ``duration_s``.
"""
from __future__ import annotations

import numpy as np

from experiments.calibration.model import ContactSetup, sensor_temperature
from experiments.calibration.trace import ContactTrace

__all__ = ["synthetic_trace", "synthetic_traces", "NOISE_C", "RESOLUTION_C", "RATE_HZ"]

NOISE_C = 0.02
RESOLUTION_C = 0.001
RATE_HZ = 20.0


def synthetic_trace(resistance: float, skin_thickness: float, *, setup: ContactSetup | None = None,
                    skin_temperature: float = 35.0, material_temperature: float = 24.0,
                    duration_s: float = 25.0, rate_Hz: float = RATE_HZ, noise_C: float = NOISE_C,
                    resolution_C: float = RESOLUTION_C, rng=None, sample: str = "1",
                    roughness_um: float | None = None, roughness_id: int | None = None) -> ContactTrace:
    """One noisy trace of the exact model.

    Parameters
    ----------
    resistance : float, m² K/W
    skin_thickness : float, m
    setup : ContactSetup, optional
        Default: 3 mm steel, material-side sensor.
    skin_temperature, material_temperature : float, °C
    duration_s : float, s
    rate_Hz : float, Hz
    noise_C : float, °C
        SD of the white noise.
    resolution_C : float, °C
        Quantisation step (0: none).
    rng : numpy.random.Generator, optional
    sample, roughness_um, roughness_id :
        Passed to :class:`ContactTrace`.

    Returns
    -------
    ContactTrace
    """
    setup = setup or ContactSetup()
    rng = rng if rng is not None else np.random.default_rng(0)
    n = int(round(duration_s * rate_Hz))
    t = np.arange(1, n + 1) / rate_Hz
    y = sensor_temperature(t, resistance, skin_thickness, skin_temperature, material_temperature, setup)
    y = y + noise_C * rng.standard_normal(n)
    if resolution_C > 0:
        y = np.round(y / resolution_C) * resolution_C
    return ContactTrace(t, y, skin_temperature, material_temperature, sample, roughness_um,
                        source=f"synthetic[{sample}]", roughness_id=roughness_id)


def synthetic_traces(resistances, skin_thickness: float, *, roughness_um=None, repetitions: int = 1,
                     rng=None, **kwargs) -> list[ContactTrace]:
    """Traces on several samples (one R each, one shared L), ``repetitions`` per sample.

    Parameters
    ----------
    resistances : sequence of float, m² K/W
        One per sample; samples are named "1", "2", ...
    skin_thickness : float, m
    roughness_um : sequence of float, optional
    repetitions : int
    rng : numpy.random.Generator, optional
    **kwargs
        Passed to :func:`synthetic_trace`.
    """
    rng = rng if rng is not None else np.random.default_rng(0)
    out = []
    for rep in range(repetitions):
        for k, R in enumerate(resistances):
            ra = None if roughness_um is None else roughness_um[k]
            out.append(synthetic_trace(R, skin_thickness, rng=rng, sample=str(k + 1),
                                       roughness_um=ra, roughness_id=k + 1, **kwargs))
    return out
