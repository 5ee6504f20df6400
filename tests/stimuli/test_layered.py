"""Layered, perfused skin (stimuli.layered) against independent references."""
import itertools
import warnings

import numpy as np
import pytest

from stimuli import Contact, Skin, material
from stimuli.finite_volume import Layer, solve_contact
from stimuli.layered import BLOOD_HEAT_CAPACITY, LayeredContact, Tissue, skin_layers

from stimuli_mpref import theta_layered_reference

pytestmark = pytest.mark.filterwarnings("error")

TIMES = [1e-3, 0.1, 3.0, 20.0]


def _ref_layers(layers):
    return [(t.thickness, t.conductivity, t.density, t.specific_heat, t.perfusion, BLOOD_HEAT_CAPACITY)
            for t in layers]


def _ref_material(m):
    return (m.conductivity, m.density, m.specific_heat, m.thickness)


CASES = list(itertools.product(
    [0.0, 6.5e-4],                                    # R
    [None, 3e-3],                                     # half-space or slab
    [None, "pmma"],                                   # support under a slab
    [0.0, 1.25e-3, 2e-2],                              # perfusion, 1/s
    [None, 2e-3],                                     # hypodermis
))


#: four representative cases always; the whole product with ``-m slow`` (~40 s of mpmath)
_QUICK = {(6.5e-4, 3e-3, "pmma", 1.25e-3, 2e-3), (0.0, None, None, 2e-2, None),
          (6.5e-4, None, None, 1.25e-3, None), (0.0, 3e-3, None, 0.0, 2e-3)}


@pytest.mark.parametrize("R,D,support,w,hypo", [
    c if c in _QUICK else pytest.param(*c, marks=pytest.mark.slow)
    for c in CASES if not (c[1] is None and c[2])])
def test_layered_matches_mpmath_transfer_matrices(R, D, support, w, hypo):
    # 1e-9 K is the bound; this checks theta (K per K of T_S0 - T_M0) to 1e-10
    skin = Skin(650e-6)
    layers = skin_layers(skin, perfusion=w, hypodermis=hypo)
    mat = material("stainless_steel", D)
    sup = None if support is None else material(support)
    c = LayeredContact(layers, mat, R, 1.0, 0.0, support=sup)
    L = c.thickness
    ref_sup = None if sup is None else (sup.conductivity, sup.density, sup.specific_heat)
    points = [("receptor", L - skin.epidermis, "skin"), ("interface_skin", L, "skin"),
              ("interface_material", L, "material"), ("material", L + 1e-3, "material")]
    if hypo:
        points.append(("skin", 1e-3, "skin"))       # inside the hypodermis
    for q, x, kind in points:
        got = c.theta(q, TIMES, x)
        ref = [theta_layered_reference(_ref_layers(layers), _ref_material(mat), R, x, t, kind,
                                       support=ref_sup) for t in TIMES]
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-10, err_msg=f"{q} x={x}")


def test_one_layer_without_perfusion_is_the_homogeneous_contact():
    skin = Skin(650e-6)
    t = np.arange(20001) / 1000.0
    for D in (None, 3e-3):
        m = material("stainless_steel", D)
        lc = LayeredContact(skin_layers(skin, layered=False), m, 6.5e-4, 35.5, 20.0)
        c = Contact(skin, m, 6.5e-4, 35.5, 20.0)
        np.testing.assert_allclose(lc.temperature("receptor", t, skin.dermis),
                                   c.receptor_temperature(t), rtol=0, atol=1e-12)
        np.testing.assert_allclose(lc.temperature("interface_material", t),
                                   c.interface_temperature(t), rtol=0, atol=1e-12)


def test_layered_agrees_with_finite_volumes():
    # the independent numerical check: the finite-volume solver's layered skin (no perfusion)
    dermis, epi = skin_layers(Skin(650e-6))
    skin = Skin(650e-6, conductivity=dermis.conductivity, density=dermis.density,
                specific_heat=dermis.specific_heat)
    epi_props = Layer(epi.conductivity, epi.density, epi.specific_heat)
    steel = material("stainless_steel")
    c = LayeredContact((dermis, epi), steel, 6.5e-4, 35.5, 20.0)
    t = np.array([0.05, 1.0, 5.0, 20.0])
    fv = solve_contact(skin, steel, 6.5e-4, 35.5, 20.0, t, depth=skin.dermis, cells=64,
                       epidermis_properties=epi_props)
    ex = c.temperature("receptor", t, skin.dermis)
    np.testing.assert_allclose(ex, fv, rtol=0, atol=2e-3)
    # ... and layering matters here far more than that agreement
    homo = Contact(Skin(650e-6), steel, 6.5e-4, 35.5, 20.0).receptor_temperature(t)
    assert np.max(np.abs(ex - homo)) > 0.1


def test_perfusion_warms_the_receptor_and_is_small_at_20_s():
    skin, steel = Skin(650e-6), material("stainless_steel")
    t = np.array([1.0, 8.0, 20.0])
    cold = LayeredContact(skin_layers(skin), steel, 6.5e-4, 35.5, 20.0).temperature("receptor", t, skin.dermis)
    warm = LayeredContact(skin_layers(skin, perfusion=1.25e-3), steel, 6.5e-4, 35.5, 20.0).temperature(
        "receptor", t, skin.dermis)
    assert np.all(warm >= cold)
    assert np.max(warm - cold) < 0.05           # Pennes length ~9 mm >> 0.65 mm of skin
    assert Tissue(1e-3, 0.45, 1200, 3300, 1.25e-3).pennes_length > 5e-3


@pytest.mark.parametrize("L", [50e-6, 650e-6, 5e-3])
@pytest.mark.parametrize("D,support", [(None, None), (3e-3, None), (3e-3, "copper")])
def test_no_nan_inf_or_warning_on_the_hard_grid_with_layers_and_perfusion(L, D, support):
    t = np.concatenate([[0.0], np.geomspace(1e-4, 1e4, 120)])
    skin = Skin(L)
    sup = None if support is None else material(support)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name in ("copper", "polystyrene_foam", "stainless_steel"):
            mat = material(name, D)
            for R in (0.0, 1e-12, 1e-6, 1e-3, 1e-1):
                for w, hypo in ((0.0, None), (2e-2, 2e-3)):
                    c = LayeredContact(skin_layers(skin, perfusion=w, hypodermis=hypo), mat, R, 1.0, 0.0,
                                       support=sup)
                    vals = [c.theta("skin", t, 0.0), c.theta("receptor", t, c.thickness - skin.epidermis),
                            c.theta("interface_skin", t), c.theta("interface_material", t)]
                    if D is not None:
                        vals.append(c.theta("material", t, c.thickness + D))
                    for v in vals:
                        assert np.all(np.isfinite(v))
                        assert np.all((v > -1e-12) & (v < 1 + 1e-12))


def test_display_driven_layered_response_matches_homogeneous_and_finite_volumes():
    from stimuli import skin_response
    from stimuli.layered import layered_skin_response
    skin = Skin(650e-6)
    t = np.arange(20001) * 1e-3
    g = 22.0 + 3.0 * (1.0 - np.exp(-t / 5.0))
    dermis, epi = skin_layers(skin)
    derm_skin = Skin(650e-6, conductivity=dermis.conductivity, density=dermis.density,
                     specific_heat=dermis.specific_heat)
    for R in (0.0, 6e-4):
        one = layered_skin_response(skin_layers(skin, layered=False), t, g, 35.5, skin.dermis, resistance=R)
        np.testing.assert_allclose(one, skin_response(skin, t, g, 35.5, resistance=R), rtol=0, atol=1e-11)
        two = layered_skin_response((dermis, epi), t, g, 35.5, skin.dermis, resistance=R)
        fv = skin_response(derm_skin, t, g, 35.5, method="numerical", resistance=R, cells=64,
                           epidermis_properties=Layer(epi.conductivity, epi.density, epi.specific_heat))
        np.testing.assert_allclose(two, fv, rtol=0, atol=1e-6)


def test_display_driven_perfused_steady_state_is_the_pennes_profile():
    # constant surface for a long time: u(x) = h sinh(q x) / sinh(q L), q = sqrt(w rho_b c_b / k)
    from stimuli.layered import layered_skin_response
    w = 2e-2
    layer = (Tissue(1e-3, 0.45, 1200.0, 3300.0, w),)
    t = np.arange(2001) * 1.0                              # 2000 s >> L^2 / alpha
    x = 0.4e-3
    got = layered_skin_response(layer, t, np.full(t.size, 25.0), 35.0, x)[-1]
    q = np.sqrt(w * BLOOD_HEAT_CAPACITY / 0.45)
    want = 35.0 - 10.0 * np.sinh(q * x) / np.sinh(q * 1e-3)
    assert abs(got - want) < 1e-9


@pytest.mark.parametrize("L", [50e-6, 650e-6, 5e-3])
def test_display_driven_layered_response_on_the_hard_grid(L):
    # finite, warning-free, and within the extremes of the surface history and T_S0 (maximum principle)
    from stimuli.layered import layered_skin_response
    skin = Skin(L)
    t = np.arange(2001) * 0.01
    g = 22.0 + 8.0 * np.sin(t) ** 2
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for R in (0.0, 1e-12, 1e-3, 1e-1):
            for w, hypo in ((0.0, None), (2e-2, 2e-3)):
                layers = skin_layers(skin, perfusion=w, hypodermis=hypo)
                top = sum(x.thickness for x in layers)
                for x in (top - skin.epidermis, top):
                    u = layered_skin_response(layers, t, g, 35.0, x, resistance=R)
                    assert np.all(np.isfinite(u))
                    assert np.all((u >= 22.0 - 1e-9) & (u <= 35.0 + 1e-9))
