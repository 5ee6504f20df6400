"""Many simulated studies: agree with the participant model's own Monte Carlo."""
import csv
import json

import numpy as np
import pytest

from experiments.simulation.prediction import predicted_cell_probabilities
from experiments.simulation.observers import get_observer
from experiments.simulation.studies import build_pool, simulate_studies


@pytest.mark.slow
def test_absolute_observer_studies_match_predicted_cell_probabilities():
    # predicted_cell_probabilities is the older, independent Monte Carlo of the same absolute
    # observer (person by person, one test presentation per sample)
    pool = build_pool(hypotheses=("material",), pool_size=40, seed=3)
    out = simulate_studies(pool, "material", get_observer("absolute"), n_studies=300, seed=1)
    ours = out.proportions()                                       # (group, mode, sample)
    ref = predicted_cell_probabilities(n_people=40, n_reps=200, seed=5)
    for gi, g in enumerate("AB"):
        for m, mode in enumerate(("real", "simulated")):
            want = ref[(ref.group == g) & (ref["mode"] == mode)].sort_values("roughness_id")
            np.testing.assert_allclose(ours[gi, m], want["p_correct"], atol=0.07)
    assert out.correct.shape == (300, 30, 2, 4)
    assert np.all(out.answers.sum(axis=-1) == 3)


def test_superposed_features_equal_the_direct_computation():
    from experiments.simulation.person import draw_person
    from experiments.protocol import load_protocol
    from experiments.session.setup import simulated_target_profile
    from experiments.simulation.replay import protocol_variant
    from experiments.simulation.studies import imposed_features
    person = draw_person("B", 20261124)
    r_pad = person.pad_resistance()
    for side in ("material", "compensated"):
        proto = protocol_variant(load_protocol("roughness_recognition"), side)
        profiles = [simulated_target_profile(proto, {}, "B", None, s.id, s.roughness_um)
                    for s in proto.samples]
        fast = imposed_features(person, [(p.times, p.temperature) for p in profiles], r_pad)
        direct = np.array([person.features(*person.feel_imposed(p.times, p.temperature,
                                                                 pad_resistance=r_pad))
                           for p in profiles])
        np.testing.assert_allclose(fast, direct, rtol=0, atol=1e-9)


@pytest.mark.slow
def test_emulated_session_features_are_the_perfect_tracking_features(tmp_path):
    """How far the fast studies' features are from what an emulated session's person felt.

    The studies assume a display that tracks the target perfectly; the session's person feels
    the emulated pad's recorded contact temperature.  Same person, same trial skin temperature
    (logged), same profile: the features agree to well under the 0.3 perceptual noise.
    """
    from experiments.simulation.cohort import write_cohort
    from experiments.simulation.figure9.study import run_participant
    from experiments.simulation.person import SimulatedPerson
    from experiments.protocol import load_protocol
    from experiments.session.setup import simulated_target_profile
    from experiments.simulation.studies import imposed_features
    proto = load_protocol("roughness_recognition")
    paths = {p.stem: p for p in write_cohort(tmp_path / "people", seed=0)}
    result = run_participant(paths["P16"], tmp_path / "data", seed=0, durable=False)
    record = json.loads(paths["P16"].read_text())
    session = result["session_dir"]
    with open(f"{session}/trials.csv") as fh:
        rid = {int(r["trial_index"]): int(r["roughness_id"]) for r in csv.DictReader(fh)}
    st = record["skin_thickness"]
    diffs = []
    with open(f"{session}/events.jsonl") as fh:
        for e in map(json.loads, fh):
            if e.get("event") != "simulated_percept" or e["felt_as"] != "simulated":
                continue
            person = SimulatedPerson(st["total_um"] * 1e-6, st["dermis_um"] / st["total_um"],
                                     e["skin_temperature_C"])
            r = rid[e["trial_index"]]
            prof = simulated_target_profile(proto, record, "B", None, r, proto.sample(r).roughness_um)
            ideal = imposed_features(person, [(prof.times, prof.temperature)],
                                     e["pad_resistance_m2K_W"])[0]
            diffs.append(np.asarray(e["features"]) - ideal)
    diffs = np.array(diffs)
    assert diffs.shape == (12, 4)
    assert np.abs(diffs).max() < 0.01          # logged features are rounded to 1e-4


def test_scenarios_judge_the_simulated_block_for_a_response_bias():
    # the skin-side replay judged by the absolute observer names nearly every
    # simulated sample 4#; the claims table must see it (it was ✓ on every old claim)
    from experiments.simulation.figure9.scenarios import evaluate_scenarios
    pool = build_pool(hypotheses=("skin", "compensated"), pool_size=20, seed=3)
    res = evaluate_scenarios(pool, observers=["absolute"], n_studies=40, seed=2)
    wide = res.wide()
    assert wide.loc[("skin", "absolute"), "no_dominant_answer_simulated"] == 0.0
    assert wide.loc[("skin", "absolute"), "all"] == 0.0
    assert wide.loc[("compensated", "absolute"), "no_dominant_answer_simulated"] >= 0.9
    stats = res.claims.set_index(["hypothesis", "claim"])["mean_statistic"]
    assert stats[("skin", "no_dominant_answer_simulated")] > 0.5        # share of one answer
    assert stats[("compensated", "no_dominant_answer_simulated")] < 0.5
    # simulated proportion correct: the skin/absolute 4#-for-everything pattern is ~1/4
    p = res.proportions
    sim = p[(p.hypothesis == "skin") & (p["mode"] == "simulated")]
    assert sim[sim.roughness_id < 4]["expected"].max() < 0.2
