"""Calibration's forward model is the scene planner's model.

The calibration contact is planned once per fit (start values, the traces' white-noise level as
tolerance) and the fit's readings are computed with the model the planner returns; at the fitted
values the plan is checked again and the fit is redone with the stated model if the planner then
keeps an effect it had dropped. References: the same traces fitted with ``plan_model=False`` (the
exact model of the stated setup, unchanged code path).
"""
import json

import numpy as np
import pytest

from experiments.calibration import ContactSetup, calibration_record, fit_traces, synthetic_traces
from stimuli import contact_resistance, material

RA_UM = [1.6, 12.5]
R_TRUE = [float(contact_resistance(r * 1e-6)) for r in RA_UM]
L_TRUE = 800e-6


def _pair(thickness_m, duration_s, seed, roughness=True):
    setup = ContactSetup(material("stainless_steel", thickness=thickness_m))
    tr = synthetic_traces(R_TRUE, L_TRUE, roughness_um=RA_UM if roughness else None, setup=setup,
                          duration_s=duration_s, rng=np.random.default_rng(seed))
    return fit_traces(tr, setup), fit_traces(tr, setup, plan_model=False)


def test_a_slab_the_planner_drops_is_fitted_as_a_half_space_with_the_same_estimates():
    # 20 mm of steel over 8 s: the back is not felt within the noise (0.02 K), the planner drops it
    planned, exact = _pair(0.02, 8.0, seed=3)
    prob = planned.problem
    assert prob.model is not None and prob.model.geometry == "half-space"
    assert prob.forward_setup.sample_thickness is None          # the grids evaluate the half-space
    assert prob.setup.sample_thickness == 0.02                  # the stated setup is what is reported
    fm = planned.diagnostics["forward_model"]
    slab = {d["effect"]: d for d in fm["planned"]["decisions"]}["slab"]
    assert not slab["included"] and 0.0 < slab["bound_K"] < fm["planned"]["tolerance_K"]
    assert "half-space" in fm["evaluated"] and "slab 20 mm" in exact.diagnostics["forward_model"]["evaluated"]
    rec = calibration_record(planned)
    assert json.loads(json.dumps(rec["forward_model"])) == fm        # recorded with the participant
    assert rec["sample_thickness_um"] == pytest.approx(20000.0)     # the stated sample, not the model
    # the planned model differs from the slab by <= bound_K at every sample, so the estimates may
    # move by at most sum_j |pinv(J)_ij| * bound (linearised, coordinates log R, log L)
    J = prob.jacobian(planned.coordinates)
    shift_max = np.abs(np.linalg.pinv(J)).sum(axis=1) * fm["planned"]["bound_K"]
    dp = planned.coordinates - exact.coordinates
    assert np.all(np.abs(dp) <= shift_max), (dp, shift_max)
    for a, b in zip(planned.parameters, exact.parameters):
        half = 0.5 * (b.high - b.low)
        assert abs(a.value - b.value) < 1e-3 * half, (a.name, a.value, b.value, half)
        assert abs(a.low - b.low) < 1e-2 * half and abs(a.high - b.high) < 1e-2 * half


def test_a_slab_the_planner_keeps_goes_through_its_model_and_gives_identical_estimates():
    planned, exact = _pair(3e-3, 25.0, seed=5)                 # the paper's 3 mm samples: kelvins
    assert planned.problem.model.geometry == "slab"
    assert planned.problem.forward_setup == planned.problem.setup
    assert planned.diagnostics["forward_model"]["planned"]["geometry"] == "slab"
    np.testing.assert_array_equal(planned.coordinates, exact.coordinates)


def test_a_plan_the_fitted_values_contradict_is_refitted_with_the_stated_model():
    # 11 mm steel, 8 s, no roughness given: at the start R (1e-3) the slab's effect is just under
    # the noise, at the fitted R (6.5e-4) just over it -> the fit is redone with the slab
    planned, exact = _pair(0.011, 8.0, seed=0, roughness=False)
    fm = planned.diagnostics["forward_model"]
    assert "refitted with the exact model" in fm["note"]
    assert not {d["effect"]: d for d in fm["planned"]["decisions"]}["slab"]["included"]  # what was dropped
    assert planned.diagnostics["plan"]["geometry"] == "slab"
    assert planned.problem.forward_setup.sample_thickness == pytest.approx(0.011)
    np.testing.assert_array_equal(planned.coordinates, exact.coordinates)


def test_a_lumped_sensor_is_not_a_scene_and_keeps_the_exact_model():
    from experiments.calibration import Sensor
    setup = ContactSetup(material("stainless_steel", thickness=3e-3), Sensor.lumped())
    tr = synthetic_traces(R_TRUE, L_TRUE, roughness_um=RA_UM, setup=setup, duration_s=20.0,
                          rng=np.random.default_rng(1))
    fit = fit_traces(tr, setup)
    assert fit.problem.model is None
    assert "lumped sensor" in fit.diagnostics["forward_model"]["note"]


def test_a_half_space_sample_is_fitted_through_the_planners_model():
    planned, exact = _pair(None, 8.0, seed=2)
    assert planned.problem.model is not None and planned.problem.model.geometry == "half-space"
    assert planned.diagnostics["forward_model"]["planned"]["geometry"] == "half-space"
    np.testing.assert_array_equal(planned.coordinates, exact.coordinates)
