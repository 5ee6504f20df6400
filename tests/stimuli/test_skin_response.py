"""skin_response (stimuli.display_response) against an independent high-precision reference.

The reference inverts the Laplace-domain solution (docs/design.md) with mpmath (Talbot, 30 digits):
a unit surface step gives sinh(q x) / (s sinh(q L)), a unit ramp sinh(q x) / (s^2 sinh(q L)),
q = sqrt(s / alpha). A surface history that is piecewise linear with few kinks, *sampled* at 1 kHz,
is exactly its own linear interpolant, so its exact response is a short sum of such inversions:
u(t) = h0 S(t) + sum_k (m_k - m_{k-1}) Rr(t - t_k). No series or FFT of the code under test is used.
"""
from __future__ import annotations

import math

import mpmath as mp
import numpy as np
import pytest

from stimuli.display_response import skin_response
from stimuli.errors import ModelInputError
from stimuli.finite_volume import Layer
from stimuli.properties import Skin


def _laplace_pair(skin, x):
    a = mp.mpf(skin.conductivity) / (mp.mpf(skin.density) * mp.mpf(skin.specific_heat))
    L, x = mp.mpf(skin.thickness), mp.mpf(x)

    def step(s):
        q = mp.sqrt(s / a)
        return mp.sinh(q * x) / (s * mp.sinh(q * L))

    def ramp(s):
        q = mp.sqrt(s / a)
        return mp.sinh(q * x) / (s * s * mp.sinh(q * L))

    def S(t):
        return mp.invertlaplace(step, t, method="talbot") if t > 0 else mp.mpf(0)

    def Rr(t):
        return mp.invertlaplace(ramp, t, method="talbot") if t > 0 else mp.mpf(0)

    return S, Rr


# kinks of the test history: (time s, slope K/s from there on); h0 relative to T_S0
H0 = -8.0
KINKS = [(0.0, -0.6), (2.0, 0.5), (7.5, 0.0), (12.3, 0.9), (16.0, -0.3)]


def _history(t):
    h = np.full_like(t, H0)
    prev = 0.0
    for tk, m in KINKS:
        h += (m - prev) * np.clip(t - tk, 0.0, None)
        prev = m
    return h


def _reference(skin, x, t):
    S, Rr = _laplace_pair(skin, x)
    with mp.workdps(30):
        u = mp.mpf(H0) * S(mp.mpf(t))
        prev = 0.0
        for tk, m in KINKS:
            if t > tk:
                u += mp.mpf(m - prev) * Rr(mp.mpf(t) - mp.mpf(tk))
            prev = m
    return float(u)


@pytest.mark.parametrize("thickness, depth", [(1.0e-3, None), (650e-6, 0.2e-3), (100e-6, None), (5e-3, 4.9e-3)])
def test_exact_20s_at_1kHz_within_1e_6_K_of_mpmath(thickness, depth):
    skin = Skin(thickness)
    x = skin.dermis if depth is None else depth
    t = np.arange(20001) * 1e-3
    T0 = 35.0
    T = skin_response(skin, t, T0 + _history(t), initial_temperature=T0, depth=depth)
    assert T.shape == t.shape and T[0] == T0
    for i in [1, 37, 500, 2000, 2001, 4321, 7500, 12300, 12301, 16000, 20000]:
        ref = T0 + _reference(skin, x, t[i])
        assert abs(T[i] - ref) < 1e-6, (i, T[i], ref)


def test_exact_constant_step_matches_eigen_series_far_in_time():
    # Eigen series by hand (mpmath): S = xi + 2/pi sum (-1)^n/n sin(n pi xi) exp(-n^2 pi^2 tau)
    skin = Skin(650e-6)
    t = np.linspace(0.0, 60.0, 601)
    T = skin_response(skin, t, np.full(t.size, 20.0), initial_temperature=36.0)
    xi = mp.mpf(skin.dermis) / mp.mpf(skin.thickness)
    for i in [5, 50, 300, 600]:
        tau = mp.mpf(skin.diffusivity) * mp.mpf(t[i]) / mp.mpf(skin.thickness) ** 2
        S = xi + 2 / mp.pi * mp.nsum(lambda n: (-1) ** n / n * mp.sin(n * mp.pi * xi)
                                     * mp.exp(-n ** 2 * mp.pi ** 2 * tau), [1, mp.inf])
        assert abs(T[i] - float(36 - 16 * S)) < 1e-9


def test_paper_form_is_first_image_term_and_its_bound_holds():
    skin = Skin(1e-3)
    t = np.arange(4001) * 1e-3
    g = 35.0 + _history(t)
    T_exact = skin_response(skin, t, g)
    T_paper, info = skin_response(skin, t, g, method="paper", full_output=True)
    err = np.max(np.abs(T_paper - T_exact))
    assert info.method == "paper"
    assert 1e-6 < err <= info.error_bound          # a real, bounded approximation
    printed, pinfo = skin_response(skin, t, g, method="paper-as-printed", full_output=True)
    assert np.all(printed == 35.0)                 # Eq. 8's (1 + gamma)/2 -> 0 for a display
    assert np.max(np.abs(printed - T_exact)) <= pinfo.error_bound


def test_tolerance_picks_cheapest_method_and_reports_it():
    skin = Skin(1e-3)
    short = np.arange(501) * 1e-3
    long = np.arange(20001) * 1e-3
    _, info = skin_response(skin, long, np.full(long.size, 30.0), tolerance=1e-6, full_output=True)
    assert info.method == "exact" and info.error_bound <= 1e-6
    _, info = skin_response(skin, short, np.full(short.size, 30.0), tolerance=1e-2, full_output=True,
                            epidermis_properties=Layer(0.5, 1200.0, 3340.0))
    assert info.method == "numerical" and info.error_bound <= 1e-2


def test_numerical_agrees_with_exact():
    skin = Skin(1e-3)
    t = np.arange(2001) * 1e-2
    g = 35.0 + _history(t)
    T_exact = skin_response(skin, t, g)
    T_num, info = skin_response(skin, t, g, method="numerical", full_output=True)
    err = np.max(np.abs(T_num - T_exact))
    assert err < 1e-4
    assert err <= info.error_bound < 30 * err      # the estimate is conservative, not absurdly
    finer = skin_response(skin, t, g, method="numerical", cells=64)
    assert np.max(np.abs(finer - T_exact)) < 1e-6 < err   # fourth order: 2x cells, ~16x smaller


def test_surface_and_inner_boundary():
    skin = Skin(1e-3)
    t = np.arange(11) * 0.1
    g = np.linspace(30.0, 31.0, 11)
    assert np.array_equal(skin_response(skin, t, g, depth=skin.thickness), g)
    assert np.all(skin_response(skin, t, g, depth=0.0) == 35.0)


def test_no_warnings_nan_for_extremes():
    for L in (100e-6, 5e-3):
        skin = Skin(L)
        t = np.arange(10001) * 1.0
        with np.errstate(all="raise"):
            T = skin_response(skin, t, np.full(t.size, 20.0), depth=L * 0.999)
        assert np.all(np.isfinite(T)) and np.all((T >= 20.0 - 1e-9) & (T <= 35.0 + 1e-9))


@pytest.mark.parametrize("kwargs, field", [
    (dict(t=np.array([0.0, 0.1, 0.3])), "t"),
    (dict(t=np.array([0.1, 0.2, 0.3])), "t"),
    (dict(surface_temperature=np.array([30.0, 30.0])), "surface_temperature"),
    (dict(surface_temperature=np.array([30.0, np.nan, 30.0])), "surface_temperature"),
    (dict(depth=2e-3), "depth"),
    (dict(method="magic"), "method"),
    (dict(tolerance=-1.0), "tolerance"),
    (dict(method="exact", epidermis_properties=Layer(1.0, 1.0, 1.0)), "method"),
])
def test_bad_input_names_the_field(kwargs, field):
    args = dict(t=np.array([0.0, 0.1, 0.2]), surface_temperature=np.array([30.0, 30.0, 30.0]))
    args.update(kwargs)
    with pytest.raises(ModelInputError, match=rf"skin_response: {field}: expected"):
        skin_response(Skin(1e-3), **args)


def test_response_is_linear_and_monotone_in_surface_temperature():
    skin = Skin(800e-6)
    t = np.arange(3001) * 1e-3
    rng = np.random.default_rng(20240601)
    g1 = 30.0 + np.cumsum(rng.normal(0.0, 0.01, t.size))
    g2 = 30.0 + 2.0 * np.sin(t)
    a = skin_response(skin, t, g1) - 35.0
    b = skin_response(skin, t, g2) - 35.0
    ab = skin_response(skin, t, g1 + g2 - 35.0) - 35.0
    assert np.max(np.abs(ab - (a + b))) < 1e-10
    colder = skin_response(skin, t, g2 - 1.0)
    assert np.all(colder <= b + 35.0)
    assert np.all(colder[100:] < b[100:] + 35.0)   # after 0.1 s the receptor has felt the step
    assert math.isclose(colder[0], 35.0)


# --------------------------------------------------------------------------- contact resistance
# Robin condition at x = L: -lambda dT/dx = (T(L-) - g) / R. With u = A sinh(q x) (u(0) = 0):
# -lambda q A cosh(q L) = (A sinh(q L) - G) / R, so u = G sinh(q x) / (sinh(q L) + R lambda q cosh(q L)),
# lambda q = beta sqrt(s). Written again here in plain mpmath hyperbolics, inverted by Talbot.
def _robin_pair(skin, x, R):
    a = mp.mpf(skin.conductivity) / (mp.mpf(skin.density) * mp.mpf(skin.specific_heat))
    lam, L, x, R = mp.mpf(skin.conductivity), mp.mpf(skin.thickness), mp.mpf(x), mp.mpf(R)

    def K(s):
        q = mp.sqrt(s / a)
        return mp.sinh(q * x) / (mp.sinh(q * L) + R * lam * q * mp.cosh(q * L))

    def S(t):
        return mp.invertlaplace(lambda s: K(s) / s, t, method="talbot") if t > 0 else mp.mpf(0)

    def Rr(t):
        return mp.invertlaplace(lambda s: K(s) / (s * s), t, method="talbot") if t > 0 else mp.mpf(0)

    return S, Rr


def _robin_reference(skin, x, R, t):
    S, Rr = _robin_pair(skin, x, R)
    with mp.workdps(30):
        u = mp.mpf(H0) * S(mp.mpf(t))
        prev = 0.0
        for tk, m in KINKS:
            if t > tk:
                u += mp.mpf(m - prev) * Rr(mp.mpf(t) - mp.mpf(tk))
            prev = m
    return float(u)


@pytest.mark.parametrize("thickness, depth, R", [
    (650e-6, None, 6.5e-4),          # a finger-pad resistance of Eq. 5's size
    (650e-6, 650e-6, 6.5e-4),        # the skin side L- of the contact
    (1.0e-3, None, 2e-5),            # small R: close to the Dirichlet case
    (100e-6, 100e-6, 1e-2),          # thin skin, large R
])
def test_resistance_exact_20s_at_1kHz_within_1e_6_K_of_mpmath(thickness, depth, R):
    skin = Skin(thickness)
    x = skin.dermis if depth is None else depth
    t = np.arange(20001) * 1e-3
    T0 = 35.0
    T, info = skin_response(skin, t, T0 + _history(t), initial_temperature=T0, depth=depth,
                            resistance=R, full_output=True)
    assert info.method == "exact" and info.error_bound < 1e-6
    assert T[0] == T0
    worst = 0.0
    for i in [1, 37, 500, 2000, 2001, 7500, 12301, 16000, 20000]:
        ref = T0 + _robin_reference(skin, x, R, t[i])
        worst = max(worst, abs(T[i] - ref))
    assert worst <= max(info.error_bound, 1e-9), worst


def test_resistance_numerical_agrees_with_exact_and_its_estimate_holds():
    skin = Skin(650e-6)
    t = np.arange(2001) * 1e-2
    g = 35.0 + _history(t)
    for depth in (None, skin.thickness):
        T_exact = skin_response(skin, t, g, depth=depth, resistance=6.5e-4)
        T_num, info = skin_response(skin, t, g, depth=depth, resistance=6.5e-4, method="numerical",
                                    full_output=True)
        err = np.max(np.abs(T_num - T_exact))
        assert info.method == "numerical" and err < 1e-4 and err <= info.error_bound


def test_resistance_zero_is_dirichlet_and_small_resistance_is_continuous():
    skin = Skin(650e-6)
    t = np.arange(5001) * 1e-3
    g = 35.0 + _history(t)
    dirichlet = skin_response(skin, t, g)
    assert np.array_equal(skin_response(skin, t, g, resistance=0.0), dirichlet)
    assert np.array_equal(skin_response(skin, t, g, resistance=None), dirichlet)
    diffs = [np.max(np.abs(skin_response(skin, t, g, resistance=R) - dirichlet)) for R in (1e-5, 1e-6, 1e-7)]
    # the receptor's gain d / (L + R lambda) moves by O(R): the difference shrinks ~10x per decade
    assert diffs[0] > diffs[1] > diffs[2] and diffs[2] < 2e-3 and diffs[0] / diffs[2] > 30


def test_large_resistance_limits():
    skin = Skin(650e-6)
    lam, alpha = skin.conductivity, skin.diffusivity
    t = np.arange(6001) * 1e-2                  # 60 s: tau = alpha t / L^2 > 10, steady
    g = np.full(t.size, 25.0)                   # a 10 K step
    for R in (1e-2, 1e-1, 1.0):
        T = skin_response(skin, t, g, initial_temperature=35.0, resistance=R)
        # steady state: a series circuit R + d / lambda of the total L / lambda + R
        assert abs(T[-1] - (35.0 - 10.0 * skin.dermis / (skin.thickness + R * lam))) < 1e-9
        # surface, short times: a half-space behind R (Carslaw & Jaeger §2.7),
        # u = h [1 - exp(H^2 alpha t) erfc(H sqrt(alpha t))], H = 1 / (R lambda)
        Ts = skin_response(skin, t[:11], g[:11], initial_temperature=35.0, depth=skin.thickness,
                           resistance=R)
        for i in (1, 5, 10):
            z = mp.sqrt(mp.mpf(alpha) * t[i]) / (mp.mpf(R) * mp.mpf(lam))
            ref = 35.0 - 10.0 * float(1 - mp.exp(z * z) * mp.erfc(z))
            assert abs(Ts[i] - ref) < 1e-3 * 10.0 * float(z) + 1e-9     # images at 2L: e^-(L^2/alpha t)
    # and the receptor's whole response falls as 1/R once R >> L / lambda
    a = skin_response(skin, t, g, initial_temperature=35.0, resistance=1.0) - 35.0
    b = skin_response(skin, t, g, initial_temperature=35.0, resistance=10.0) - 35.0
    felt = np.abs(b) > 1e-8                     # above the inversion's ~1e-13 K absolute noise
    assert felt.sum() > 5900 and np.max(np.abs(a[felt] / b[felt] - 10.0)) < 0.05


@pytest.mark.parametrize("kwargs, field", [
    (dict(resistance=-1e-4), "resistance"),
    (dict(resistance=float("nan")), "resistance"),
    (dict(resistance=1e-4, method="paper"), "method"),
    (dict(resistance=1e-4, epidermis_properties=Layer(0.5, 1200.0, 3340.0)), "method"),
])
def test_resistance_bad_input_names_the_field(kwargs, field):
    args = dict(t=np.array([0.0, 0.1, 0.2]), surface_temperature=np.array([30.0, 30.0, 30.0]))
    args.update(kwargs)
    with pytest.raises(ModelInputError, match=rf"skin_response: {field}: expected"):
        skin_response(Skin(1e-3), **args)


def test_resistance_layered_numerical():
    skin = Skin(650e-6)
    t = np.arange(2001) * 1e-2
    g = 35.0 + _history(t)
    same = Layer(skin.conductivity, skin.density, skin.specific_heat)
    T_layer = skin_response(skin, t, g, method="numerical", epidermis_properties=same, resistance=6.5e-4)
    T_exact = skin_response(skin, t, g, resistance=6.5e-4)
    assert np.max(np.abs(T_layer - T_exact)) < 1e-4
    T_tol, info = skin_response(skin, t, g, tolerance=1e-5, epidermis_properties=Layer(0.5, 1200.0, 3340.0),
                                resistance=6.5e-4, full_output=True)
    assert info.method == "numerical" and info.error_bound <= 1e-5


@pytest.mark.parametrize("resistance", [None, 1e-4])
def test_unknown_method_error_names_every_valid_choice(resistance):
    from stimuli.display_response import METHODS
    t = np.array([0.0, 0.1, 0.2])
    with pytest.raises(ModelInputError) as err:
        skin_response(Skin(1e-3), t, np.full(3, 30.0), method="magic", resistance=resistance)
    assert list(METHODS) == ["exact", "paper", "paper-as-printed", "numerical"]
    assert "expected one of exact, paper, paper-as-printed, numerical, got 'magic'" in str(err.value)


def test_method_tables_dispatch_to_the_same_results():
    # the solve_ivp shape: one dict name -> implementation per boundary condition; calling a
    # table entry on a problem gives what skin_response(method=name) gives
    from stimuli.display_response import METHODS, ROBIN_METHODS, _Problem
    skin = Skin(650e-6)
    t = np.arange(201) * 1e-2
    g = 35.0 + _history(t)
    h = g - 35.0
    for table, R in ((METHODS, 0.0), (ROBIN_METHODS, 6.5e-4)):
        for name, method in table.items():
            u, info = method(_Problem(skin, t, 1e-2, h, 35.0, skin.dermis, 8, None, R))
            T, ref = skin_response(skin, t, g, method=name, resistance=R or None, cells=8,
                                   full_output=True)
            np.testing.assert_array_equal(35.0 + u, T)
            assert info == ref and info.method == name
    assert list(ROBIN_METHODS) == ["exact", "numerical"]


@pytest.mark.parametrize("resistance", [None, 6.5e-4])
def test_refinement_doubles_cells_until_the_estimate_is_within_tolerance(resistance):
    # one refinement loop for both boundary conditions: the grid is doubled from `cells`
    skin = Skin(650e-6)
    t = np.arange(1001) * 1e-2
    g = 35.0 + _history(t)
    epi = Layer(0.5, 1200.0, 3340.0)
    _, coarse = skin_response(skin, t, g, method="numerical", epidermis_properties=epi, cells=4,
                              resistance=resistance, full_output=True)
    _, fine = skin_response(skin, t, g, tolerance=coarse.error_bound / 4, epidermis_properties=epi,
                            cells=4, resistance=resistance, full_output=True)
    assert coarse.cells == 4 and fine.cells > 4 and fine.error_bound <= coarse.error_bound / 4
    with pytest.raises(ModelInputError, match="tolerance: expected a tolerance the finite-volume"):
        skin_response(skin, t, g, tolerance=1e-30, epidermis_properties=epi, cells=128,
                      resistance=resistance)
