"""Tests of experiments.participant_model: physics of the percept, learning, decisions, prediction."""
from __future__ import annotations

import math

import numpy as np
import pytest

from experiments.participant_model import (
    PerceptionParameters,
    SimulatedPerson,
    draw_person,
    predicted_cell_probabilities,
    receptor_features,
)

STEEL_RA_M = (1.6e-6, 12.5e-6, 50e-6, 100e-6)


def person(thickness_um, **kw):
    return SimulatedPerson(skin_thickness_m=thickness_um * 1e-6, dermis_fraction=0.6,
                           skin_temperature_C=35.5, **kw)


# -- features on a trace with a closed form --------------------------------------------------

def test_features_of_an_exponential_trace():
    # T(t) = T0 - a (1 - exp(-t / tau)): drop(t) = a (1 - exp(-t/tau)); the steepest finite
    # difference is the first one, a (1 - exp(-dt/tau)) / dt.
    a, tau, t0, dt = 4.0, 1.5, 35.5, 0.01
    t = np.arange(0, 10 + dt / 2, dt)
    y = t0 - a * (1 - np.exp(-t / tau))
    p = PerceptionParameters(drop_times_s=(1.0, 3.0, 8.0), rate_window_s=3.0)
    f = receptor_features(t, y, t0, p)
    expected = [a * (1 - math.exp(-s / tau)) for s in (1.0, 3.0, 8.0)]
    np.testing.assert_allclose(f[:3], expected, rtol=1e-4)
    assert f[3] == pytest.approx(a * (1 - math.exp(-dt / tau)) / dt, rel=1e-9)


def test_features_reject_mismatched_traces():
    with pytest.raises(ValueError, match="receptor_features"):
        receptor_features([0.0, 1.0], [35.0], 35.5, PerceptionParameters())


def test_parameters_validate_with_the_field_named():
    with pytest.raises(ValueError, match="lapse_rate"):
        PerceptionParameters(lapse_rate=1.5)
    with pytest.raises(ValueError, match="drop_noise_C"):
        PerceptionParameters(drop_noise_C=-0.1)
    with pytest.raises(ValueError, match="drop_times_s"):
        PerceptionParameters(drop_times_s=(0.0,))


# -- the percept follows the physics -----------------------------------------------------------

def test_thicker_skin_feels_a_smaller_early_drop():
    # Remark 1: the thicker the skin, the smaller the drop at the receptors (the early
    # response, when the judgement is formed).
    thin, thick = person(650.0), person(1000.0)
    for ra in STEEL_RA_M:
        f_thin = thin.features(*thin.feel_real(ra))
        f_thick = thick.features(*thick.feel_real(ra))
        assert f_thin[0] > f_thick[0] > 0        # drop at 1 s
        assert f_thin[1] > f_thick[1] > 0        # drop at 3 s
        assert f_thin[3] > f_thick[3] > 0        # peak rate of fall


def test_rougher_sample_feels_a_smaller_drop():
    # Remark 2: a larger contact resistance lets less heat out of the skin.
    for thickness in (650.0, 1000.0):
        p = person(thickness)
        feats = np.array([p.features(*p.feel_real(ra)) for ra in STEEL_RA_M])
        assert np.all(np.diff(feats, axis=0) < 0), feats


def test_real_feel_scales_with_the_temperature_difference():
    # The contact problem is linear in (T_S0 - T_M0): the drop doubles when the difference does.
    p = person(700.0)
    _, a = p.feel_real(12.5e-6, material_temperature_C=25.5, skin_temperature_C=35.5)
    _, b = p.feel_real(12.5e-6, material_temperature_C=15.5, skin_temperature_C=35.5)
    np.testing.assert_allclose(35.5 - b, 2 * (35.5 - a), atol=1e-9)


def test_imposed_skin_side_interface_reproduces_the_contact():
    # Imposing on the skin the skin-side interface temperature of a real contact must give the
    # same receptor temperature as the contact itself (two independent solvers in stimuli).
    from stimuli import Contact, contact_resistance, material
    p = person(800.0)
    steel = material("stainless_steel", thickness=3e-3)
    c = Contact(p.skin, steel, resistance=contact_resistance(50e-6, skin=p.skin, material=steel),
                skin_temperature=35.5, material_temperature=20.0)
    t = p.time_grid()
    surface = np.concatenate(([c.interface_temperature(t[1:2], side="skin")[0]],
                              c.interface_temperature(t[1:], side="skin")))
    t_imp, rec_imp = p.feel_imposed(t, surface)
    t_real, rec_real = p.feel_real(50e-6)
    np.testing.assert_allclose(t_imp, t_real)
    # The first sample stands for the jump at t = 0+; error is confined to early times.
    assert np.max(np.abs(rec_imp[50:] - rec_real[50:])) < 0.05


# -- learning and deciding -------------------------------------------------------------------------

def test_templates_are_the_mean_of_familiarisation_percepts():
    p = person(650.0)
    p.learn(2, [1.0, 2.0, 3.0, 4.0])
    p.learn(2, [3.0, 2.0, 1.0, 0.0])
    p.learn(1, [5.0, 5.0, 5.0, 5.0])
    means = p.template_means()
    np.testing.assert_allclose(means[2], [2.0, 2.0, 2.0, 2.0])
    np.testing.assert_allclose(means[1], [5.0, 5.0, 5.0, 5.0])


def test_each_mode_is_judged_with_its_own_templates_when_it_has_them():
    params = PerceptionParameters(lapse_rate=0.0)
    p = person(650.0, params=params)
    rng = np.random.default_rng(1)
    p.learn(1, [1.0, 1.0, 1.0, 1.0], mode="real")
    p.learn(2, [9.0, 9.0, 9.0, 9.0], mode="real")
    # Only real templates: a simulated trial is judged against them.
    assert p.decide([8.5, 8.5, 8.5, 8.5], rng, mode="simulated") == 2
    p.learn(3, [8.0, 8.0, 8.0, 8.0], mode="simulated")
    p.learn(4, [1.5, 1.5, 1.5, 1.5], mode="simulated")
    assert p.decide([8.5, 8.5, 8.5, 8.5], rng, mode="simulated") == 3
    assert p.decide([8.5, 8.5, 8.5, 8.5], rng, mode="real") == 2


def test_noise_free_observer_names_every_familiar_sample():
    params = PerceptionParameters(drop_noise_C=0.0, rate_noise_C_per_s=0.0, weber_fraction=0.0,
                                  lapse_rate=0.0)
    p = person(650.0, params=params)
    rng = np.random.default_rng(20261122)
    feats = {i + 1: p.features(*p.feel_real(ra)) for i, ra in enumerate(STEEL_RA_M)}
    for rid, f in feats.items():
        p.learn(rid, p.perceive(f, rng))
    for rid, f in feats.items():
        assert p.decide(p.perceive(f, rng), rng) == rid


def test_no_templates_means_guessing():
    p = person(650.0)
    rng = np.random.default_rng(3)
    answers = {p.decide(np.zeros(4), rng) for _ in range(200)}
    assert answers == {1, 2, 3, 4}


def test_decisions_are_reproducible_under_a_seed():
    def run(seed):
        p = draw_person("A", rng=seed)
        rng = np.random.default_rng(seed)
        feats = [p.features(*p.feel_real(ra)) for ra in STEEL_RA_M]
        for rid, f in enumerate(feats, 1):
            p.learn(rid, p.perceive(f, rng))
        return [p.decide(p.perceive(f, rng), rng) for f in feats * 10]
    assert run(11) == run(11)
    assert run(11) != run(12)


def test_draw_person_stays_in_the_group_range():
    rng = np.random.default_rng(5)
    for group, (lo, hi) in (("A", (600, 750)), ("B", (900, 1200))):
        for _ in range(50):
            p = draw_person(group, rng=rng)
            assert lo <= p.skin_thickness_m * 1e6 <= hi
            assert 35.5 <= p.skin_temperature_C <= 36.0
    with pytest.raises(ValueError, match="group"):
        draw_person("C")


# -- prediction ----------------------------------------------------------------------------------

def test_predicted_probabilities_are_probabilities_above_chance_where_features_separate():
    df = predicted_cell_probabilities(n_people=3, n_reps=300, seed=1, modes=("real",))
    assert set(df["group"]) == {"A", "B"} and len(df) == 8
    assert df["p_correct"].between(0.0, 1.0).all()
    # 3# and 4# differ from every other sample by more than a kelvin: well above chance (0.25).
    far = df[df["roughness_id"].isin([3, 4])]
    assert (far["p_correct"] > 0.5).all(), far


def test_prediction_falls_to_chance_when_noise_swamps_the_features():
    params = PerceptionParameters(drop_noise_C=50.0, rate_noise_C_per_s=50.0)
    df = predicted_cell_probabilities(n_people=2, n_reps=2000, seed=2, modes=("real",),
                                      params=params)
    # 4 classes: chance 0.25; 2 people x 2000 reps gives a Monte Carlo sd of ~0.007 per cell.
    assert np.all(np.abs(df["p_correct"] - 0.25) < 0.06), df


def test_thin_skin_recognises_real_samples_better_with_additive_noise():
    # With additive sensory noise only, what matters is how far apart the samples feel; the
    # thicker skin's receptors see smaller and closer drops (Remark 1), so group B must do worse
    # on real samples on average. This is a consequence of the physics, not an input.
    params = PerceptionParameters(weber_fraction=0.0, lapse_rate=0.0)
    df = predicted_cell_probabilities(n_people=4, n_reps=1500, seed=9, modes=("real",),
                                      params=params)
    mean = df.groupby("group")["p_correct"].mean()
    assert mean["A"] > mean["B"] + 0.02, df


def test_material_side_targets_feel_colder_than_the_real_samples_and_reverse_their_order():
    # The contract's display target is the *material* side of the interface (Eq. 7's quantity).
    # Imposed on the skin it skips the contact resistance's temperature step, so it must feel
    # colder than touching the real sample, and more so the rougher the sample (a larger R
    # keeps the steel's surface nearer 20 °C). This is the physics behind the simulated half
    # of the Figure 9 study; see the report.
    from stimuli import Skin, target_profile
    p = person(650.0)
    real, sim = [], []
    for ra in STEEL_RA_M:
        real.append(p.features(*p.feel_real(ra)))
        prof = target_profile(roughness=ra, skin=Skin(650e-6), skin_temperature=35.5,
                              material_temperature=20.0, duration=p.params.duration_s,
                              rate=100.0, sample_thickness=3e-3)
        sim.append(p.features(*p.feel_imposed(prof.times, prof.temperature)))
    real, sim = np.array(real), np.array(sim)
    assert np.all(sim[:, :3] > real[:, :3])              # every drop larger on the display
    assert np.all(np.diff(real[:, 1]) < 0)                # real: rougher feels warmer
    assert np.all(np.diff(sim[:, 1]) > 0)                 # display: rougher feels colder


def test_skin_side_targets_would_make_simulated_like_real():
    groups = {"A": (650.0, 650.0)}
    # Persons exactly like the target's skin (650 µm, 35.5 °C): the skin side of the contact,
    # imposed on the skin, is the real contact again, so both modes must score alike.
    kw = dict(groups=groups, target_thickness_um={"A": 650.0}, skin_temperature_C=(35.5, 35.5),
              n_people=3, n_reps=1500, seed=4)
    df = predicted_cell_probabilities(target_side="skin", **kw).set_index(["mode", "roughness_id"])
    diff = (df.loc["simulated", "p_correct"] - df.loc["real", "p_correct"]).abs()
    assert diff.max() < 0.08, df
    with pytest.raises(ValueError, match="target_side"):
        predicted_cell_probabilities(target_side="air", **kw)
