"""Contact: API behaviour, trends, method selection, errors."""
import numpy as np
import pytest

from stimuli import Contact, ModelInputError, Skin, contact_resistance, material

pytestmark = pytest.mark.filterwarnings("error")

STEEL = material("stainless_steel")


def test_skin_side_interface_rises_with_R():
    skin = Skin(650e-6)
    t = np.array([0.5, 5.0, 20.0])
    temps = [Contact(skin, STEEL, R, 35.0, 24.0).interface_temperature(t, side="skin")
             for R in (0.0, 1e-4, 1e-3, 1e-2, 1e-1)]
    assert np.all(np.diff(np.array(temps), axis=0) > 0)


def test_material_side_interface_falls_with_R():
    skin = Skin(650e-6)
    temps = [Contact(skin, STEEL, R, 35.0, 24.0).interface_temperature([20.0])[0]
             for R in (0.0, 1e-4, 1e-3, 1e-2)]
    assert np.all(np.diff(temps) < 0)


def test_receptor_drop_smaller_for_thicker_skin():
    # Remark 1 of the paper: the thicker the skin, the smaller the drop at the receptors.
    # True of the exact model during the first seconds (t <= 2 s here); later it reverses,
    # because x = 0 is held at T_S0 and a thin skin's receptors sit closer to that core
    # (at 20 s the drops are 5.38, 6.05, 6.53, 6.87 K for L = 0.6 ... 1.2 mm).
    t = np.array([0.2, 0.5, 1.0, 2.0])
    R = contact_resistance(1.6e-6)
    drops = [36.0 - Contact(Skin(L), STEEL, R, 36.0, 20.0).receptor_temperature(t)
             for L in (600e-6, 800e-6, 1000e-6, 1200e-6)]
    assert np.all(np.diff(np.array(drops), axis=0) < 0)


def test_receptor_temperature_rises_with_roughness():
    skin = Skin(650e-6)
    vals = [Contact(skin, STEEL, contact_resistance(ra), 36.0, 20.0).receptor_temperature([20.0])[0]
            for ra in (0.4e-6, 1.6e-6, 12.5e-6, 50e-6, 100e-6)]
    assert np.all(np.diff(vals) > 0)


@pytest.mark.parametrize("name", ["copper", "stainless_steel", "polystyrene_foam"])
@pytest.mark.parametrize("R", [0.0, 1e-3, 1e-1])
def test_psi_in_unit_interval(name, R):
    c = Contact(Skin(1e-3), material(name), R, 35.0, 20.0)
    psi = c.recognizing_profile(np.concatenate([[0.0], np.geomspace(1e-4, 1e4, 60)]))
    assert np.all((psi >= -1e-12) & (psi <= 1 + 1e-12))


def test_initial_values():
    skin = Skin(650e-6)
    c0 = Contact(skin, STEEL, 0.0, 36.0, 20.0)
    tc = (skin.effusivity * 36 + STEEL.effusivity * 20) / (skin.effusivity + STEEL.effusivity)
    assert c0.interface_temperature(0.0) == pytest.approx(tc, abs=1e-12)
    assert c0.interface_temperature(1e-6) == pytest.approx(tc, abs=1e-3)
    c1 = Contact(skin, STEEL, 1e-3, 36.0, 20.0)
    assert c1.interface_temperature(0.0) == 20.0
    assert c1.interface_temperature(0.0, side="skin") == 36.0
    assert c1.receptor_temperature(0.0) == 36.0


def test_slab_and_half_space_agree_early_and_differ_late():
    skin = Skin(650e-6)
    half = Contact(skin, STEEL, 6.5e-4, 35.0, 24.0)
    slab = Contact(skin, material("stainless_steel", thickness=3e-3), 6.5e-4, 35.0, 24.0)
    assert abs(half.interface_temperature(0.05) - slab.interface_temperature(0.05)) < 1e-6
    assert slab.interface_temperature(20.0) > half.interface_temperature(20.0) + 0.1


def test_tolerance_picks_cheapest_and_reports():
    c = Contact(Skin(650e-6), STEEL, 0.0, 36.0, 20.0)
    t = np.linspace(0, 20, 201)
    _, info = c.interface_temperature(t, tolerance=2.0, full_output=True)
    assert info.method == "paper-as-printed"
    assert 1.0 < info.error_bound <= 2.0
    _, info = c.interface_temperature(t, tolerance=1e-6, full_output=True)
    assert info.method == "exact"
    with pytest.raises(ModelInputError, match="tolerance"):
        c.interface_temperature(t, tolerance=1e-14)


def test_numerical_method_close_to_exact():
    c = Contact(Skin(650e-6), STEEL, 6.5e-4, 35.0, 24.0)
    t = np.array([0.5, 5.0, 20.0])
    np.testing.assert_allclose(c.receptor_temperature(t, method="numerical"),
                               c.receptor_temperature(t), atol=0.05)


@pytest.mark.parametrize("L,name,R", [(50e-6, "foam", 1e-3), (5e-3, "copper", 0.0),
                                      (650e-6, "stainless_steel", 7e-4)])
def test_numerical_method_holds_over_eight_decades_of_time(L, name, R):
    # Regression: one finite-volume grid for t in [1e-4, 1e4] s (foam, 50 µm skin) was off by
    # 0.18 in theta at t = 2.6e-4 s; solve_contact now uses one grid per window of times.
    c = Contact(Skin(L), material(name), R, 1.0, 0.0)
    t = np.concatenate([[0.0], np.geomspace(1e-4, 1e4, 81)])
    for side in ("material", "skin"):
        np.testing.assert_allclose(c.interface_temperature(t, side=side, method="numerical"),
                                   c.interface_temperature(t, side=side), atol=1e-3)
    np.testing.assert_allclose(c.receptor_temperature(t, method="numerical"),
                               c.receptor_temperature(t), atol=2e-3)


def test_paper_methods_refuse_slabs():
    c = Contact(Skin(650e-6), material("ss", 3e-3), 0.0, 35.0, 24.0)
    with pytest.raises(ModelInputError, match="half-space"):
        c.interface_temperature([1.0], method="paper")


@pytest.mark.parametrize("kwargs,match", [
    (dict(resistance=-1.0), "resistance"),
    (dict(resistance=float("nan")), "resistance"),
    (dict(skin_temperature="warm"), "skin_temperature"),
])
def test_bad_construction(kwargs, match):
    args = dict(skin=Skin(650e-6), material=STEEL, resistance=0.0, skin_temperature=35.0,
                material_temperature=24.0)
    args.update(kwargs)
    with pytest.raises(ModelInputError, match=match):
        Contact(**args)


def test_bad_calls():
    c = Contact(Skin(650e-6), STEEL, 0.0, 35.0, 24.0)
    with pytest.raises(ModelInputError, match="t: expected finite times"):
        c.interface_temperature([-1.0])
    with pytest.raises(ModelInputError, match="x: expected"):
        c.skin_temperature(1e-3, [1.0])
    with pytest.raises(ModelInputError, match="side"):
        c.interface_temperature([1.0], side="left")
    with pytest.raises(ModelInputError, match="method"):
        c.interface_temperature([1.0], method="magic")


def test_unknown_method_error_names_every_valid_choice():
    c = Contact(Skin(650e-6), STEEL, 0.0, 35.0, 24.0)
    with pytest.raises(ModelInputError) as err:
        c.receptor_temperature([1.0], method="magic")
    for name in ("exact", "paper", "paper-as-printed", "numerical"):
        assert repr(name) in str(err.value)


def test_method_table_maps_names_to_evaluators():
    # the solve_ivp shape: one dict name -> implementation, the same the evaluators dispatch on
    from stimuli import METHODS
    assert list(METHODS) == ["exact", "paper", "paper-as-printed", "numerical"]
    assert all(callable(f) for f in METHODS.values())
    c = Contact(Skin(650e-6), STEEL, 6.5e-4, 35.0, 24.0)
    t = np.array([0.5, 5.0])
    for name, evaluate in METHODS.items():
        np.testing.assert_array_equal(evaluate(c, "interface_material", 650e-6, t),
                                      c.theta("interface_material", 650e-6, t, method=name))


@pytest.mark.parametrize("call", [
    lambda c, **kw: c.interface_temperature([1.0, 20.0], side="skin", **kw),
    lambda c, **kw: c.skin_temperature(3e-4, [1.0, 20.0], **kw),
    lambda c, **kw: c.material_temperature(1e-3, [1.0, 20.0], **kw),
    lambda c, **kw: c.receptor_temperature([1.0, 20.0], **kw),
    lambda c, **kw: c.recognizing_profile([1.0, 20.0], **kw),
])
def test_full_output_returns_the_values_and_their_method_info(call):
    from stimuli import MethodInfo
    c = Contact(Skin(650e-6), STEEL, 0.0, 35.0, 24.0)
    plain = call(c, tolerance=2.0)
    assert isinstance(plain, np.ndarray)               # without full_output: values only, as before
    values, info = call(c, tolerance=2.0, full_output=True)
    np.testing.assert_array_equal(values, plain)
    assert isinstance(info, MethodInfo)
    assert info.method in ("paper-as-printed", "exact") and info.error_bound <= 2.0
    _, exact = call(c, method="exact", full_output=True)
    assert exact.method == "exact" and exact.error_bound > 0
    _, printed = call(c, method="paper-as-printed", full_output=True)
    assert printed.method == "paper-as-printed" and np.isnan(printed.error_bound)
    assert not hasattr(c, "last_info")                  # no mutable side channel left
