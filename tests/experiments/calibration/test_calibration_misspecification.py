"""Calibration you can trust: misspecification checks, T_S0 propagation, correlations.

Synthetic traces: the exact calibration model plus 0.02 °C white noise (as in
test_calibration_fit.py); the truths are Eq. 5 resistances and L = 800 µm.
"""
import json

import numpy as np
import pytest

from experiments.calibration import calibration_record, fit_traces, synthetic_traces, write_report
from stimuli import contact_resistance

RA_UM = [1.6, 12.5]
R_TRUE = [float(contact_resistance(r * 1e-6)) for r in RA_UM]
L_TRUE = 800e-6


def _traces(told_C, true_C=35.3, seed=11):
    tr = synthetic_traces(R_TRUE, L_TRUE, roughness_um=RA_UM, skin_temperature=true_C,
                          duration_s=25.0, rng=np.random.default_rng(seed))
    return [type(t)(t.time_s, t.temperature_C, told_C, t.material_temperature_C, t.sample,
                    t.roughness_um, t.source, t.roughness_id) for t in tr]


@pytest.fixture(scope="module")
def fits():
    right = fit_traces(_traces(35.3))
    wrong = fit_traces(_traces(35.0))                    # a 0.3 K thermometer error
    propagated = fit_traces(_traces(35.0), skin_temperature_sd_C=0.3)
    return right, wrong, propagated


def _covers(fit):
    truth = R_TRUE + [L_TRUE]
    return [p.low <= v <= p.high for p, v in zip(fit.parameters, truth)]


def test_a_skin_temperature_error_is_warned_and_its_shift_predicted(fits):
    right, wrong, _ = fits
    # the plain intervals exclude the truth (what the issue found) ...
    assert not all(_covers(wrong))
    # ... and the fit says so
    assert any("skin temperature: 0.3 K" in w and "beyond the interval" in w for w in wrong.warnings)
    # the first-order prediction (made from the correct fit) matches the actual refit's bias
    case = next(c for c in right.diagnostics["misspecification"] if c["name"] == "skin_temperature")
    for p_right, p_wrong in zip(right.parameters, wrong.parameters):
        actual = p_wrong.value / p_right.value - 1
        predicted = case["shift"][p_right.name]
        assert actual * predicted > 0 and abs(actual - predicted) < 0.25 * abs(actual), p_right.name


def test_propagated_skin_temperature_uncertainty_covers_the_truth(fits):
    _, wrong, propagated = fits
    assert all(_covers(propagated))
    assert not any("skin temperature" in w for w in propagated.warnings)
    for a, b in zip(wrong.parameters, propagated.parameters):
        assert b.low < a.low and b.high > a.high and a.value == b.value


def test_geometry_and_sensor_lag_checks_are_reported(fits):
    right = fits[0]
    names = [c["name"] for c in right.diagnostics["misspecification"]]
    assert names == ["skin_temperature", "geometry", "sensor_lag"]
    geo = right.diagnostics["misspecification"][1]
    assert geo["shift"]["R[1]"] > 0.2                   # a thicker sample reads warmer: larger R


def test_correlations_and_effective_core_depth_in_report_and_record(fits, tmp_path):
    right = fits[0]
    write_report(right, tmp_path)
    md = (tmp_path / "parameters.md").read_text(encoding="utf-8")
    assert "Correlation of the estimates" in md and "| L | " in md
    assert "effective core depth" in md and "effective depth of the isothermal core" in md
    assert "Plausible misspecifications" in md
    rec = calibration_record(right)
    json.dumps(rec)
    C = np.array(rec["correlation"]["matrix"])
    assert rec["correlation"]["parameters"] == ["R[1]", "R[2]", "L"]
    np.testing.assert_allclose(np.diag(C), 1.0)
    assert C[0, 2] < -0.5                               # R and L trade off on these traces
    assert "isothermal core" in rec["skin_thickness_meaning"]


def test_the_calibration_scene_is_planned_at_the_traces_noise(fits):
    right = fits[0]
    plan = right.diagnostics["plan"]
    assert plan["quantity"] == "interface_material" and plan["tolerance_K"] == pytest.approx(right.sigma_C)
    d = {x["effect"]: x for x in plan["decisions"]}
    assert d["slab"]["included"]                        # 3 mm steel over 25 s: kelvins
    assert calibration_record(right)["plan"] == plan
