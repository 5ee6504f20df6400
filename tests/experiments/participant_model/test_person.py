"""Tests of experiments.participant_model.person and .prediction: physics of the percept, learning, decisions, prediction."""
from __future__ import annotations

import math

import numpy as np
import pytest

from experiments.participant_model.person import (
    PerceptionParameters,
    SimulatedPerson,
    draw_person,
    receptor_features,
)
from experiments.participant_model.prediction import predicted_cell_probabilities

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


def test_skin_side_targets_imposed_directly_would_make_simulated_like_real():
    groups = {"A": (650.0, 650.0)}
    # Persons exactly like the target's skin (650 µm, 35.5 °C): the skin side of the contact,
    # imposed on the skin with no pad resistance (pad=None), is the real contact again, so
    # both modes must score alike.
    kw = dict(groups=groups, target_thickness_um={"A": 650.0}, skin_temperature_C=(35.5, 35.5),
              n_people=3, n_reps=1500, seed=4)
    df = predicted_cell_probabilities(target_side="skin", pad=None, **kw).set_index(["mode", "roughness_id"])
    diff = (df.loc["simulated", "p_correct"] - df.loc["real", "p_correct"]).abs()
    assert diff.max() < 0.08, df
    with pytest.raises(ValueError, match="target_side"):
        predicted_cell_probabilities(target_side="air", **kw)


def test_compensated_targets_felt_through_the_pad_make_simulated_like_real():
    # Same persons, now feeling the pad through their finger–pad resistance (0.4 µm copper):
    # the compensated target is built to reproduce the real contact through it.
    kw = dict(groups={"A": (650.0, 650.0)}, target_thickness_um={"A": 650.0},
              skin_temperature_C=(35.5, 35.5), n_people=3, n_reps=1500, seed=4)
    df = predicted_cell_probabilities(target_side="compensated", **kw).set_index(["mode", "roughness_id"])
    diff = (df.loc["simulated", "p_correct"] - df.loc["real", "p_correct"]).abs()
    assert diff.max() < 0.08, df
    # ... whereas the paper's material-side target, felt the same way, loses 3# and 4#.
    mat = predicted_cell_probabilities(target_side="material", **kw).set_index(["mode", "roughness_id"])
    assert mat.loc[("simulated", 4), "p_correct"] < mat.loc[("real", 4), "p_correct"] - 0.5, mat


def _pad_trial(p, ra, side):
    """A simulated trial for person ``p`` with a perfectly tracking pad: the felt receptor trace."""
    from stimuli import Skin, contact_resistance, material, target_profile
    skin = Skin(650e-6)
    r_pad = float(contact_resistance(0.4e-6, skin=skin, material=material("copper")))
    prof = target_profile(roughness=ra, skin=skin, skin_temperature=35.5, material_temperature=20.0,
                          duration=p.params.duration_s, rate=100.0, sample_thickness=3e-3,
                          side=side, pad_resistance=r_pad)
    return p.feel_imposed(prof.times, prof.temperature, pad_resistance=p.pad_resistance())


def test_pad_resistance_is_eq5_of_the_pad_face_as_the_emulator_uses():
    from experiments.emulators.thermocue.pad_physics import finger_pad_resistance
    # Eq. 5 by hand: 0.8 Rq / (lambda_SF Delta_a) (H / P)^0.95 for 0.4 µm copper (401 W/mK) and
    # skin (0.34 W/mK), Rq = hypot(21.69 µm, 0.4 µm), H = 12.5 gf/mm², P = 2 N / 135 mm².
    lam = 2 * 0.34 * 401.0 / (0.34 + 401.0)
    H, P = 12.5 * 9.80665e-3 / 1e-6, 2.0 / 135e-6
    expected = 0.8 * math.hypot(21.69e-6, 0.4e-6) / (lam * 0.3) * (H / P) ** 0.95
    assert person(650.0).pad_resistance() == pytest.approx(expected, rel=1e-12)
    assert finger_pad_resistance() == pytest.approx(expected, rel=1e-12)


def test_compensated_trial_through_the_pad_feels_like_the_real_sample():
    # Tolerance 0.005 K on the receptor trace (drops of 1.5-6 K): the target is rounded to
    # 0.01 °C (error <= 0.005 K, and the skin's response to it is no larger); the solvers'
    # own errors are ~1e-9 K.  (The material-side target misses by 0.05-3.5 K here.)
    p = person(650.0)
    for ra in (1.6e-6, 100e-6):
        t, real = p.feel_real(ra)
        t2, felt = _pad_trial(p, ra, "compensated")
        np.testing.assert_allclose(t2, t)
        assert np.max(np.abs(felt - real)) < 0.005


def test_material_side_trial_through_the_pad_feels_colder_for_4():
    p = person(650.0)
    t, real = p.feel_real(100e-6)
    _, felt = _pad_trial(p, 100e-6, "material")
    drop_real, drop_felt = p.features(t, real)[:3], p.features(t, felt)[:3]
    # at 1, 3, 8 s the displayed 4# cools the receptors by more than 1 K more than the real 4#
    assert np.all(drop_felt > drop_real + 1.0), (drop_real, drop_felt)


def test_the_emulators_finger_and_the_model_feel_the_pad_alike():
    # The emulated pad's finger (a 32-cell finite-volume slab advanced exactly per 10 ms tick,
    # pad_physics.FingerSkin) and the model's skin_response(resistance=R_pad), driven by the same
    # pad temperature through the same Eq. 5 resistance, must agree at the receptors to the
    # finite-volume grid's error (a few mK against drops of 4-5 K).
    from experiments.emulators.thermocue.pad_physics import FingerSkin, finger_pad_resistance
    p = person(650.0)
    R = finger_pad_resistance()
    assert R == pytest.approx(p.pad_resistance(), rel=1e-12)
    dt = 0.01
    t = np.arange(0, 8.0 + dt / 2, dt)
    pad = 22.0 + 4.0 * (1 - np.exp(-t / 3.0))
    finger = FingerSkin(650e-6, 35.5, dt, R)
    emulated = [35.5]
    for k in range(1, t.size):
        finger.step(True, 0.5 * (pad[k - 1] + pad[k]))    # input held over the tick: its mean
        emulated.append(finger.temperature_at(0.6 * 650e-6))
    _, model = p.feel_imposed(t, pad, skin_temperature_C=35.5, pad_resistance=R)
    assert np.max(np.abs(model - np.array(emulated)[:model.size])) < 0.01


def test_emulated_compensated_trial_feels_like_the_real_sample_and_material_side_colder():
    # End to end on the emulator (virtual clock): upload the target, press the emulated finger
    # (this person's skin), feel the recorded pad trace through the pad resistance.
    # Tolerance 0.03 K on the drops at 1, 3 and 8 s (emulator tracking ~0.01 K rms, sensor noise
    # 3 mK, 0.01 °C profile steps); the material-side 4# is > 1 K colder at every time.
    from experiments.display import SafetyLimits, open_display
    from experiments.profile_rate import limit_rate
    from stimuli import Skin, target_profile
    p = person(650.0)
    t_real, real = p.feel_real(100e-6)
    f_real = p.features(t_real, real)
    felt = {}
    for side in ("compensated", "material"):
        prof = target_profile(roughness=100e-6, skin=Skin(650e-6), skin_temperature=35.5,
                              material_temperature=20.0, duration=9.0, rate=100.0,
                              sample_thickness=3e-3, side=side, pad_resistance=p.pad_resistance())
        y, _ = limit_rate(prof.temperature, 0.01, 10.0)      # 4# compensated starts at 10.7 °C/s
        frames = []
        with open_display("emulator://?clock=virtual&seed=2", limits=SafetyLimits()) as disp:
            disp.upload_profile(prof.times, y)
            disp.arm(mode="playback", force_threshold_N=2.0, max_duration_s=9.0)
            disp.sim_finger(press_after_s=0.3, force_N=2.5, hold_s=9.0, skin_thickness_m=650e-6,
                            skin_temperature_C=35.5)
            rec = disp.run_trial(timeout_s=30.0, on_telemetry=frames.append)
        assert rec.status == "ok"
        t = np.array([f.device_time_s for f in frames]) - rec.contact_time_s
        c = np.array([f.contact_C for f in frames])
        keep = t >= 0
        tt, rr = p.feel_imposed(t[keep], c[keep], pad_resistance=p.pad_resistance())
        felt[side] = p.features(tt, rr)
    np.testing.assert_allclose(felt["compensated"][:3], f_real[:3], atol=0.03)
    assert np.all(felt["material"][:3] > f_real[:3] + 1.0)


def test_cooling_features_refuse_a_warm_material():
    # the observer's features are drops and a rate of fall; a warming trace is refused
    t = np.linspace(0.0, 8.0, 81)
    warm = 35.0 + 3.0 * (1.0 - np.exp(-t))
    with pytest.raises(ValueError, match="expected a cooling trace"):
        receptor_features(t, warm, 35.0, PerceptionParameters())


def test_feel_real_uses_eq5_at_the_given_force():
    # R is Eq. 5 at the contact force; a firmer press lowers R, the smooth sample
    # feels colder (1.5 -> 2.5 N moves the 1# receptor by ~0.5 K at 5 s)
    from stimuli import Contact, contact_resistance, material
    p = person(650.0)
    t, soft = p.feel_real(1.6e-6, force_N=1.5)
    _, firm = p.feel_real(1.6e-6, force_N=2.5)
    i = int(np.argmin(np.abs(t - 5.0)))
    assert 0.3 < soft[i] - firm[i] < 0.8
    steel = material("stainless_steel", p.params.sample_thickness_m)
    R = contact_resistance(1.6e-6, skin=p.skin, material=steel, force=2.5)
    want = Contact(p.skin, steel, R, p.skin_temperature_C, p.params.material_temperature_C)
    np.testing.assert_allclose(firm[1:], want.receptor_temperature(t[1:]), atol=1e-9)


def test_display_driven_receptor_goes_through_the_scene_planner():
    # feel_imposed is computed by the planner's model (one chokepoint), which keeps
    # the skin's layers (kelvins at the receptor) and neglects perfusion (millikelvins)
    from stimuli import skin_response
    from stimuli.layered import layered_skin_response, skin_layers
    person = SimulatedPerson(skin_thickness_m=650e-6, skin_temperature_C=35.5)
    t = np.arange(0, 5.0, 0.01)
    surface = 22.0 + 6.0 * np.exp(-t / 2.0)
    grid, plain = person.feel_imposed(t, surface, pad_resistance=1e-4)
    assert person.last_display_plan is not None and not person.last_display_plan.layered
    g = np.interp(grid, t, surface)
    np.testing.assert_array_equal(plain, skin_response(person.skin, grid, g, initial_temperature=35.5,
                                                       depth=person.skin.dermis, resistance=1e-4))
    _, layered = person.feel_imposed(t, surface, pad_resistance=1e-4, layered=True,
                                     perfusion_per_s=1.25e-3)
    plan = {d.effect: d.included for d in person.last_display_plan.decisions}
    assert plan == {"perfusion": False, "layered": True}
    expect = layered_skin_response(skin_layers(person.skin, layered=True), grid, g, 35.5,
                                   person.skin.dermis, 1e-4)
    np.testing.assert_allclose(layered, expect, atol=1e-12)
    assert np.max(np.abs(layered - plain)) > 0.3


def test_model_tolerance_is_a_quarter_of_the_smallest_difference_between_the_stimuli():
    # recomputed with the exact models (stimuli.Contact and stimuli.skin_response, not the
    # planner): the four samples as the group profile skins feel them, real and as every replay
    # hypothesis plays them through the 0.4 µm copper pad; the closest pair's smallest drop
    # difference, / 4
    import itertools

    from experiments.participant_model.person import (MODEL_TOLERANCE_C, PerceptionParameters,
                                                      receptor_features)
    from experiments.protocol import load_protocol
    from experiments.session.setup import simulated_target_profile
    from experiments.simulation.replay import REPLAY_HYPOTHESES, protocol_variant
    from stimuli import Contact, Skin, contact_resistance, material, skin_response
    params = PerceptionParameters()
    steel = material("stainless_steel", thickness=3e-3)
    t = np.arange(1, 2001) / 100
    base = load_protocol("roughness_recognition")
    smallest = {}
    for L, group in ((650e-6, "A"), (1000e-6, "B")):
        skin = Skin(L, dermis=0.6 * L)
        r_pad = contact_resistance(0.4e-6, skin=skin, material=material("copper"))
        kinds = {"real": []}
        for ra in (1.6, 12.5, 50.0, 100.0):
            R = contact_resistance(ra * 1e-6, skin=skin, material=steel)
            T = Contact(skin, steel, R, 35.5, 20.0).receptor_temperature(t)
            kinds["real"].append(receptor_features(np.r_[0, t], np.r_[35.5, T], 35.5, params)[:3])
        for name in REPLAY_HYPOTHESES:
            variant = protocol_variant(base, name)
            kinds[name] = []
            for s in variant.samples:
                prof = simulated_target_profile(variant, {}, group, None, s.id, s.roughness_um)
                grid = np.arange(int(params.duration_s * 100) + 1) / 100
                g = np.interp(grid, prof.times, prof.temperature)
                T = skin_response(skin, grid, g, initial_temperature=35.5, depth=skin.dermis,
                                  resistance=r_pad)
                kinds[name].append(receptor_features(grid, T, 35.5, params)[:3])
        for kind, feats in kinds.items():
            for a, b in itertools.combinations(feats, 2):
                smallest[kind] = min(smallest.get(kind, np.inf), np.abs(a - b).min())
    assert 0.10 < smallest["real"] < 0.13              # the real 1# and 2#
    assert 0.011 < smallest["printed"] < 0.014         # the closest replayed pair
    least = min(smallest.values())
    assert MODEL_TOLERANCE_C <= least / 4 < MODEL_TOLERANCE_C + 0.0005
    assert params.model_tolerance_C == MODEL_TOLERANCE_C < 0.3


def test_real_and_displayed_contacts_are_planned_at_the_participants_tolerance():
    # both paths through the scene planner, at a quarter of the smallest difference between the
    # samples (MODEL_TOLERANCE_C), not the 0.3 K perceptual floor; the decision kept for the log
    from experiments.participant_model.person import MODEL_TOLERANCE_C, SimulatedPerson
    p = SimulatedPerson(800e-6)
    p.feel_real(12.5e-6)
    assert p.last_plan["felt_as"] == "real"
    assert p.last_plan["tolerance_K"] == MODEL_TOLERANCE_C
    assert 0.0 <= p.last_plan["bound_K"] <= MODEL_TOLERANCE_C
    t = np.arange(0, 5.0, 0.01)
    p.feel_imposed(t, 22.0 + 6.0 * np.exp(-t / 2.0), pad_resistance=1e-4)
    assert p.last_display_plan.tolerance_K == MODEL_TOLERANCE_C
    assert p.last_plan["felt_as"] == "simulated"
    assert p.last_plan["tolerance_K"] == MODEL_TOLERANCE_C < 0.3
