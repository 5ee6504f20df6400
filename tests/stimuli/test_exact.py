"""The "exact" method against an independent mpmath computation (hard cases)."""
import itertools
import warnings

import numpy as np
import pytest
from scipy.special import erfc

from stimuli import Contact, Skin, material
from stimuli.exact import invert_laplace

from stimuli_mpref import theta_interface_r0_series, theta_reference

pytestmark = pytest.mark.filterwarnings("error")

TIMES = [1e-4, 3e-2, 20.0, 1e4]
TOL = 1e-12

# R in [0, 0.1] m^2 K/W incl. exactly 0; materials far more (copper) and far less
# (foam) conductive than skin, and steel; half-space and a 3 mm slab.
CASES = list(itertools.product([0.0, 1e-6, 1e-3, 1e-1],
                               ["copper", "polystyrene_foam", "stainless_steel"],
                               [None, 3e-3]))


def _points(skin):
    L = skin.thickness
    return [("skin", L), ("material", L), ("skin", skin.dermis), ("skin", 0.0)]


@pytest.mark.parametrize("R,name,D", CASES)
def test_exact_matches_mpmath(R, name, D):
    skin = Skin(650e-6)
    mat = material(name, D)
    c = Contact(skin, mat, R, 1.0, 0.0)   # temperatures = theta
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for kind, x in _points(skin):
            got = (c.skin_temperature(x, TIMES) if kind == "skin"
                   else c.material_temperature(x, TIMES))
            assert np.all(np.isfinite(got))
            ref = [theta_reference(skin, mat, R, x, t, kind) for t in TIMES]
            np.testing.assert_allclose(got, ref, rtol=0, atol=TOL, err_msg=f"{kind} x={x}")


@pytest.mark.parametrize("L,name", [(5e-3, "copper"), (5e-3, "polystyrene_foam"), (50e-6, "stainless_steel")])
@pytest.mark.parametrize("R", [0.0, 1e-2])
def test_exact_thick_and_thin_skin(L, name, R):
    skin = Skin(L)
    mat = material(name)
    c = Contact(skin, mat, R, 1.0, 0.0)
    for kind, x in [("skin", skin.dermis), ("material", L + 1e-4), ("skin", L)]:
        got = (c.skin_temperature(x, TIMES) if kind == "skin" else c.material_temperature(x, TIMES))
        ref = [theta_reference(skin, mat, R, x, t, kind) for t in TIMES]
        np.testing.assert_allclose(got, ref, rtol=0, atol=TOL)


def test_exact_against_image_series_at_r0():
    # A second, physically independent reference: the R = 0 image series.
    skin, steel = Skin(650e-6), material("stainless_steel")
    c = Contact(skin, steel, 0.0, 1.0, 0.0)
    t = np.array([1e-3, 0.5, 20.0, 300.0])
    ref = [theta_interface_r0_series(skin, steel, v) for v in t]
    np.testing.assert_allclose(c.interface_temperature(t), ref, rtol=0, atol=TOL)


def test_uniform_grid_path_equals_pointwise():
    # The 20 s, 1 kHz profile uses the factorised exp(s t) path; single times do not.
    skin, steel = Skin(650e-6), material("stainless_steel")
    c = Contact(skin, steel, 7e-4, 35.0, 24.0)
    t = np.arange(20001) / 1000.0
    whole = c.interface_temperature(t)
    idx = [1, 2, 17, 999, 5000, 12345, 20000]
    single = np.array([c.interface_temperature(t[i]) for i in idx])
    np.testing.assert_allclose(whole[idx], single, rtol=0, atol=1e-11)


def test_invert_laplace_known_pairs():
    t = np.geomspace(1e-4, 1e4, 41)
    for a in (0.0, 0.01, 1.0, 30.0):
        f = invert_laplace(lambda s: np.exp(-a * np.sqrt(s)) / s, t)
        np.testing.assert_allclose(f, erfc(a / (2 * np.sqrt(t))), rtol=0, atol=1e-13)


def test_invert_laplace_rejects_nonpositive_times():
    with pytest.raises(ValueError, match="t: expected finite times > 0"):
        invert_laplace(lambda s: 1 / s, [0.0, 1.0])


@pytest.mark.parametrize("L", [50e-6, 650e-6, 5e-3])
@pytest.mark.parametrize("D", [None, 3e-3])
def test_no_nan_inf_or_warning_on_the_hard_grid(L, D):
    # R in [0, 0.1] incl. exactly 0, t in [1e-4, 1e4], x at 0, d, L-, L+ (and the slab's back).
    t = np.concatenate([[0.0], np.geomspace(1e-4, 1e4, 120)])
    skin = Skin(L)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name in ("copper", "polystyrene_foam", "stainless_steel"):
            mat = material(name, D)
            for R in (0.0, 1e-12, 1e-6, 1e-3, 1e-1):
                c = Contact(skin, mat, R, 1.0, 0.0)
                vals = [c.skin_temperature(0.0, t), c.receptor_temperature(t),
                        c.interface_temperature(t, side="skin"), c.interface_temperature(t),
                        c.recognizing_profile(t)]
                if D is not None:
                    vals.append(c.material_temperature(L + D, t))
                for v in vals:
                    assert np.all(np.isfinite(v))
                    assert np.all((v > -1e-12) & (v < 1 + 1e-12))   # theta and psi stay in [0, 1]


def test_inversion_plan_is_reusable_across_transforms():
    # one plan, two transforms with known inverses (erfc(a / 2 sqrt t)), any time order and shape
    from stimuli.exact import InversionPlan
    t = np.array([[5.0, 1e-3], [0.2, 40.0]])
    plan = InversionPlan(t)
    for a in (0.5, 2.0):
        f = plan.apply(np.exp(-a * np.sqrt(plan.s)) / plan.s)
        np.testing.assert_allclose(f, erfc(a / (2 * np.sqrt(t))), rtol=0, atol=1e-13)
