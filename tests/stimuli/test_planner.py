"""The scene planner: the planned model against the full model over a grid of scenes."""
import itertools
import json
import math
import warnings

import numpy as np
import pytest

from stimuli.planner import plan
from stimuli.scene import Model, Scene, evaluate

pytestmark = pytest.mark.filterwarnings("error")

GRID = list(itertools.product(
    ["receptor", "interface_material", "interface_skin"],
    ["half-space", "slab", "slab-on-support"],
    [False, True],                      # layered
    [0.0, 1.25e-3, 2e-2],               # perfusion
    [0.02, 0.3, 2.0],                   # tolerance, K
    [1.6e-6, 100e-6],                   # roughness
))


@pytest.mark.parametrize("quantity,geometry,layered,w,tol,ra", GRID)
def test_planned_model_within_tolerance_of_the_full_model(quantity, geometry, layered, w, tol, ra):
    scene = Scene(quantity=quantity, geometry=geometry, layered=layered, perfusion_per_s=w,
                  tolerance_K=tol, roughness_m=ra, support="wood" if geometry == "slab-on-support" else None,
                  duration_s=20.0, rate_Hz=200.0)
    full = evaluate(scene, scene.full_model())
    for screen in (True, False):
        p = plan(scene, screen=screen)
        got = p.evaluate()
        err = float(np.max(np.abs(got - full)))
        assert err <= tol, (p.lines(), err)
        assert err <= p.bound_K + 1e-9      # the reported bound is a bound at every sample
        json.dumps(p.to_dict(), allow_nan=False)   # strict JSON: caches, session events


@pytest.mark.parametrize("quantity,geometry,layered,w,tol", list(itertools.product(
    ["receptor", "interface_material", "interface_skin"], ["half-space", "slab", "slab-on-support"],
    [False, True], [1.25e-3, 2e-2], [0.02, 0.3, 2.0])))
def test_planned_model_within_tolerance_with_a_hypodermis(quantity, geometry, layered, w, tol):
    # a 2 mm hypodermis: the closed forms and the quasi-steady screen cannot decide, the
    # Laplace-domain bounds often do (speed); the planned model stays within tolerance
    scene = Scene(quantity=quantity, geometry=geometry, layered=layered, perfusion_per_s=w,
                  hypodermis_m=2e-3, tolerance_K=tol, support="wood" if geometry == "slab-on-support"
                  else None, duration_s=20.0, rate_Hz=200.0)
    full = evaluate(scene, scene.full_model())
    for screen in (True, False):
        p = plan(scene, screen=screen)
        err = float(np.max(np.abs(p.evaluate() - full)))
        assert err <= tol, (p.lines(), err)
        assert err <= p.bound_K + 1e-9
        json.dumps(p.to_dict(), allow_nan=False)


@pytest.mark.parametrize("quantity", ["interface_material", "interface_skin"])
@pytest.mark.parametrize("tau,tol", [(0.001, 0.3), (0.05, 0.3), (0.05, 5.0), (0.3, 2.0)])
def test_sensor_lag_bound_holds(quantity, tau, tol):
    scene = Scene(quantity=quantity, sensor_time_constant_s=tau, tolerance_K=tol, rate_Hz=100.0,
                  geometry="half-space")
    p = plan(scene)
    full = evaluate(scene, scene.full_model())
    lag = [d for d in p.decisions if d.effect == "sensor"][0]
    unlagged = evaluate(scene, Model("exact", "half-space"))
    assert np.max(np.abs(full - unlagged)) <= lag.bound_K + 1e-12     # tau max|dT/dt| is a bound
    assert np.max(np.abs(p.evaluate() - full)) <= tol


def test_decisions_name_what_matters_at_the_papers_scene():
    # 3 mm steel at 20 s: the slab is kept (K-sized), perfusion neglected (~0.01 K)
    p = plan(Scene(quantity="receptor", perfusion_per_s=1.25e-3), screen=False)
    d = {x.effect: x for x in p.decisions}
    assert d["slab"].included and d["slab"].bound_K > 1.0
    assert not d["perfusion"].included and d["perfusion"].bound_K < 0.05
    # screened (the production default): the warmed-through slab is kept without evaluating it
    q = plan(Scene(quantity="receptor", perfusion_per_s=1.25e-3))
    assert q.model == p.model
    slab = [x for x in q.decisions if x.effect == "slab"][0]
    assert slab.included and "warmed through" in slab.note
    # a half-space interface at a loose tolerance: the paper's printed Eq. 7 is enough ...
    p = plan(Scene(quantity="interface_material", geometry="half-space", tolerance_K=2.0))
    assert p.model.method == "eq7"
    # ... and not at a tight one
    assert plan(Scene(quantity="interface_material", geometry="half-space", tolerance_K=0.01)).model.method == "exact"


def test_range_checks_at_the_edge_of_the_model():
    from stimuli import ModelInputError
    from stimuli.errors import ModelRangeWarning
    with pytest.raises(ModelInputError, match="skin_temperature_C"):
        Scene(skin_temperature_C=-300.0)
    with pytest.raises(ModelInputError, match="material_temperature_C"):
        Scene(material_temperature_C=1000.0)
    with pytest.raises(ModelInputError, match="skin_thickness_m"):
        Scene(skin_thickness_m=1e-9)
    with pytest.warns(ModelRangeWarning, match="skin_temperature_C"):
        Scene(skin_temperature_C=44.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Scene(skin_temperature_C=33.0)


def test_absurd_inputs_refused_where_they_enter():
    import numpy as np
    from stimuli import Contact, ModelInputError, Skin, contact_resistance, material, skin_response
    from stimuli.errors import ModelRangeWarning
    with pytest.raises(ModelInputError, match="thickness"):
        Skin(1e-9)                                                     # 1 nm skin
    with pytest.raises(ModelInputError, match="absolute zero"):
        Contact(Skin(650e-6), material("steel"), 0.0, -300.0, 1000.0)
    t = np.arange(11) * 0.1
    with pytest.raises(ModelInputError, match="surface_temperature"):
        skin_response(Skin(650e-6), t, np.full(11, 200.0), 35.0)      # a 200 °C display
    with pytest.raises(ModelInputError, match="P/H"):
        contact_resistance(1.6e-6, force=20.0)                         # P > H
    with pytest.warns(ModelRangeWarning, match="P/H"):
        contact_resistance(1.6e-6, force=6.0)                          # P/H = 0.36
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        contact_resistance(1.6e-6, force=2.5)                          # the emulated finger


def test_target_profile_refuses_absurd_temperatures():
    from stimuli import ModelInputError, target_profile
    with pytest.raises(ModelInputError, match="material_temperature_C"):
        target_profile(material_temperature=1000.0, cache=False)
    with pytest.raises(ModelInputError, match="skin_temperature_C"):
        target_profile(skin_temperature=-300.0, cache=False)


def test_planned_model_within_tolerance_on_random_hard_scenes():
    # beyond steel: copper, glass, foam, thin and thick skin, any roughness, any perfusion
    rng = np.random.default_rng(20261124)
    for _ in range(60):
        scene = Scene(quantity=str(rng.choice(["receptor", "interface_material", "interface_skin"])),
                      material=str(rng.choice(["copper", "glass", "polystyrene_foam", "stainless_steel"])),
                      geometry=str(rng.choice(["half-space", "slab", "slab-on-support"])),
                      support="wood", sample_thickness_m=float(rng.uniform(0.5e-3, 10e-3)),
                      skin_thickness_m=float(rng.uniform(300e-6, 2e-3)),
                      roughness_m=float(rng.uniform(0.0, 100e-6)), layered=bool(rng.integers(2)),
                      perfusion_per_s=float(rng.choice([0.0, 1.25e-3, 2e-2])),
                      tolerance_K=float(rng.choice([0.01, 0.1, 0.3, 1.0])),
                      material_temperature_C=float(rng.uniform(5.0, 30.0)),
                      duration_s=float(rng.choice([2.0, 20.0])), rate_Hz=100.0)
        full = evaluate(scene, scene.full_model())
        p = plan(scene)
        err = float(np.max(np.abs(p.evaluate() - full)))
        assert err <= scene.tolerance_K, (p.lines(), err)


def test_planned_temperature_is_the_contact_for_the_default_scene():
    from stimuli import Contact, Skin, contact_resistance, material
    from stimuli.planner import planned_temperature
    skin, steel = Skin(1e-3), material("stainless_steel", 3e-3)
    R = contact_resistance(50e-6, skin=skin, material=steel)
    t = np.arange(2001) * 0.01
    T, p = planned_temperature("receptor", skin, steel, R, 35.5, 20.0, t)
    np.testing.assert_allclose(T, Contact(skin, steel, R, 35.5, 20.0).receptor_temperature(t), atol=1e-11)
    assert p.model.geometry == "slab" and p.scene.tolerance_K == 0.3
    # with layered skin the planner keeps the layers (about 1 K at the receptor)
    T2, p2 = planned_temperature("receptor", skin, steel, R, 35.5, 20.0, t, layered=True)
    assert p2.model.layered and np.max(np.abs(T2 - T)) > 0.3


def test_planned_temperature_with_no_temperature_difference_stays_put():
    from stimuli import Skin, material
    from stimuli.planner import planned_temperature
    T, p = planned_temperature("interface_material", Skin(650e-6), material("steel", 3e-3), 1e-3,
                               30.0, 30.0, np.arange(11) * 0.1)
    assert p is None and np.all(T == 30.0)


def test_probe_evaluation_is_evaluate_to_the_last_bit():
    # the planner's unchecked probe evaluation (speed) computes what evaluate does
    from stimuli.planner import _at_probes, probe_plan, _resolved
    from stimuli.scene import Model, Scene, evaluate
    probes, ip = probe_plan(20.0, 1000.0)
    for quantity in ("receptor", "interface_material", "interface_skin"):
        scene = _resolved(Scene(quantity=quantity, perfusion_per_s=1.25e-3, support="wood",
                                geometry="slab-on-support"))
        for model in (Model(geometry="slab-on-support", layered=True, perfusion=True),
                      Model(geometry="slab"), Model(geometry="half-space", layered=True)):
            np.testing.assert_array_equal(_at_probes(scene, model, probes, ip),
                                          evaluate(scene, model, probes, plan=ip))


def test_probe_inversion_error_bound():
    # the planner's cheap probe inversion (PROBE_NODES per window, speed) is within its
    # stated PROBE_INVERSION_ERROR x |dT| of the production inversion (itself within 1e-12 of
    # mpmath, tests/stimuli/test_exact.py) for every model the planner compares, over a grid
    from dataclasses import replace
    from stimuli.planner import (EFFECTS, PROBE_INVERSION_ERROR, _at_probes, _drop, probe_plan,
                                 _resolved)
    worst = 0.0
    for (duration, rate), quantity, geometry, layered, w, R in itertools.product(
            [(20.0, 1000.0), (20.0, 200.0), (2.0, 100.0), (120.0, 1000.0)],
            ["receptor", "interface_material", "interface_skin"],
            ["half-space", "slab", "slab-on-support"], [False, True], [0.0, 1.25e-3, 2e-2],
            [0.0, 1e-4, 1e-3]):
        scene = _resolved(Scene(quantity=quantity, geometry=geometry, layered=layered,
                                perfusion_per_s=w, resistance=R, duration_s=duration, rate_Hz=rate,
                                support="wood" if geometry == "slab-on-support" else None))
        probes, cheap = probe_plan(duration, rate, cheap=True)
        dT = abs(scene.skin_temperature_C - scene.material_temperature_C)
        models = [replace(scene.full_model(), sensor=False)]
        for effect in EFFECTS[1:]:          # every model a chain of drops reaches
            for m in list(models):
                cand = _drop(m, effect, scene)
                if cand is not None and cand.method == "exact":
                    models.append(cand)
        for m in models:
            err = np.max(np.abs(_at_probes(scene, m, probes, cheap)
                                - evaluate(scene, m, probes))) / dT
            worst = max(worst, float(err))
    assert worst <= PROBE_INVERSION_ERROR, worst
    print(f"probe inversion: worst {worst:.3g} of dT (bound {PROBE_INVERSION_ERROR:g})")


HARD_PERFUSION = list(itertools.product(
    ["receptor", "interface_material", "interface_skin"],
    [("copper", "half-space", 0.0), ("stainless_steel", "slab", 1e-4),
     ("glass", "slab-on-support", 1e-3), ("copper", "slab", 0.0)],
    [(False, None), (True, None), (True, 2e-3)],           # layered, hypodermis
    [(650e-6, 0.4), (3e-3, 0.1), (400e-6, 0.9)],           # skin thickness, receptor fraction
    [(1.25e-3, 20.0, 100.0), (2e-2, 600.0, 2.0), (0.5, 60.0, 50.0)],  # w, duration, rate
))


@pytest.mark.parametrize("quantity,sample,layers,skin,run", HARD_PERFUSION)
def test_perfusion_closed_form_bounds_the_exact_effect(quantity, sample, layers, skin, run):
    # the planner neglects perfusion by a closed form (speed) without evaluating it: it
    # must be >= what perfusion changes at every sample, computed by the exact models, on hard
    # scenes (copper at R = 0: the largest deficit; 3 mm skin, hypodermis; w up to 0.5 /s, long
    # runs towards the steady state; a warm sample); tightness printed
    from stimuli.exact import INVERSION_ERROR
    from stimuli.planner import perfusion_bound, perfusion_laplace_bound
    (material, geometry, R), (layered, hyp), (L, frac), (w, duration, rate) = sample, layers, skin, run
    for T_M in (5.0, 45.0):
        scene = Scene(quantity=quantity, material=material, geometry=geometry, resistance=R,
                      support="wood" if geometry == "slab-on-support" else None, layered=layered,
                      hypodermis_m=hyp, skin_thickness_m=L, receptor_fraction=frac,
                      perfusion_per_s=w, duration_s=duration, rate_Hz=rate,
                      skin_temperature_C=35.5, material_temperature_C=T_M)
        full = evaluate(scene, scene.full_model())
        unperfused = evaluate(scene, Model("exact", geometry, layered, False))
        effect = float(np.max(np.abs(full - unperfused)))
        bound = perfusion_bound(scene)
        assert effect <= bound + 2 * INVERSION_ERROR * abs(35.5 - T_M), (effect, bound)
        # the Laplace-domain bound the planner tries when the closed form is too loose
        laplace = perfusion_laplace_bound(scene, scene.full_model())
        assert effect <= laplace + 2 * INVERSION_ERROR * abs(35.5 - T_M), (effect, laplace)
        print(f"{quantity} {material} {geometry} layered={layered} L={L} w={w}: effect "
              f"{effect:.3g} K <= bound {bound:.3g} K, Laplace {laplace:.3g} K")


def test_perfusion_neglected_by_the_closed_form_without_evaluation():
    # the benchmark's cold layered, perfused scene: perfusion's closed form (0.0058 K) is within the
    # 0.3 K, so only the layers are weighed by evaluation; the model is the evaluated planner's
    from stimuli.planner import perfusion_bound
    scene = Scene(quantity="receptor", geometry="half-space", layered=True, perfusion_per_s=1.25e-3)
    p, q = plan(scene), plan(scene, screen=False)
    d = {x.effect: x for x in p.decisions}
    assert not d["perfusion"].included and "closed form" in d["perfusion"].note
    assert d["perfusion"].bound_K == perfusion_bound(scene) < 0.01
    assert p.model == q.model and d["layered"].included
    # explain (screen=False) still evaluates it, and the evaluated effect is below the closed form
    e = {x.effect: x for x in q.decisions}["perfusion"]
    assert "closed form" not in e.note and e.bound_K < d["perfusion"].bound_K
    # too loose for the tolerance: evaluated as before (homogeneous perfused skin, 2e-2 /s)
    heavy = Scene(quantity="receptor", geometry="half-space", perfusion_per_s=2e-2, tolerance_K=0.3)
    assert perfusion_bound(heavy) > 0.3
    assert "closed form" not in {x.effect: x for x in plan(heavy).decisions}["perfusion"].note


def test_layer_screen_keeps_only_layers_the_evaluation_keeps():
    # the screen (speed) keeps layered skin without evaluating it when its steady effect
    # at the receptor is >= LAYER_SCREEN tolerances; keeping is safe, but it must not keep layers
    # that evaluating them would neglect: on a grid, every screened keep is an evaluated keep
    from stimuli.planner_bounds import layers_matter
    screened = 0
    for material, geometry, R, L, frac, tol, duration, hyp in itertools.product(
            ["copper", "stainless_steel", "glass", "polystyrene_foam"],
            ["half-space", "slab"], [0.0, 1e-3], [400e-6, 650e-6, 1e-3], [0.1, 0.4, 0.7],
            [0.02, 0.3, 1.0], [5.0, 20.0], [None, 1e-3]):
        scene = Scene(quantity="receptor", material=material, geometry=geometry, resistance=R,
                      skin_thickness_m=L, receptor_fraction=frac, layered=True, hypodermis_m=hyp,
                      tolerance_K=tol, duration_s=duration, rate_Hz=100.0)
        if layers_matter(scene) is None:
            continue
        screened += 1
        p = plan(scene)
        assert {d.effect: d for d in p.decisions}["layered"].included
        evaluated = {d.effect: d for d in plan(scene, screen=False).decisions}["layered"]
        assert evaluated.included, (p.lines(), evaluated)
    assert screened > 100, screened


@pytest.mark.parametrize("quantity", ["receptor", "interface_material", "interface_skin"])
@pytest.mark.parametrize("geometry", ["half-space", "slab", "slab-on-support"])
def test_real_s_transform_is_the_layered_transform(quantity, geometry):
    # the planner's plain-float transform at a real s (its Laplace-domain bounds) is the exact
    # model's transform (stimuli.layered.LayeredTransform) at that s
    from stimuli.planner import _resolved
    from stimuli.planner_bounds import _real_quantity
    from stimuli.scene import scene_contact
    for layered, w, hyp, L in itertools.product([False, True], [0.0, 2e-2], [None, 2e-3],
                                                [400e-6, 3e-3]):
        scene = _resolved(Scene(quantity=quantity, geometry=geometry, layered=layered,
                                perfusion_per_s=w, hypodermis_m=hyp, skin_thickness_m=L,
                                support="wood" if geometry == "slab-on-support" else None))
        model = scene.full_model()
        c = scene_contact(scene, model)
        tr = c.transform
        s = np.array([1e-3, 0.05, 1.0, 40.0, 3e3])
        if quantity == "interface_material":
            want = tr.material_rise(s, tr.L).real
        else:
            x = c.thickness - scene.receptor_depth if quantity == "receptor" else tr.L
            want = tr.skin_deficit(s, float(x)).real
        got = np.array([_real_quantity(scene, model, scene.skin, float(si)) for si in s])
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)


def test_undecided_scene_decided_in_the_laplace_domain_without_evaluation():
    # the benchmark's scene with 2 mm of hypodermis: perfusion's closed form (0.53 K) exceeds the
    # 0.3 K and the skin is not quasi-steady, so before this the planner evaluated three models at
    # the probes; the Laplace-domain bounds decide both without evaluating anything, with the
    # evaluated planner's model, and the bounds hold against the exact models
    from stimuli import planner
    from stimuli.planner import perfusion_bound
    scene = Scene(quantity="receptor", geometry="half-space", layered=True, perfusion_per_s=1.25e-3,
                  hypodermis_m=2e-3, duration_s=20.0, rate_Hz=1000.0)
    assert perfusion_bound(scene) > 0.3
    calls = []
    real = planner._at_probes
    planner.plan_scene.cache_clear()
    try:
        planner._at_probes = lambda *a, **k: calls.append(a) or real(*a, **k)
        p = plan(scene)
    finally:
        planner._at_probes = real
        planner.plan_scene.cache_clear()
    assert calls == []                                  # nothing evaluated
    d = {x.effect: x for x in p.decisions}
    assert not d["perfusion"].included and "Laplace" in d["perfusion"].note
    assert d["layered"].included and "lower bound" in d["layered"].note
    q = plan(scene, screen=False)
    assert q.model == p.model
    full = evaluate(scene, scene.full_model())
    unperfused = evaluate(scene, Model("exact", "half-space", True, False))
    homogeneous = evaluate(scene, Model("exact", "half-space", False, False))
    assert np.max(np.abs(full - unperfused)) <= d["perfusion"].bound_K
    assert np.max(np.abs(p.evaluate() - full)) <= p.bound_K <= 0.3
    assert np.max(np.abs(homogeneous - full)) > 2 * 0.3


def test_undecided_perfusion_is_kept_unevaluated_only_where_the_layers_stay():
    # at 0.1 K neither perfusion bound fits (Laplace 0.137 K) although its effect is 0.059 K:
    # with the layers kept (their lower bound >= 2 tolerances) the model is exact and layered
    # either way and perfusion is in the same transfer matrix, so the planner keeps it without
    # evaluating anything (before: two models at the probes, 0.44 of an evaluation); the planned
    # model is then the full model. Without layers the same perfusion is still evaluated.
    from stimuli import planner
    from stimuli.planner import perfusion_bound, perfusion_laplace_bound

    def counted(scene, **kw):
        calls = []
        real = planner._at_probes
        planner.plan_scene.cache_clear()
        try:
            planner._at_probes = lambda *a, **k: calls.append(a) or real(*a, **k)
            return plan(scene, **kw), calls
        finally:
            planner._at_probes = real
            planner.plan_scene.cache_clear()

    near = Scene(quantity="receptor", geometry="half-space", layered=True, perfusion_per_s=1.25e-3,
                 hypodermis_m=2e-3, duration_s=20.0, rate_Hz=1000.0, tolerance_K=0.1)
    assert perfusion_bound(near) > 0.1
    assert perfusion_laplace_bound(near, near.full_model(), near.skin, 0.1) > 0.1
    p, calls = counted(near)
    assert calls == []
    d = {x.effect: x for x in p.decisions}
    assert d["perfusion"].included and "kept without evaluation" in d["perfusion"].note
    assert d["layered"].included
    assert p.model == near.full_model()
    full = evaluate(near, near.full_model())
    unperfused = evaluate(near, Model("exact", "half-space", True, False))
    assert 0 < np.max(np.abs(full - unperfused)) <= d["perfusion"].bound_K      # an upper bound
    assert np.max(np.abs(p.evaluate() - full)) <= p.bound_K <= 0.1
    # the evaluated planner may drop it (within the tolerance): both are right, neither cheaper
    q, _ = counted(near, screen=False)
    assert np.max(np.abs(q.evaluate() - full)) <= q.bound_K <= 0.1
    # homogeneous skin: dropping perfusion may open the way to Eq. 7, so it is evaluated as before
    homog = near.replace(layered=False, hypodermis_m=None, tolerance_K=0.005)
    assert perfusion_laplace_bound(homog, homog.full_model(), homog.skin, 0.005) > 0.005
    r, calls = counted(homog)
    assert calls, "perfusion of homogeneous skin is decided at the probes"
    assert "kept without evaluation" not in {x.effect: x for x in r.decisions}["perfusion"].note


def test_layer_lower_bound_is_a_lower_bound_and_its_keeps_are_evaluated_keeps():
    # the Laplace-domain screen keeps layered skin without evaluation when a lower bound of its
    # effect is >= LAYER_LOWER_SCREEN tolerances: the bound must be below the exact effect
    # (every quantity and geometry, hypodermis, short and long scenes), and every such keep an
    # evaluated keep
    from stimuli.planner import _resolved
    from stimuli.planner_bounds import LAYER_LOWER_SCREEN, _effect_lower_bound
    screened = 0
    for quantity, material, geometry, R, L, frac, duration, hyp, T_M in itertools.product(
            ["receptor", "interface_material", "interface_skin"],
            ["copper", "stainless_steel", "polystyrene_foam"], ["half-space", "slab"], [0.0, 1e-3],
            [400e-6, 1e-3], [0.1, 0.7], [1.0, 20.0], [None, 2e-3], [5.0, 45.0]):
        scene = Scene(quantity=quantity, material=material, geometry=geometry, resistance=R,
                      skin_thickness_m=L, receptor_fraction=frac, layered=True, hypodermis_m=hyp,
                      tolerance_K=0.3, duration_s=duration, rate_Hz=50.0,
                      skin_temperature_C=35.5, material_temperature_C=T_M)
        r = _resolved(scene)
        ref = scene.full_model()
        cand = Model("exact", geometry, False, False)
        low = _effect_lower_bound(r, ref, cand, r.skin, math.inf)
        effect = float(np.max(np.abs(evaluate(scene, cand) - evaluate(scene, ref))))
        assert low <= effect + 1e-9, (scene, low, effect)
        if low >= LAYER_LOWER_SCREEN * 0.3:
            screened += 1
            evaluated = {d.effect: d for d in plan(scene, screen=False).decisions}["layered"]
            assert evaluated.included, (scene, low, evaluated)
    assert screened > 50, screened
    print(f"Laplace layer screen: {screened} screened keeps, all evaluated keeps")
