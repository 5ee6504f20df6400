"""The display-driven planner (stimuli.display_planner): planned vs full model over a grid."""
from __future__ import annotations

import itertools

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
    # screened (speed): kept without evaluation, perfusion by its closed form
    assert d["layered"].included and "without evaluation" in d["layered"].note
    assert not d["perfusion"].included and d["perfusion"].bound_K < 0.05
    # evaluated (screen=False): the same decisions, the layers' effect > 0.3 K, perfusion's mK
    from stimuli.display_planner import plan_display
    e = {x.effect: x for x in plan_display(skin, skin.dermis, 0.0, 10.0, 500.0,
                                           np.full(T.size, 25.0 - 35.5), tolerance=0.3,
                                           layered=True, perfusion_per_s=1.25e-3,
                                           screen=False).decisions}
    assert e["layered"].included and e["layered"].bound_K > 0.3
    assert not e["perfusion"].included and e["perfusion"].bound_K < d["perfusion"].bound_K


def _histories_hard(t):
    rng = np.random.default_rng(11)
    return {"cold step": np.full(t.size, 15.0), "warm step": np.full(t.size, 42.0),
            "return": np.interp(t, [0, t[-1] / 4, t[-1] / 2, t[-1]], [20.0, 20.0, 35.5, 35.5]),
            "square": 35.5 + 10.0 * np.sign(np.sin(2 * np.pi * t / 4.0 + 0.1)),
            "noisy": 25.0 + 0.5 * rng.standard_normal(t.size)}


@pytest.mark.parametrize("L_um,frac", [(400.0, 0.9), (650.0, 0.6), (3000.0, 0.6), (1000.0, 0.1)])
@pytest.mark.parametrize("R", [0.0, 1e-3])
def test_display_perfusion_closed_form_bounds_the_exact_effect(L_um, frac, R):
    # the display planner's closed form for perfusion (perfusion_factor x sup|h|, not
    # evaluated) against the effect the exact models compute at every sample, hard cases: w up
    # to 0.5 /s, 3 mm skin, 60 s, warm and cold drives
    from stimuli.exact import INVERSION_ERROR
    from stimuli.planner import perfusion_factor
    t = np.arange(3001) * 0.02                     # 60 s at 50 Hz
    skin = Skin(L_um * 1e-6, dermis=frac * L_um * 1e-6)
    for name, g in _histories_hard(t).items():
        h_sup = float(np.max(np.abs(g - 35.5)))
        for layered in (False, True):
            for w in (1.25e-3, 2e-2, 0.5):
                run = lambda w_: layered_skin_response(skin_layers(skin, layered=layered,
                                                                   perfusion=w_), t, g, 35.5,
                                                       skin.dermis, R)
                effect = float(np.max(np.abs(run(w) - run(None))))
                bound = perfusion_factor(skin, layered, w, None, float(t[-1])) * h_sup
                assert effect <= bound + 4 * INVERSION_ERROR * max(h_sup, 1.0), (name, effect, bound)


def test_display_layer_screen_keeps_only_layers_the_evaluation_keeps():
    # the display planner's layer screen (speed) must not keep layers that evaluating
    # them would neglect: over skins, pads, tolerances and drives, every screened keep is an
    # evaluated keep
    from stimuli.display_planner import _layers_matter, plan_display
    screened = 0
    for L_um, frac, R, tol, (duration, rate) in itertools.product(
            [400.0, 650.0, 1000.0], [0.2, 0.6, 0.9], [0.0, 1e-4, 1e-3], [0.02, 0.3, 1.0],
            [(10.0, 500.0), (20.0, 100.0), (60.0, 20.0)]):
        skin = Skin(L_um * 1e-6, dermis=frac * L_um * 1e-6)
        t = np.arange(int(round(duration * rate)) + 1) / rate
        for name, g in _histories_hard(t).items():
            h = g - 35.5
            if _layers_matter(skin, skin.dermis, R, duration, rate, h, tol) is None:
                continue
            screened += 1
            p = plan_display(skin, skin.dermis, R, duration, rate, h, tolerance=tol,
                             layered=True, perfusion_per_s=1.25e-3)
            assert p.layered
            q = plan_display(skin, skin.dermis, R, duration, rate, h, tolerance=tol,
                             layered=True, perfusion_per_s=1.25e-3, screen=False)
            assert q.layered, (name, L_um, frac, R, tol, duration, q.decisions)
    assert screened > 50, screened


def test_display_probe_inversion_error_bound():
    # the display planner's probes use the scene planner's cheap inversion (speed): on
    # every step response it compares (skins, receptor depths, pads, perfusion, durations and
    # rates), each probe value is within PROBE_INVERSION_ERROR of the production inversion
    # (itself within 1e-12 of mpmath, tests/stimuli/test_exact.py)
    from stimuli.display_planner import _step
    from stimuli.planner import PROBE_INVERSION_ERROR, probe_plan
    worst = 0.0
    for (duration, rate), L_um, frac, R, layered, w in itertools.product(
            [(20.0, 1000.0), (10.0, 500.0), (2.0, 100.0), (120.0, 1000.0)],
            [400.0, 650.0, 1000.0, 3000.0], [0.1, 0.6, 0.9], [0.0, 1e-4, 1e-3],
            [False, True], [None, 1.25e-3, 2e-2]):
        skin = Skin(L_um * 1e-6, dermis=frac * L_um * 1e-6)
        layers = skin_layers(skin, layered=layered, perfusion=w)
        _, cheap = probe_plan(duration, rate, cheap=True)
        _, prod = probe_plan(duration, rate)
        err = np.max(np.abs(_step(layers, skin.dermis, R, cheap) - _step(layers, skin.dermis, R, prod)))
        worst = max(worst, float(err))
    assert worst <= PROBE_INVERSION_ERROR, worst
    print(f"display probe inversion: worst {worst:.3g} (bound {PROBE_INVERSION_ERROR:g})")


def test_display_kernel_at_real_s_is_the_layered_transform():
    # the display planner's plain-float kernel (its Laplace-domain lower bound) is the exact
    # model's (stimuli.layered.LayeredTransform.display_kernel) at real s
    from stimuli.display_planner import display_kernel_real
    from stimuli.layered import LayeredTransform
    from stimuli.materials import material
    s = np.array([1e-3, 0.05, 1.0, 40.0, 3e3])
    for L_um, frac, R, layered, w in itertools.product([400.0, 3000.0], [0.1, 0.6, 0.95],
                                                        [0.0, 1e-3], [False, True], [None, 2e-2]):
        skin = Skin(L_um * 1e-6, dermis=frac * L_um * 1e-6)
        tr = LayeredTransform(skin_layers(skin, layered=layered, perfusion=w), material("copper"), 0.0)
        want = tr.display_kernel(s, skin.dermis, R).real
        got = [display_kernel_real(skin, layered, w, skin.dermis, R, float(x)) for x in s]
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)


def test_history_transform_is_the_piecewise_linear_history():
    # L[h](s) of the sampled history as the models take it (linear between samples, held after
    # the end), against quadrature of the interpolant on a 50x finer grid plus the held tail
    from stimuli.display_planner import _history_transform
    rate = 100.0
    t = np.arange(1001) / rate
    for g in list(_histories_hard(t).values()) + [20.0 + 8.0 * np.exp(-t / 3.0)]:
        h = g - 35.5
        for a in (4.0, 8.0, 16.0):
            s = a / t[-1]
            tf = np.linspace(0.0, t[-1], 50 * (t.size - 1) + 1)
            f = np.interp(tf, t, h) * np.exp(-s * tf)
            want = float(np.sum((f[1:] + f[:-1]) / 2) * (tf[1] - tf[0])) + h[-1] * np.exp(-s * t[-1]) / s
            assert abs(_history_transform(h, rate, a) - want) <= 1e-5 * np.max(np.abs(h)) / s


def test_display_layer_lower_bound_is_below_the_effect_and_its_keeps_are_evaluated_keeps():
    # the Laplace-domain screen keeps the layers without evaluation when a lower bound of their
    # effect is >= LAYER_LOWER_SCREEN tolerances: the bound must be below the exact effect
    # (skins, pads, perfusion, drives), and every such keep an evaluated keep
    from stimuli.display_planner import LAYER_LOWER_SCREEN, _layers_lower_bound, plan_display
    screened = 0
    for (duration, rate), L_um, frac, R, w in itertools.product(
            [(10.0, 200.0), (20.0, 50.0)], [400.0, 650.0, 2000.0], [0.2, 0.6, 0.9], [0.0, 1e-3],
            [None, 2e-2]):
        skin = Skin(L_um * 1e-6, dermis=frac * L_um * 1e-6)
        t = np.arange(int(round(duration * rate)) + 1) / rate
        hist = dict(_histories_hard(t), decay=27.75 + 7.75 * np.exp(-t / 2.0))
        for name, g in hist.items():
            h = g - 35.5
            low = _layers_lower_bound(skin, skin.dermis, R, rate, h, w, np.inf)
            run = lambda layered: layered_skin_response(skin_layers(skin, layered=layered,
                                                                    perfusion=w), t, g, 35.5,
                                                        skin.dermis, R)
            effect = float(np.max(np.abs(run(True) - run(False))))
            assert low <= effect + 1e-9, (name, L_um, frac, R, w, low, effect)
            for tol in (0.02, 0.3, 1.0):
                if low < LAYER_LOWER_SCREEN * tol:
                    continue
                screened += 1
                q = plan_display(skin, skin.dermis, R, duration, rate, h, tolerance=tol,
                                 layered=True, perfusion_per_s=w or 0.0, screen=False)
                assert q.layered, (name, L_um, frac, R, tol, q.decisions)
    assert screened > 100, screened
    print(f"display Laplace layer screen: {screened} screened keeps, all evaluated keeps")


def test_decay_drive_decided_without_evaluation():
    # the benchmark's decay drive (20 s at 1 kHz, pad 1e-4): the quasi-steady screen cannot
    # decide the layers (1.1 K < 4 x 0.3 K); the lower bound keeps them without evaluation, with
    # the evaluated planner's model
    from stimuli import display_planner
    from stimuli.display_planner import plan_display
    skin = Skin(650e-6)
    t = np.arange(20001) / 1000.0
    h = 27.75 + 7.75 * np.exp(-t / 2.0) - 35.5
    calls = []
    real = display_planner._step
    try:
        display_planner._step = lambda *a: calls.append(a) or real(*a)
        p = plan_display(skin, skin.dermis, 1e-4, 20.0, 1000.0, h, tolerance=0.3, layered=True,
                         perfusion_per_s=1.25e-3)
    finally:
        display_planner._step = real
    assert calls == []
    d = {x.effect: x for x in p.decisions}
    assert d["layered"].included and "lower bound" in d["layered"].note
    q = plan_display(skin, skin.dermis, 1e-4, 20.0, 1000.0, h, tolerance=0.3, layered=True,
                     perfusion_per_s=1.25e-3, screen=False)
    assert (q.layered, q.perfusion) == (p.layered, p.perfusion)
