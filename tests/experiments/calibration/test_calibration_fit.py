"""Recovery of known parameters from synthetic traces, interval coverage, refusals.

Synthetic traces: the exact model (independently checked in test_calibration_model.py) plus
the stated sensor noise, 0.02 °C white Gaussian then 1 mK quantisation, 20 Hz unless stated.
True resistances: Eq. 5 (stimuli.contact_resistance) for the paper's 1#-4# samples.
"""
import numpy as np
import pytest

from experiments.calibration import (CalibrationRefused, ContactSetup, Sensor, fit_traces,
                                     synthetic_traces)
from stimuli import contact_resistance, material

RA_UM = [1.6, 12.5, 50.0, 100.0]
R_TRUE = [float(contact_resistance(r * 1e-6)) for r in RA_UM]
L_TRUE = 800e-6


def _check_recovered(fit, r_true, l_true, rtol):
    """Estimates within ``rtol`` of the truth, and the truth within twice the 95 % interval's
    half-width (about 4 standard errors: a single data set misses that with p ~ 1e-4, while
    the plain 95 % interval misses 1 in 20; coverage itself is tested over many seeds)."""
    for p, truth in [*zip(fit.resistances(), r_true), (fit.skin_thickness, l_true)]:
        assert abs(p.value / truth - 1) < rtol, (p, truth)
        half = (np.log(p.high) - np.log(p.low)) / 2
        assert abs(np.log(p.value / truth)) <= 2 * half, (p, truth)


@pytest.mark.parametrize("sensor,D", [(Sensor("material"), 3e-3), (Sensor("skin"), 3e-3),
                                      (Sensor.lumped(), 3e-3), (Sensor("material"), None)])
def test_recovers_resistances_and_skin_thickness(sensor, D):
    setup = ContactSetup(material("stainless_steel", thickness=D), sensor)
    traces = synthetic_traces(R_TRUE, L_TRUE, roughness_um=RA_UM, setup=setup, duration_s=25.0,
                              rng=np.random.default_rng(20261122))
    fit = fit_traces(traces, setup)
    _check_recovered(fit, R_TRUE, L_TRUE, rtol=0.02)
    assert 0.018 < fit.sigma_C < 0.022                   # the noise that was put in
    assert fit.interval_method == "profile" and fit.level == 0.95
    assert fit.diagnostics["jacobian_rank"] == 5


def test_recovers_initial_skin_temperature_too():
    traces = synthetic_traces(R_TRUE[:2], 1.1e-3, roughness_um=RA_UM[:2], skin_temperature=35.6,
                              duration_s=25.0, rng=np.random.default_rng(7))
    # each trace is told 35.0 °C: the fit must find the 35.6 the data were made with
    traces = [type(t)(t.time_s, t.temperature_C, 35.0, t.material_temperature_C, t.sample,
                      t.roughness_um, t.source, t.roughness_id) for t in traces]
    fit = fit_traces(traces, fit_skin_temperature=True)
    T = fit.parameter("T_S0")
    assert T.low <= 35.6 <= T.high and abs(T.value - 35.6) < 0.1
    _check_recovered(fit, R_TRUE[:2], 1.1e-3, rtol=0.05)


def test_bootstrap_intervals_cover_the_truth():
    traces = synthetic_traces(R_TRUE[:2], L_TRUE, duration_s=10.0, rate_Hz=10.0,
                              rng=np.random.default_rng(3))
    fit = fit_traces(traces, interval="bootstrap", bootstrap_samples=60, seed=1)
    assert fit.interval_method == "bootstrap"
    _check_recovered(fit, R_TRUE[:2], L_TRUE, rtol=0.05)


@pytest.mark.slow
def test_profile_intervals_have_near_nominal_coverage():
    # 50 independent data sets (2 samples, 10 s at 10 Hz).  For 95 % intervals the number
    # covering the truth is Binomial(50, 0.95): P(X <= 41) = 0.012, so >= 42 is demanded;
    # and the half-widths must match the actual scatter of the estimates (1.96 SD within 35 %),
    # so intervals that were simply too wide would fail as well.
    truth = np.array(R_TRUE[:2] + [L_TRUE])
    cover = np.zeros(3)
    est, half = [], []
    for seed in range(50):
        traces = synthetic_traces(R_TRUE[:2], L_TRUE, duration_s=10.0, rate_Hz=10.0,
                                  rng=np.random.default_rng(5000 + seed))
        fit = fit_traces(traces)
        v = np.array([p.value for p in fit.parameters])
        lo = np.array([p.low for p in fit.parameters])
        hi = np.array([p.high for p in fit.parameters])
        cover += (lo <= truth) & (truth <= hi)
        est.append(np.log(v))
        half.append((np.log(hi) - np.log(lo)) / 2)
    assert np.all(cover >= 42), cover
    ratio = np.mean(half, axis=0) / (1.96 * np.std(est, axis=0, ddof=1))
    assert np.all((ratio > 0.65) & (ratio < 1.35)), ratio


def test_refuses_flat_profile_when_skin_is_deeper_than_the_heat_gets():
    # 3 s on a half-space: heat penetrates sqrt(alpha t) ~ 0.5 mm, the skin is 2 mm thick
    setup = ContactSetup(material("stainless_steel"), Sensor("material"))
    traces = synthetic_traces(R_TRUE[:2], 2e-3, setup=setup, duration_s=3.0,
                              rng=np.random.default_rng(11))
    with pytest.raises(CalibrationRefused) as err:
        fit_traces(traces, setup)
    assert any("profile likelihood of L is flat" in r for r in err.value.reasons)
    assert "not identifiable" in str(err.value)


def test_refuses_parameter_at_bound():
    traces = synthetic_traces([1e-8, 1e-3], L_TRUE, duration_s=10.0, rng=np.random.default_rng(2))
    with pytest.raises(CalibrationRefused, match=r"R\[1\] = 1e-06 is at its lower bound"):
        fit_traces(traces)


def test_refuses_non_convergence():
    traces = synthetic_traces(R_TRUE[:2], L_TRUE, duration_s=10.0, rng=np.random.default_rng(2))
    with pytest.raises(CalibrationRefused, match="did not converge"):
        fit_traces(traces, max_nfev=1)


def test_refuses_unidentifiable_skin_temperature():
    # one 2 s trace, a 3 mm skin the heat never crosses, and T_S0 free as well: L is not
    # determined (and T_S0 trades off against R); the fit must be refused with reasons
    setup = ContactSetup(material("stainless_steel"), Sensor("material"))
    traces = synthetic_traces([3e-3], 3e-3, setup=setup, duration_s=2.0, noise_C=0.05,
                              rng=np.random.default_rng(4))
    with pytest.raises(CalibrationRefused) as err:
        fit_traces(traces, setup, fit_skin_temperature=True)
    assert any(r.startswith("L ") or " of L " in r for r in err.value.reasons), err.value.reasons


def test_per_trace_skin_temperatures_are_recovered():
    # every touch starts from its own skin temperature; the traces are told 35.0 (a surface
    # reading), the truth differs by up to ±0.2 K: fitting one T_S0 per trace recovers them
    rng = np.random.default_rng(99)
    true_ts0 = [35.2, 34.8, 35.1, 34.9]
    traces = []
    for k, (R, ts0) in enumerate(zip(R_TRUE, true_ts0)):
        tr = synthetic_traces([R], L_TRUE, skin_temperature=ts0, duration_s=15.0, rng=rng)[0]
        traces.append(type(tr)(tr.time_s, tr.temperature_C, 35.0, tr.material_temperature_C,
                               str(k + 1), RA_UM[k], tr.source, k + 1))
    fit = fit_traces(traces, fit_skin_temperature="per-trace")
    _check_recovered(fit, R_TRUE, L_TRUE, rtol=0.05)
    for i, ts0 in enumerate(true_ts0):
        T = fit.parameter(f"T_S0[{i + 1}]")
        half = (T.high - T.low) / 2                       # Wald interval (nuisance parameter)
        assert abs(T.value - ts0) <= 2 * half and half < 0.5, (T, ts0)   # informative: < ±0.5 K
    assert fit.parameter("T_S0[1]").kind == "skin_temperature"


def test_refuses_rank_deficient_jacobian():
    # 2 s on a half-space with a 3 mm skin: the heat front (sqrt(alpha t) ~ 0.4 mm) never
    # reaches the inner boundary, so the readings do not depend on L at all
    setup = ContactSetup(material("stainless_steel"), Sensor("material"))
    traces = synthetic_traces([1e-3, 2e-3], 3e-3, setup=setup, duration_s=2.0,
                              rng=np.random.default_rng(1))
    with pytest.raises(CalibrationRefused, match="the Jacobian has rank 2 < 3") as err:
        fit_traces(traces, setup)
    assert err.value.diagnostics["jacobian_rank"] == 2


def test_interval_methods_are_one_table_and_the_error_names_them():
    # the solve_ivp shape: interval= picks an entry of INTERVALS; anything else is refused with
    # the table's names
    from experiments.calibration import CalibrationError
    from experiments.calibration.fit import INTERVALS
    assert list(INTERVALS) == ["profile", "bootstrap"]
    traces = synthetic_traces(R_TRUE[:1], L_TRUE, duration_s=5.0, rng=np.random.default_rng(7))
    with pytest.raises(CalibrationError,
                       match="interval: expected 'profile' or 'bootstrap', got 'wald'"):
        fit_traces(traces, interval="wald")
