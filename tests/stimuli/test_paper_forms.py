"""Printed vs corrected closed forms, each correction shown against the exact solution."""
import numpy as np
import pytest
from scipy.special import erfc

from stimuli import Contact, Skin, material
from stimuli import paper_forms as pf
from stimuli._special import exp_erfc

pytestmark = pytest.mark.filterwarnings("error")

SKIN = Skin(650e-6)
STEEL = material("stainless_steel")
T = np.array([1e-3, 0.1, 1.0, 5.0, 20.0])


def _pair(R, mat=STEEL, skin=SKIN):
    return Contact(skin, mat, R, 1.0, 0.0), pf.PaperParameters.from_contact(skin, mat, R)


@pytest.mark.parametrize("name", ["stainless_steel", "copper", "polystyrene_foam", "wood"])
def test_corrected_forms_are_exact_at_r0(name):
    c, _ = _pair(0.0, material(name))
    L, d = SKIN.thickness, SKIN.dermis
    for q, x in [("interface_material", L), ("interface_skin", L), ("skin", d), ("psi", d),
                 ("material", L + 1e-3), ("skin", 0.3 * L)]:
        np.testing.assert_allclose(c.theta(q, x, T, "paper"), c.theta(q, x, T, "exact"),
                                   rtol=0, atol=1e-12, err_msg=q)


def test_eq3b_sign_of_mu_x_minus_L():
    c, P = _pair(0.0)
    x = SKIN.thickness + 1e-3
    exact = c.material_temperature(x, [1.0])[0]
    assert pf.eq3b(P, x, [1.0], printed=True)[0] - exact == pytest.approx(0.075, abs=0.002)
    assert abs(pf.eq3b(P, x, [1.0])[0] - exact) < 1e-12


def test_eq4b_second_erfc_offset():
    c, P = _pair(0.0)
    L = SKIN.thickness
    exact = c.interface_temperature([20.0])[0]
    assert pf.eq4b(P, L, [20.0], printed=True)[0] - exact == pytest.approx(0.051, abs=0.002)
    assert abs(pf.eq3b(P, L, [20.0], printed=True)[0] - exact) < 1e-12   # 3b has (2n+2)L
    assert abs(pf.eq4b(P, L, [20.0])[0] - exact) < 1e-12


def test_resistance_terms_need_n_dependence_t_to_zero():
    # With R > 0 the material side starts at its own temperature (theta = 0).
    c, P = _pair(6.5e-4)
    L, t = SKIN.thickness, [1e-8]
    assert abs(c.interface_temperature(t)[0]) < 1e-3
    assert abs(pf.eq3b(P, L, t)[0]) < 1e-3
    assert pf.eq3b(P, L, t, printed=True)[0] == pytest.approx(P.gamma / 2, abs=1e-3)


def test_skin_resistance_term_needs_n_dependence_t_to_zero():
    # With R > 0 the skin side starts at its own temperature (theta = 1); an n-independent
    # e_SR summed over n makes it start far above (3.245 for steel at t = 1e-8 s).
    c, P = _pair(6.5e-4)
    L = SKIN.thickness
    for t in ([1e-8], [1e-4]):
        exact = c.skin_temperature(L, t)[0]
        assert abs(pf.eq3a(P, L, t)[0] - exact) < 1e-12
        assert pf.eq3a(P, L, t, printed=True)[0] > 3.0 * exact
    assert abs(c.skin_temperature(L, [1e-8])[0] - 1.0) < 1e-3


def _interface_with_emr_sign(P, t, sign):
    # Corrected Eq. 3b at x = L+ but e_MR,n = E(2nL) + sign * E((2n+2)L), summed here independently.
    a = np.sqrt(P.alpha_s * np.asarray(t))
    L, g, total = P.L, P.gamma, 0.0
    for n in range(200):
        A, B = 2 * n * L, (2 * n + 2) * L
        total = total + (-g) ** n * (erfc(A / (2 * a)) + erfc(B / (2 * a))
                                     - exp_erfc(P.H1 * a, A / (2 * a)) - sign * exp_erfc(P.H1 * a, B / (2 * a)))
    return (1 + g) / 2 * total


@pytest.mark.parametrize("R", [1e-4, 6.5e-4, 3e-3])
def test_emr_terms_add(R):
    c, P = _pair(R)
    t = np.array([1e-2, 0.1, 0.5, 1, 2, 5, 10, 20])
    exact = c.interface_temperature(t)
    plus = np.abs(_interface_with_emr_sign(P, t, +1) - exact).max()
    minus = np.abs(_interface_with_emr_sign(P, t, -1) - exact).max()
    assert plus < minus
    np.testing.assert_allclose(pf.eq7(P, t), _interface_with_emr_sign(P, t, +1), rtol=0, atol=1e-13)


def test_eq8_prefactor():
    # R = 0, short time (t << L^2/alpha: the n = 0 term is the whole answer):
    # printed psi / exact psi = (1 + gamma)/(1 - gamma) = beta_S / beta_M.
    skin = Skin(5e-3)
    c, P = _pair(0.0, skin=skin)
    t = [2.0]
    ratio = pf.eq8(P, skin.dermis, t, printed=True)[0] / c.recognizing_profile(t)[0]
    assert ratio == pytest.approx(skin.effusivity / STEEL.effusivity, rel=1e-9)
    assert pf.eq8(P, skin.dermis, t)[0] == pytest.approx(c.recognizing_profile(t)[0], abs=1e-12)


def test_eq7_single_term_limits():
    c, P = _pair(0.0)
    # t -> 0 (and L -> inf): the n = 0 term is exact
    assert abs(pf.eq7(P, [1e-3], printed=True)[0] - c.interface_temperature([1e-3])[0]) < 1e-12
    # finite L at 20 s: the missing images cost 0.080 in theta
    assert c.interface_temperature([20.0])[0] - pf.eq7(P, [20.0], printed=True)[0] == pytest.approx(0.080, abs=0.002)
    # docs/design.md: for 35 degC skin on 24 degC steel Eq. 7 never exceeds 27.05 degC, at any R
    for R in (0.0, 6.5e-4, 3e-3):
        _, P = _pair(R)
        tt = np.geomspace(1e-4, 1e4, 200)
        assert np.all(24 + 11 * pf.eq7(P, tt, printed=True) <= 27.05)


@pytest.mark.parametrize("L", [50e-6, 650e-6, 5e-3])
@pytest.mark.parametrize("name", ["copper", "stainless_steel", "polystyrene_foam"])
def test_closed_forms_finite_on_the_hard_grid(L, name):
    skin = Skin(L)
    tt = np.geomspace(1e-4, 1e4, 50)
    for R in (0.0, 1e-12, 1e-6, 1e-3, 1e-1):
        c, P = _pair(R, material(name), skin)
        for m in ("paper", "paper-as-printed"):
            for q, x in [("interface_material", L), ("interface_skin", L), ("skin", 0.0),
                         ("psi", skin.dermis), ("material", L + 5e-3)]:
                assert np.all(np.isfinite(c.theta(q, x, tt, m))), (R, m, q)


def test_paper_psi_in_unit_interval():
    for name in ("stainless_steel", "copper", "polystyrene_foam"):
        for R in (0.0, 1e-3, 1e-1):
            c, _ = _pair(R, material(name))
            psi = c.recognizing_profile(np.geomspace(1e-4, 1e4, 80), method="paper")
            assert np.all((psi >= -1e-12) & (psi <= 1 + 1e-12))


def test_constant_gamma_is_only_approximate_for_positive_R():
    # Not a misprint but the closed form's nature: the exact image ratio is
    # Gamma(p) = (p + h2)/(p + h1), which is gamma only as p -> 0. The corrected
    # forms are exact at R = 0 (above) and drift from the exact solution as R grows.
    t = np.linspace(0.1, 20.0, 60)
    errs = []
    for R in (1e-5, 1e-4, 6.5e-4, 3e-3):
        c, _ = _pair(R)
        errs.append(np.abs(c.theta("interface_material", None, t, "paper")
                           - c.theta("interface_material", None, t, "exact")).max())
    assert errs[0] > 1e-4 and np.all(np.diff(errs) > 0) and errs[-1] > 0.02
