"""Per-participant calibration: fit contact resistances and skin thickness to traces.

The paper's Remark 3: initial skin temperatures and contact resistances differ between
people; "we can manage to measure them ... as soon as they are determined, the theoretical
profiles are then gotten".  This package makes that a step of the product:

>>> import numpy as np
>>> from experiments.calibration import synthetic_traces, fit_traces
>>> traces = synthetic_traces([6.5e-4, 1.6e-3], 800e-6, duration_s=10.0,
...                           rng=np.random.default_rng(1))   # 0.02 °C noise, 1 mK steps
>>> fit = fit_traces(traces)              # 3 mm steel, sensor on the sample surface
>>> L = fit.skin_thickness
>>> bool(L.low < 800e-6 < L.high), bool(abs(L.value / 800e-6 - 1) < 0.01)
(True, True)

Modules: ``model`` (exact forward model of the sensor reading, sensor placement),
``trace`` (a checked trace), ``problem`` (the residuals and Jacobian in the fit's
coordinates), ``fit`` (least squares + identifiability checks), ``planning`` (the contact as a
scene of the planner),
``intervals`` (profile likelihood, bootstrap), ``synthetic`` (noisy model traces),
``session_traces`` (read a session directory), ``report`` (PNG + tables),
``writeback`` (the participant record's ``calibration`` field, and
:func:`calibrated_profile_parameters` for later simulated trials).
"""
from experiments.calibration.errors import CalibrationError, CalibrationRefused
from experiments.calibration.fit import BOUNDS, CalibrationFit, FitProblem, Parameter, fit_traces
from experiments.calibration.model import (SENSOR_SIDES, ContactSetup, ResponseGrid, Sensor,
                                           sensor_response, sensor_temperature)
from experiments.calibration.report import fit_summary, write_report
from experiments.calibration.session_traces import SessionTraces, load_session_traces
from experiments.calibration.synthetic import (NOISE_C, RATE_HZ, RESOLUTION_C, synthetic_trace,
                                               synthetic_traces)
from experiments.calibration.trace import ContactTrace
from experiments.calibration.writeback import (calibrated_profile_parameters, calibration_record,
                                               write_participant_calibration)

__all__ = [
    "CalibrationError", "CalibrationRefused", "CalibrationFit", "FitProblem", "Parameter", "BOUNDS",
    "fit_traces", "Sensor", "ContactSetup", "ResponseGrid", "SENSOR_SIDES", "sensor_response",
    "sensor_temperature", "ContactTrace", "synthetic_trace", "synthetic_traces", "NOISE_C",
    "RESOLUTION_C", "RATE_HZ", "SessionTraces", "load_session_traces", "write_report",
    "fit_summary", "calibration_record", "write_participant_calibration",
    "calibrated_profile_parameters",
]
