"""The finite-volume solver against independent analytic solutions.

References (computed here, not by the code under test):
* surface step on a slab: the eigen series S = xi + 2/pi sum (-1)^n/n sin(n pi xi) e^{-n^2 pi^2 tau}
  (Carslaw & Jaeger §3.4), summed with mpmath;
* a linear surface ramp: its time integral, (xi t - L^2/alpha (xi - xi^3)/6 - 2 L^2/(alpha pi^3)
  sum (-1)^n sin(n pi xi)/n^3 e^{-n^2 pi^2 tau}), also with mpmath;
* two layers in series at steady state: T(d) = T0 + (g - T0) (d/k_d) / (d/k_d + (L-d)/k_e);
* contact of two half-spaces through R (early times, before the skin's inner boundary matters):
  theta_M(L+) = b_S/(b_S+b_M) (1 - erfcx(a sqrt t)), a = (b_S + b_M)/(R b_S b_M).
"""
from __future__ import annotations

import math

import mpmath as mp
import numpy as np
import pytest
from scipy.special import erfcx

from stimuli.errors import ModelInputError
from stimuli.finite_volume import Layer, solve_contact, solve_surface
from stimuli.properties import Material, Skin

STEEL = Material(14.9, 7900.0, 447.0)


def _eigen_step(skin, x, t):
    xi = mp.mpf(x) / mp.mpf(skin.thickness)
    tau = mp.mpf(skin.diffusivity) * mp.mpf(t) / mp.mpf(skin.thickness) ** 2
    return float(xi + 2 / mp.pi * mp.nsum(lambda n: (-1) ** n / n * mp.sin(n * mp.pi * xi)
                                          * mp.exp(-n ** 2 * mp.pi ** 2 * tau), [1, mp.inf]))


def _eigen_ramp(skin, x, t):
    L, a = mp.mpf(skin.thickness), mp.mpf(skin.diffusivity)
    xi, tau = mp.mpf(x) / L, a * mp.mpf(t) / L ** 2
    rest = mp.nsum(lambda n: (-1) ** n * mp.sin(n * mp.pi * xi) / n ** 3
                   * mp.exp(-n ** 2 * mp.pi ** 2 * tau), [1, mp.inf])
    return float(xi * mp.mpf(t) - L ** 2 / a * ((xi - xi ** 3) / 6 + 2 / mp.pi ** 3 * rest))


def _max_step_error(cells, skin, t, check):
    T = solve_surface(skin, t, np.full(t.size, 25.0), 35.0, cells=cells)
    return max(abs(T[i] - (35.0 - 10.0 * _eigen_step(skin, skin.dermis, t[i]))) for i in check)


def test_step_matches_eigen_series_and_converges_second_order():
    skin = Skin(1e-3)
    t = np.arange(2001) * 1e-2
    check = [10, 50, 200, 1000, 2000]
    e = [_max_step_error(c, skin, t, check) for c in (32, 64, 128)]
    assert e[2] < 2e-3
    assert 3.0 < e[0] / e[1] < 5.0 and 3.0 < e[1] / e[2] < 5.0   # halving cells: error / 4


def test_ramp_matches_series():
    skin = Skin(650e-6, dermis=400e-6)
    t = np.arange(1001) * 1e-2
    rate = -0.8                                          # K/s from 35 °C, no initial jump
    T = solve_surface(skin, t, 35.0 + rate * t, 35.0, cells=128)
    for i in (20, 100, 500, 1000):
        ref = 35.0 + rate * _eigen_ramp(skin, skin.dermis, t[i])
        assert abs(T[i] - ref) < 2e-4, (i, T[i], ref)


def test_layered_with_equal_properties_is_homogeneous():
    skin = Skin(900e-6)
    t = np.arange(501) * 2e-2
    g = 30.0 + np.sin(t)
    a = solve_surface(skin, t, g, 35.0)
    b = solve_surface(skin, t, g, 35.0, epidermis_properties=Layer(0.34, 1200.0, 3340.0))
    assert np.max(np.abs(a - b)) < 1e-12


def test_layered_steady_state_is_series_conduction():
    skin = Skin(1e-3, dermis=0.7e-3)
    epi = Layer(0.2, 1100.0, 3000.0)
    t = np.arange(201) * 2.0                           # 400 s: long past every time constant
    T = solve_surface(skin, t, np.full(t.size, 25.0), 35.0, epidermis_properties=epi)
    rd, re = 0.7e-3 / 0.34, 0.3e-3 / 0.2
    assert abs(T[-1] - (35.0 - 10.0 * rd / (rd + re))) < 1e-6
    # a more conductive epidermis lets the receptor cool faster
    fast = solve_surface(skin, t[:20], np.full(20, 25.0), 35.0, epidermis_properties=Layer(1.0, 1100.0, 3000.0))
    assert np.all(fast[1:] < T[1:20])


def test_depth_is_exact_face_and_edges():
    skin = Skin(1e-3)
    t = np.arange(11) * 0.5
    g = np.full(t.size, 30.0)
    assert np.all(solve_surface(skin, t, g, 35.0, depth=0.0) == 35.0)
    assert np.all(solve_surface(skin, t, g, 35.0, depth=1e-3) == 30.0)
    shallow = solve_surface(skin, t, g, 35.0, depth=0.9e-3)
    deep = solve_surface(skin, t, g, 35.0, depth=0.3e-3)
    assert np.all(shallow[1:] < deep[1:])


def test_contact_matches_half_space_pair_with_resistance_at_early_times():
    skin = Skin(1e-3)
    bs, bm = skin.effusivity, STEEL.effusivity
    t = np.array([0.0, 2e-3, 5e-3, 1e-2, 2e-2])
    for R in (0.0, 1e-4, 1e-3):
        T = solve_contact(skin, STEEL, R, 35.0, 24.0, t, depth=skin.thickness, side="material",
                          cells=64)
        if R == 0.0:
            ref = np.full(t.size, bs / (bs + bm))
        else:
            a = (bs + bm) / (R * bs * bm)
            ref = bs / (bs + bm) * (1.0 - erfcx(a * np.sqrt(t)))
        assert T[0] == (24.0 + 11.0 * bs / (bs + bm) if R == 0.0 else 24.0)
        assert np.max(np.abs((T[1:] - 24.0) / 11.0 - ref[1:])) < 2e-4, R


def test_contact_skin_side_and_resistance_drop():
    skin = Skin(1e-3)
    t = np.array([0.5, 5.0, 20.0])
    R = 5e-3
    s = solve_contact(skin, STEEL, R, 35.0, 24.0, t, depth=skin.thickness, side="skin")
    m = solve_contact(skin, STEEL, R, 35.0, 24.0, t, depth=skin.thickness, side="material")
    assert np.all(s > m)                             # temperature drops across R
    rec_lo = solve_contact(skin, STEEL, 0.0, 35.0, 24.0, t)
    rec_hi = solve_contact(skin, STEEL, R, 35.0, 24.0, t)
    assert np.all(rec_hi > rec_lo)                   # resistance keeps the receptor warmer


def test_contact_slab_with_insulated_back_warms_to_skin_temperature():
    skin = Skin(1e-3)
    slab = Material(14.9, 7900.0, 447.0, thickness=3e-3)
    t = np.array([1.0, 30.0, 1e5])
    T = solve_contact(skin, slab, 1e-3, 35.0, 24.0, t, depth=1e-3 + 3e-3)
    assert T[0] < T[1] < 35.0 and abs(T[2] - 35.0) < 1e-6
    early = [0.01, 0.05]                             # the back 3 mm away is not yet felt
    a = solve_contact(skin, slab, 1e-3, 35.0, 24.0, early, depth=1e-3, side="material")
    b = solve_contact(skin, STEEL, 1e-3, 35.0, 24.0, early, depth=1e-3, side="material")
    assert np.max(np.abs(a - b)) < 1e-4


@pytest.mark.parametrize("args, field", [
    (dict(resistance=-1.0), "resistance"),
    (dict(t=[-1.0]), "t"),
    (dict(depth=-1e-3), "depth"),
    (dict(side="left"), "side"),
    (dict(cells=1), "cells"),
])
def test_contact_bad_input(args, field):
    kw = dict(resistance=0.0, t=[1.0], depth=None, side="skin", cells=16)
    kw.update(args)
    with pytest.raises(ModelInputError, match=rf": {field}: expected"):
        solve_contact(Skin(1e-3), STEEL, kw["resistance"], 35.0, 24.0, kw["t"], kw["depth"],
                      side=kw["side"], cells=kw["cells"])


def test_layer_rejects_nonpositive():
    with pytest.raises(ModelInputError, match="Layer: density: expected"):
        Layer(0.3, 0.0, 3000.0)


def test_bisected_grid_is_self_similar_and_richardson_gains_two_orders():
    # splitting every cell in two divides the (second-order) error by 4 almost exactly, so the
    # Richardson combination (4 u2 - u1)/3 is far more accurate than either grid
    skin = Skin(1e-3)
    t = np.arange(2001) * 1e-2
    check = [10, 50, 200, 1000, 2000]
    ref = np.array([35.0 - 10.0 * _eigen_step(skin, skin.dermis, t[i]) for i in check])
    g = np.full(t.size, 25.0)
    u1 = solve_surface(skin, t, g, 35.0, cells=32)[check]
    u2 = solve_surface(skin, t, g, 35.0, cells=32, split=2)[check]
    e1, e2 = np.max(np.abs(u1 - ref)), np.max(np.abs(u2 - ref))
    assert 3.8 < e1 / e2 < 4.2
    assert np.max(np.abs((4 * u2 - u1) / 3 - ref)) < e2 / 20
    with pytest.raises(ModelInputError, match="split: expected"):
        solve_surface(skin, t, g, 35.0, split=0)


@pytest.mark.parametrize("name, thickness, R", [
    ("stainless_steel", None, 1e-3), ("stainless_steel", 3e-3, 0.0), ("wood", None, 5e-3),
    ("copper", 3e-3, 1e-4),
])
def test_contact_agrees_with_the_exact_laplace_solution(name, thickness, R):
    # two independent methods: finite volumes here, numerical Laplace inversion in stimuli.contact
    from stimuli.materials import material
    from stimuli.contact import Contact
    skin = Skin(800e-6)
    mat = material(name, thickness=thickness)
    t = np.array([0.01, 0.3, 2.0, 20.0])
    c = Contact(skin, mat, resistance=R, skin_temperature=35.0, material_temperature=20.0)
    for depth, side, exact in [
            (skin.thickness, "material", c.interface_temperature(t, side="material")),
            (skin.thickness, "skin", c.interface_temperature(t, side="skin")),
            (skin.dermis, "skin", c.receptor_temperature(t))]:
        u1 = solve_contact(skin, mat, R, 35.0, 20.0, t, depth=depth, side=side, cells=32)
        u2 = solve_contact(skin, mat, R, 35.0, 20.0, t, depth=depth, side=side, cells=32, split=2)
        assert np.max(np.abs(u2 - exact)) < 0.02, (depth, side)            # second order ...
        rich = (4.0 * u2 - u1) / 3.0                                       # ... and Richardson
        assert np.max(np.abs(rich - exact)) < 2e-4, (depth, side, rich, exact)


@pytest.mark.parametrize("name", ["copper", "polystyrene_foam"])
@pytest.mark.parametrize("R", [0.0, 1e-1])
def test_contact_hard_cases_finite_and_bounded(name, R):
    from stimuli.materials import material
    skin = Skin(5e-3)
    t = np.geomspace(1e-4, 1e4, 9)
    with np.errstate(all="raise"):
        for depth, side in [(0.0, "skin"), (skin.dermis, "skin"), (5e-3, "skin"), (5e-3, "material")]:
            T = solve_contact(skin, material(name), R, 35.0, 20.0, t, depth=depth, side=side)
            assert np.all(np.isfinite(T)) and np.all((T >= 20.0 - 1e-9) & (T <= 35.0 + 1e-9))


# --------------------------------------------------------------------------- surface through R
def test_surface_through_resistance_steady_state_is_series_conduction():
    skin = Skin(1e-3, dermis=0.7e-3)
    epi = Layer(0.2, 1100.0, 3000.0)
    t = np.arange(201) * 2.0                           # 400 s: long past every time constant
    R = 5e-4
    rd, re = 0.7e-3 / 0.34, 0.3e-3 / 0.2
    T = solve_surface(skin, t, np.full(t.size, 25.0), 35.0, epidermis_properties=epi, resistance=R)
    assert abs(T[-1] - (35.0 - 10.0 * rd / (rd + re + R))) < 1e-6
    Ts = solve_surface(skin, t, np.full(t.size, 25.0), 35.0, depth=1e-3, epidermis_properties=epi,
                       resistance=R)
    assert abs(Ts[-1] - (35.0 - 10.0 * (rd + re) / (rd + re + R))) < 1e-6


def test_surface_through_resistance_early_times_converge_second_order():
    # t << L^2/alpha: a half-space behind R (Carslaw & Jaeger §2.7):
    # T(L-) = T0 + h [1 - erfcx(H sqrt(alpha t))], H = 1 / (R lambda); images at 2L are below 1e-30
    skin = Skin(5e-3)
    R = 2e-4
    t = np.arange(101) * 1e-3
    z = np.sqrt(skin.diffusivity * t) / (R * skin.conductivity)
    exact = 35.0 - 10.0 * (1.0 - erfcx(z))
    errs = [np.max(np.abs(solve_surface(skin, t, np.full(t.size, 25.0), 35.0, depth=5e-3, cells=c,
                                        resistance=R)[20:] - exact[20:])) for c in (32, 64)]
    assert errs[1] < 2e-3 and 3.0 < errs[0] / errs[1] < 5.0


@pytest.mark.parametrize("bad", [-1e-4, float("nan"), "rough"])
def test_surface_bad_resistance(bad):
    with pytest.raises(ModelInputError, match=r"solve_surface: resistance: expected"):
        solve_surface(Skin(1e-3), np.arange(3) * 0.1, np.full(3, 30.0), 35.0, resistance=bad)
