"""The display-driven planner (stimuli.display_planner): planned vs full model over a grid."""
from __future__ import annotations

import numpy as np
import pytest

from stimuli import Skin, skin_response
from stimuli.display_planner import planned_skin_response
from stimuli.layered import layered_skin_response, skin_layers

T = np.arange(5001) * 2e-3       # 10 s at 500 Hz


def _histories():
    rng = np.random.default_rng(7)
    return {"step": np.full(T.size, 25.0), "decay": 20.0 + 8.0 * np.exp(-T / 3.0),
            "noisy": 22.0 + 0.05 * rng.standard_normal(T.size),
            "ramp-back": np.interp(T, [0, 2, 6, 10], [30.0, 24.0, 33.0, 34.0])}


def _full(skin, g, R, layered, w):
    return layered_skin_response(skin_layers(skin, layered=layered, perfusion=w or None), T, g,
                                 35.5, skin.dermis, R)


@pytest.mark.parametrize("L_um", [650.0, 1000.0])
@pytest.mark.parametrize("R", [0.0, 1e-3])
def test_planned_model_is_within_tolerance_of_the_full_model_and_every_bound_holds(L_um, R):
    skin = Skin(L_um * 1e-6, dermis=0.6 * L_um * 1e-6)
    for name, g in _histories().items():
        for layered, w in ((True, 1.25e-3), (False, 1.25e-3), (True, 0.0), (False, 5e-3)):
            for tol in (0.3, 0.01, 3.0):
                T_plan, plan = planned_skin_response(skin, T, g, 35.5, resistance=R, tolerance=tol,
                                                     layered=layered, perfusion_per_s=w)
                full = _full(skin, g, R, layered, w)
                err = float(np.max(np.abs(T_plan - full)))
                assert err <= tol, (name, layered, w, tol, plan.decisions)
                assert err <= plan.bound_K + 1e-9, (name, plan.decisions)
            # each effect's stated bound covers its actual effect (tolerance large: all evaluated)
            _, plan = planned_skin_response(skin, T, g, 35.5, resistance=R, tolerance=50.0,
                                            layered=layered, perfusion_per_s=w)
            d = {x.effect: x for x in plan.decisions}
            if w:
                effect = float(np.max(np.abs(_full(skin, g, R, layered, 0.0) - full)))
                assert effect <= d["perfusion"].bound_K, (name, effect, d["perfusion"])
            if layered:
                effect = float(np.max(np.abs(_full(skin, g, R, False, 0.0)
                                             - _full(skin, g, R, True, 0.0))))
                assert effect <= d["layered"].bound_K + d["perfusion"].bound_K, (name, effect, d)


def test_homogeneous_skin_is_skin_response_exactly():
    skin = Skin(800e-6)
    g = 20.0 + 8.0 * np.exp(-T / 3.0)
    T_plan, plan = planned_skin_response(skin, T, g, 35.0, resistance=2e-4)
    np.testing.assert_array_equal(T_plan, skin_response(skin, T, g, initial_temperature=35.0,
                                                        resistance=2e-4))
    assert not plan.layered and not plan.perfusion


def test_layers_are_kept_at_the_perceptual_floor_and_perfusion_is_neglected():
    # epidermis/dermis properties move the receptor by kelvins; perfusion by millikelvins (10 s)
    skin = Skin(650e-6)
    T_plan, plan = planned_skin_response(skin, T, np.full(T.size, 25.0), 35.5, layered=True,
                                         perfusion_per_s=1.25e-3)
    assert plan.layered and not plan.perfusion
    d = {x.effect: x for x in plan.decisions}
    assert d["layered"].included and d["layered"].bound_K > 0.3
    assert not d["perfusion"].included and d["perfusion"].bound_K < 0.05
