import numpy as np
import pytest

from experiments.emulators.thermocue.pad_physics import CONTACT_AREA_M2, FingerSkin, PadParams, PadPlant


def slab_step_reference(x, t, L, alpha, n_terms=400):
    """theta(x, t) of a slab 0<x<L, theta(0)=0 held, theta(L)=1 from t=0, theta=0 initially.

    Separation of variables: theta = x/L + sum_n 2(-1)^n/(n pi) sin(n pi x/L) exp(-n^2 pi^2 alpha t/L^2).
    """
    n = np.arange(1, n_terms + 1)
    return x / L + np.sum(2 * (-1.0) ** n / (n * np.pi) * np.sin(n * np.pi * x / L)
                          * np.exp(-(n * np.pi / L) ** 2 * alpha * t))


@pytest.mark.parametrize("L", [650e-6, 1000e-6])
def test_skin_slab_matches_the_series_solution(L):
    # the surface held at 20 °C (negligible resistance) against a 35 °C core: receptor depth 0.6 L
    skin = FingerSkin(L, 35.0, 0.01, resistance=1e-9)
    alpha = 0.34 / (1200 * 3340)
    ticks = {10: None, 50: None, 200: None, 1000: None}
    for k in range(1, 1001):
        skin.step(True, 20.0)
        if k in ticks:
            want = 35.0 - 15.0 * slab_step_reference(0.6 * L, k * 0.01, L, alpha)
            assert skin.temperature_at(0.6 * L) == pytest.approx(want, abs=0.02), k


def test_skin_surface_flux_matches_the_series_at_one_second():
    L, alpha, k = 650e-6, 0.34 / (1200 * 3340), 0.34
    skin = FingerSkin(L, 35.0, 0.01, resistance=1e-9)
    for _ in range(100):
        q = skin.step(True, 20.0)
    n = np.arange(1, 400)
    # flux out of the surface: -k dT/dx at x=L = k*15/L * (1 + 2 sum exp(-n^2 pi^2 alpha t / L^2))
    # (tick-averaged flux vs instantaneous: compare at t = 0.995 s, the tick's middle)
    want = k * 15 / L * (1 + 2 * np.sum(np.exp(-(n * np.pi / L) ** 2 * alpha * 0.995)))
    assert q == pytest.approx(want, rel=0.02)


def test_pad_tracks_a_profile_under_a_finger():
    rng_profile = 20.0 + 8.0 * np.sqrt(np.arange(2001) * 0.01 / 20.0)
    plant = PadPlant(PadParams(), 0.01, 20.0, seed=4)
    finger = FingerSkin(650e-6, 35.5, 0.01, resistance=6e-4)
    for _ in range(100):
        plant.step(20.0, 20.0, 0.0, True)
    err = []
    for k in range(2000):
        load = finger.step(True, plant.pad) * CONTACT_AREA_M2
        y = plant.step(rng_profile[k], rng_profile[k + 1], load, True)
        err.append(y - rng_profile[k + 1])
    err = np.array(err)
    assert np.sqrt(np.mean(err ** 2)) < 0.05
    assert np.abs(err).max() < 0.5
    assert 0.05 < load < 2.0              # the finger still warms the pad after 20 s, W


def test_without_power_the_pad_relaxes_to_the_heat_sink():
    plant = PadPlant(PadParams(), 0.01, 40.0, seed=1)
    for _ in range(2000):
        plant.step(32.0, 32.0, 0.0, False)
    assert abs(plant.pad - plant.hs) < 0.5 and plant.current == 0.0
