"""The calibration's forward model against independent references.

References: (1) mpmath's own Talbot inversion at 30 digits of the transforms written out
here from the physics (docs/design.md's F(s) and the lumped-node balance), (2) stimuli's exact
Contact (another implementation of the same contact), (3) limits, (4) finite differences for
the analytic derivatives.
"""
import math

import mpmath as mp
import numpy as np
import pytest

from experiments.calibration import CalibrationError, ContactSetup, Sensor, sensor_response, sensor_temperature
from stimuli import Contact, Skin, material
from stimuli.exact import invert_laplace

SKIN = (0.34, 1200.0, 3340.0)
STEEL = (14.9, 7900.0, 447.0)


def mp_reference(side, t, R, L, D=None, C=0.0, R1=0.0):
    """θ(t) by mpmath.invertlaplace (Talbot, 30 digits) of the transform written from scratch."""
    mp.mp.dps = 30
    ks, rs_, cs = [mp.mpf(v) for v in SKIN]
    km, rm, cm = [mp.mpf(v) for v in STEEL]
    bs, bm = mp.sqrt(ks * rs_ * cs), mp.sqrt(km * rm * cm)
    a_s, a_m = ks / (rs_ * cs), km / (rm * cm)
    R, L, C, R1 = mp.mpf(R), mp.mpf(L), mp.mpf(C), mp.mpf(R1)

    def F(s):
        zs = mp.tanh(mp.sqrt(s / a_s) * L) / (bs * mp.sqrt(s))          # skin impedance
        zm = 1 / (bm * mp.sqrt(s)) if D is None else mp.coth(mp.sqrt(s / a_m) * D) / (bm * mp.sqrt(s))
        if side == "lumped":        # C (s θ - 1) = (1/s - θ)/(R1 + zs) - θ/(R + zm)
            return (C + 1 / (s * (R1 + zs))) / (C * s + 1 / (R1 + zs) + 1 / (R + zm))
        flux = (1 / s) / (R + zs + zm)
        return flux * zm if side == "material" else 1 / s - flux * zs

    return float(mp.invertlaplace(F, t, method="talbot"))


@pytest.mark.parametrize("side,D,C,R1", [
    ("material", None, 0.0, 0.0), ("material", 3e-3, 0.0, 0.0), ("skin", None, 0.0, 0.0),
    ("skin", 3e-3, 0.0, 0.0), ("lumped", 3e-3, 155.0, 5e-4), ("lumped", None, 400.0, 1e-4)])
def test_matches_mpmath_reference(side, D, C, R1):
    sensor = Sensor.lumped(C, R1) if side == "lumped" else Sensor(side)
    setup = ContactSetup(material("stainless_steel", thickness=D), sensor, SKIN)
    t = np.array([0.02, 0.7, 6.0, 25.0])
    got = sensor_response(t, 1.3e-3, 750e-6, setup)
    ref = [mp_reference(side, ti, 1.3e-3, 750e-6, D, C, R1) for ti in t]
    np.testing.assert_allclose(got, ref, rtol=0, atol=2e-10)


@pytest.mark.parametrize("side", ["skin", "material"])
@pytest.mark.parametrize("D", [None, 3e-3])
def test_matches_stimuli_exact_contact(side, D):
    steel = material("stainless_steel", thickness=D)
    t = np.array([0.01, 0.1, 1.0, 5.0, 20.0, 25.0])
    for R, L in [(6.5e-4, 650e-6), (3.1e-3, 1.1e-3), (0.0, 900e-6)]:
        ref = Contact(Skin(L), steel, resistance=R, skin_temperature=35.5,
                      material_temperature=20.0).interface_temperature(t, side=side, method="exact")
        got = sensor_temperature(t, R, L, 35.5, 20.0, ContactSetup(steel, Sensor(side)))
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-8)


def test_lumped_without_mass_or_glue_is_the_skin_side():
    steel = material("stainless_steel", thickness=3e-3)
    t = np.linspace(0.05, 25, 30)
    a = sensor_response(t, 2e-3, 800e-6, ContactSetup(steel, Sensor("lumped", 0.0, 0.0)))
    b = sensor_response(t, 2e-3, 800e-6, ContactSetup(steel, Sensor("skin")))
    np.testing.assert_allclose(a, b, atol=1e-11)


def test_sensor_mass_slows_the_early_response():
    steel = material("stainless_steel", thickness=3e-3)
    t = np.array([0.02, 0.1])
    heavy = sensor_response(t, 1e-3, 800e-6, ContactSetup(steel, Sensor.lumped(600.0, 5e-4)))
    light = sensor_response(t, 1e-3, 800e-6, ContactSetup(steel, Sensor.lumped(10.0, 5e-4)))
    assert np.all(heavy > light)          # starts at the skin temperature (θ = 1), cools slower


def test_limits_two_half_spaces_and_thin_slab_equilibrium():
    # R = 0, very thick skin, half-space sample: constant contact temperature β_S/(β_S+β_M)
    bs, bm = math.sqrt(np.prod(SKIN)), math.sqrt(np.prod(STEEL))
    th = sensor_response([0.5, 3.0], 0.0, 0.05, ContactSetup(material("stainless_steel"), Sensor("material"), SKIN))
    np.testing.assert_allclose(th, bs / (bs + bm), atol=1e-9)
    # insulated 3 mm slab: after a long time everything is at the skin temperature (θ -> 1)
    th = sensor_response([2e4], 1e-3, 800e-6, ContactSetup(material("stainless_steel", thickness=3e-3),
                                                              Sensor("material"), SKIN))
    assert abs(th[0] - 1.0) < 1e-6
    # before contact each sensor reads the body it sits on
    assert sensor_response([0.0], 1e-3, 8e-4, ContactSetup(sensor=Sensor("material")))[0] == 0.0
    assert sensor_response([-1.0], 1e-3, 8e-4, ContactSetup(sensor=Sensor("skin")))[0] == 1.0


@pytest.mark.parametrize("sensor", [Sensor("material"), Sensor("skin"), Sensor.lumped()])
def test_analytic_derivatives_match_finite_differences(sensor):
    setup = ContactSetup(material("stainless_steel", thickness=3e-3), sensor)
    t = np.array([0.05, 0.5, 3.0, 12.0, 25.0])
    R, L = 1.5e-3, 800e-6
    _, d_r, d_l = sensor_response(t, R, L, setup, derivatives=True)
    h_r, h_l = R * 1e-5, L * 1e-5
    fd_r = (sensor_response(t, R + h_r, L, setup) - sensor_response(t, R - h_r, L, setup)) / (2 * h_r)
    fd_l = (sensor_response(t, R, L + h_l, setup) - sensor_response(t, R, L - h_l, setup)) / (2 * h_l)
    np.testing.assert_allclose(d_r, fd_r, rtol=1e-5, atol=1e-3)
    np.testing.assert_allclose(d_l, fd_l, rtol=1e-5, atol=1e-2)


def test_inversion_of_a_known_pair():
    # the model inverts with stimuli's Bromwich contour; check it on the model's kind of transform:
    # L^-1[1/(s (sqrt(s) + 1))] = 1 - exp(t) erfc(sqrt(t))
    t = np.array([1e-3, 0.1, 1.0, 10.0, 100.0])
    ref = [float(1 - mp.exp(x) * mp.erfc(mp.sqrt(x))) for x in t]
    np.testing.assert_allclose(invert_laplace(lambda s: 1 / (s * (np.sqrt(s) + 1)), t), ref, atol=1e-12)


def test_bad_inputs_are_named():
    with pytest.raises(CalibrationError, match="sensor: side"):
        Sensor("finger")
    with pytest.raises(CalibrationError, match="heat_capacity"):
        Sensor("skin", heat_capacity=100.0)
    with pytest.raises(CalibrationError, match="skin_thickness"):
        sensor_response([1.0], 1e-3, -1.0, ContactSetup())
    with pytest.raises(CalibrationError, match="resistance"):
        sensor_response([1.0], float("nan"), 1e-3, ContactSetup())
