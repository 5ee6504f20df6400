"""Tests of the simulated participant as a responder (experiments.responders.simulated)."""
from __future__ import annotations

import csv
import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from experiments.errors import UserInputError
from experiments.responders import Response, TrialStimulus, get_responder
from experiments.responders.simulated import SimulatedResponder
from experiments.schedule import TrialSpec
from participants_schema import Participant

RA_UM = {1: 1.6, 2: 12.5, 3: 50.0, 4: 100.0}


class FakeDisplay:
    """Records the emulator-only calls a simulated responder makes."""

    def __init__(self):
        self.calls = []

    def sim_sample(self, **kw):
        self.calls.append(("sim_sample", kw))

    def sim_finger(self, **kw):
        self.calls.append(("sim_finger", kw))


class LoggingSession(SimpleNamespace):
    """A session stand-in that keeps the events a responder logs."""

    def __init__(self, **kw):
        super().__init__(events=[], **kw)

    def log_event(self, kind, **fields):
        self.events.append((kind, fields))


def spec(index, block, mode, rid, rep=1):
    return TrialSpec(trial_index=index, block=block, mode=mode, roughness_id=rid,
                     roughness_um=RA_UM[rid], repetition=rep)


def familiarise(responder, display):
    for rid in RA_UM:
        trial = spec(rid, "familiarise", "real", rid)
        responder.touch(trial, display)
        answer = responder.respond(trial, TrialStimulus("real", rid, RA_UM[rid]))
        assert answer.response_id == rid        # the sample is named on familiarisation trials


def test_registered_under_its_name_with_options():
    r = get_responder("simulated", seed=3, skin_thickness_um=700, drop_noise_C="0.2")
    assert isinstance(r, SimulatedResponder) and not r.human
    assert r.params.drop_noise_C == 0.2


@pytest.mark.parametrize("options, field", [({"nois": 1}, "nois"),
                                            ({"lapse_rate": 2.0}, "lapse_rate"),
                                            ({"weber_fraction": "lots"}, "weber_fraction")])
def test_bad_options_are_user_errors_naming_the_option(options, field):
    with pytest.raises(UserInputError, match=field):
        get_responder("simulated", **options)


def test_touch_scripts_the_emulator_with_own_skin_and_the_sample():
    r = SimulatedResponder(seed=1, skin_thickness_um=720.0, skin_temperature_C=35.8,
                           skin_temperature_sd_C=0.0)
    d = FakeDisplay()
    r.touch(spec(5, "real", "real", 3), d)
    (kind1, sample), (kind2, finger) = d.calls
    assert kind1 == "sim_sample" and sample["roughness_m"] == pytest.approx(50e-6)
    assert sample["material"] == "stainless_steel" and sample["thickness_m"] == pytest.approx(3e-3)
    assert kind2 == "sim_finger"
    assert finger["skin_thickness_m"] == pytest.approx(720e-6)
    assert finger["skin_temperature_C"] == pytest.approx(35.8)
    # the lab's press for this trial (2.5 ± 0.25 N, past the 2 N trigger), not one for all
    assert 2.05 <= finger["force_N"] <= 3.0 and finger["force_N"] != pytest.approx(2.5)
    fixed = SimulatedResponder(seed=1, skin_thickness_um=720.0, force_N=2.7)
    d3 = FakeDisplay()
    fixed.touch(spec(5, "real", "real", 3), d3)
    assert d3.calls[-1][1]["force_N"] == 2.7                # the option presses every trial so
    d2 = FakeDisplay()
    r.touch(spec(6, "simulated", "simulated", 3), d2)
    assert [c[0] for c in d2.calls] == ["sim_finger"]       # no sample on a simulated trial


def test_familiarisation_learns_templates_even_without_a_response():
    r = SimulatedResponder(seed=2, skin_thickness_um=650.0)
    d = FakeDisplay()
    for rid in RA_UM:
        r.touch(spec(rid, "familiarise", "real", rid), d)     # protocol: response = false
    assert list(r.person.templates) == ["real"]
    assert sorted(r.person.templates["real"]) == [1, 2, 3, 4]
    assert all(count == 1 for _, count in r.person.templates["real"].values())
    # Asking for the answer afterwards does not learn the same trial twice.
    r.respond(spec(1, "familiarise", "real", 1), TrialStimulus("real", 1, 1.6))
    assert r.person.templates["real"][1][1] == 1


def test_answers_are_reproducible_under_a_seed_and_vary_between_seeds():
    def answers(seed):
        r = SimulatedResponder(seed=seed, skin_thickness_um=650.0)
        d = FakeDisplay()
        familiarise(r, d)
        out = []
        for k in range(40):
            rid = k % 4 + 1
            trial = spec(10 + k, "real", "real", rid)
            r.touch(trial, d)
            resp = r.respond(trial, TrialStimulus("real", rid, RA_UM[rid]))
            assert isinstance(resp, Response) and resp.rt_s > 0 and resp.source == "simulated"
            out.append(resp.response_id)
        return out
    a = answers(7)
    assert a == answers(7)
    assert a != answers(8)
    # The far samples (3#, 4#) are named correctly more often than chance.
    truth = [k % 4 + 1 for k in range(40)]
    far = [x == t for x, t in zip(a, truth) if t >= 3]
    assert np.mean(far) > 0.25


def test_simulated_trial_feels_the_recorded_contact_trace():
    # A colder recorded surface must feel colder at the receptors: compare a trace 2 K colder.
    r = SimulatedResponder(seed=4, skin_thickness_um=900.0, skin_temperature_sd_C=0.0,
                           skin_temperature_C=35.5)
    t = np.arange(0, 10.0, 0.01)
    surface = 20.0 + 8.0 * np.exp(-t / 30.0)
    trial = spec(9, "simulated", "simulated", 2)
    _, warm, _ = r.feel(trial, TrialStimulus("simulated", 2, 12.5, time_s=t, contact_C=surface,
                                            target_C=surface, profile_parameters={}))
    _, cold, _ = r.feel(trial, TrialStimulus("simulated", 2, 12.5, time_s=t, contact_C=surface - 2,
                                            target_C=surface, profile_parameters={}))
    # The receptors lie under the epidermis: the first milliseconds are equal to rounding.
    assert np.all(cold <= warm + 1e-12)
    assert np.all(cold[10:] < warm[10:])
    assert warm[0] == pytest.approx(35.5)


def test_faulted_trial_is_answered_with_a_guess_not_an_error():
    r = SimulatedResponder(seed=5, skin_thickness_um=650.0)
    resp = r.respond(spec(3, "simulated", "simulated", 1),
                     TrialStimulus("simulated", 1, 1.6, status="fault"))
    assert resp.response_id in (1, 2, 3, 4)


def test_thermocue_run_with_the_simulated_responder(tmp_path):

    from experiments.cli import main
    from experiments.participant_model.cohort import write_cohort

    participant = write_cohort(tmp_path / "people", seed=1)[0]
    status = main(["run", "roughness_recognition", "--participant", str(participant),
                   "--display", "emulator://?clock=virtual&seed=2", "--responder", "simulated",
                   "--data", str(tmp_path / "data"), "--seed", "5", "--quiet",
                   "--responder-option", "lapse_rate=0.1"])
    assert status == 0
    (trials,) = Path(tmp_path / "data").glob("*/*/trials.csv")
    rows = list(csv.DictReader(trials.open()))
    scored = [r for r in rows if r["block"] != "familiarise"]
    assert len(scored) == 24 and all(r["status"] == "ok" for r in rows)
    assert {r["response_source"] for r in scored} == {"simulated"}
    assert all(r["response_id"] in {"1", "2", "3", "4"} for r in scored)
    # Every answer is traceable: one percept event per scored trial, answer as logged.
    events = [json.loads(line) for line in (trials.parent / "events.jsonl").open()]
    percepts = {e["trial_index"]: e for e in events if e.get("event") == "simulated_percept"}
    assert sorted(percepts) == sorted(int(r["trial_index"]) for r in scored)
    for r in scored:
        e = percepts[int(r["trial_index"])]
        assert e["answer"] == int(r["response_id"]) and len(e["features"]) == 4
    # Every trial logs the force the display measured over its contact: the emulated finger
    # presses with the lab's force for the trial (2.5 ± 0.25 N, 2.05-3 N: past the 2 N
    # trigger), and the display measures about that, not one force for every touch.
    forces = [float(r["contact_force_N"]) for r in rows]
    assert all(2.0 <= f <= 3.1 for f in forces) and np.std(forces) > 0.1, forces
    # Every model evaluation went through the scene planner and its decision is in the log:
    # what the simulated participant felt (at its own tolerance, not the perceptual floor) ...
    from experiments.participant_model.person import MODEL_TOLERANCE_C
    felt = {}
    for e in events:
        if e.get("event") == "simulated_receptor_model":
            felt.setdefault(e["trial_index"], []).append(e)
    assert sorted(felt) == sorted(int(r["trial_index"]) for r in rows)
    for r in rows:
        for e in felt[int(r["trial_index"])]:
            assert e["felt_as"] == r["mode"]
            assert e["tolerance_K"] == MODEL_TOLERANCE_C < 0.3
            assert 0.0 <= e["bound_K"] <= e["tolerance_K"] and e["model"].startswith("exact")
            assert e["method"] == "exact" and isinstance(e["neglected"], list)
    # ... and what the emulated finger touched: the passive sample's interface, planned
    fingers = {e["trial_index"]: e for e in events if e.get("event") == "emulated_finger_model"}
    assert sorted(fingers) == sorted(int(r["trial_index"]) for r in rows)
    for r in rows:
        e = fingers[int(r["trial_index"])]
        if r["mode"] == "real":
            for side in ("interface_material", "interface_skin"):
                d = e["sample_model"][side]
                assert d["tolerance_K"] == 0.005 and 0.0 <= d["bound_K"] <= 0.005, d
        else:
            assert e["finger_on_pad_model"]["method"] == "plant state"


def test_a_new_responder_relearns_the_opening_familiarisation_from_the_schedule():
    # A resumed session gets a fresh responder: its templates must come back identical.
    class FakeSession:
        participant = Participant(id="P9", measured_skin_m=700.0e-6)
        seed = 12
        schedule = [spec(i, "familiarise", "real", i) for i in (1, 2, 3, 4)] + \
                   [spec(5, "real", "real", 2), spec(6, "familiarise", "real", 1)]

        def log_event(self, kind, **fields):
            pass

    live = SimulatedResponder()
    live.begin_session(FakeSession())
    one_by_one = SimulatedResponder(seed=live.seed, skin_thickness_um=700.0)
    d = FakeDisplay()
    for trial in FakeSession.schedule[:4]:
        one_by_one.touch(trial, d)
    assert sorted(live.person.templates["real"]) == [1, 2, 3, 4]
    for rid in (1, 2, 3, 4):
        total, count = live.person.templates["real"][rid]
        np.testing.assert_array_equal(total, one_by_one.person.templates["real"][rid][0])
        assert count == 1          # trial 6 comes after a scored trial: not learned ahead


def test_simulated_trial_is_felt_through_the_protocols_finger_pad_resistance():

    from experiments.participant_model.person import SimulatedPerson
    t = np.arange(0, 10.0, 0.01)
    pad = 22.0 + 4.0 * (1 - np.exp(-t / 2.0))
    trial = spec(9, "simulated", "simulated", 2)
    stim = TrialStimulus("simulated", 2, 12.5, time_s=t, contact_C=pad, target_C=pad,
                         profile_parameters={})
    opts = dict(seed=4, skin_thickness_um=900.0, skin_temperature_sd_C=0.0, skin_temperature_C=35.5)
    person = SimulatedPerson(900e-6, 0.6, 35.5)
    # default (no protocol): the emulated pad's 0.4 µm copper face
    r = SimulatedResponder(**opts)
    _, felt, _ = r.feel(trial, stim)
    _, expected = person.feel_imposed(t, pad, pad_resistance=person.pad_resistance(0.4e-6, "copper"))
    np.testing.assert_allclose(felt, expected, atol=1e-9)
    # the protocol's pad: a rough steel face has a larger resistance, so the same pad feels warmer
    r = SimulatedResponder(**opts)
    r.session = LoggingSession(protocol=SimpleNamespace(
        simulation=SimpleNamespace(pad_roughness_um=50.0, pad_material="stainless_steel")))
    _, rough, _ = r.feel(trial, stim)
    # the display path's decision is logged, at the participant's tolerance (not 0.3 K)
    (kind, e), = r.session.events
    assert kind == "simulated_receptor_model" and e["felt_as"] == "simulated"
    assert e["tolerance_K"] == r.params.model_tolerance_C < 0.1 and e["bound_K"] <= e["tolerance_K"]
    assert r.pad_resistance() == pytest.approx(person.pad_resistance(50e-6, "stainless_steel"), rel=1e-12)
    assert np.all(rough[100:] > felt[100:] + 0.05)
    # pad_contact=false: the pad temperature imposed on the skin, colder still than through R
    r = SimulatedResponder(pad_contact="false", **opts)
    _, ideal, _ = r.feel(trial, stim)
    assert r.pad_resistance() is None
    assert np.all(ideal[100:] < felt[100:] - 0.05)


def test_bad_pad_options_are_user_errors():
    with pytest.raises(UserInputError, match="pad_roughness_um"):
        SimulatedResponder(pad_roughness_um="-1")
    r = SimulatedResponder(skin_thickness_um=900.0, pad_material="cheese")
    with pytest.raises(UserInputError, match="pad_material"):
        r.pad_resistance()


def test_finger_stays_on_for_the_whole_recording_of_an_exp1_session(tmp_path):
    """Exp. 1 asks for no answer: the finger stays on for record_s (25 s) of contact."""
    from experiments.cli import main
    from experiments.protocol import load_protocol

    protocol = load_protocol("interface_temperature")
    record_s, threshold_N = protocol.contact.record_s, protocol.contact.force_threshold_N
    participant = Path(__file__).resolve().parents[3] / "participants" / "examples" / "P01.json"
    status = main(["run", "interface_temperature", "--participant", str(participant),
                   "--display", "emulator://?clock=virtual", "--responder", "simulated",
                   "--data", str(tmp_path / "data"), "--seed", "1", "--quiet"])
    assert status == 0
    (trials,) = Path(tmp_path / "data").glob("*/*/trials.csv")
    rows = list(csv.DictReader(trials.open()))
    assert len(rows) == len(protocol.samples) and all(r["status"] == "ok" for r in rows)
    for row in rows:
        with open(trials.parent / row["trace_file"], newline="") as fh:
            trace = list(csv.DictReader(fh))
        t = np.array([float(f["time_s"]) for f in trace])
        force = np.array([sum(float(f[f"force{k}_N"]) for k in range(1, 5)) for f in trace])
        contact = float(row["contact_onset_s"])
        touching = t >= contact
        assert t[-1] - contact >= record_s - 0.02, (row["trace_file"], t[-1] - contact)
        assert np.all(force[touching] >= threshold_N), row["trace_file"]   # never let go early


def test_hold_depends_on_whether_the_block_asks_for_an_answer():

    from experiments.protocol import load_protocol
    from experiments.responders.simulated import HOLD_MARGIN_S

    protocol = load_protocol("roughness_recognition")
    r = SimulatedResponder(seed=1, skin_thickness_um=700.0)
    r.session = LoggingSession(protocol=protocol)
    answered = r.params.duration_s + 0.5          # feels, answers, lets go

    def hold(trial, responder=r):
        d = FakeDisplay()
        responder.touch(trial, d)
        return d.calls[-1][1]["hold_s"]

    assert hold(spec(5, "real", "real", 2)) == pytest.approx(answered)
    assert hold(spec(6, "simulated", "simulated", 2)) == pytest.approx(answered)
    # familiarisation: no answer, but told the sample and learning: the same feature window
    assert not protocol.block("familiarise").response and protocol.block("familiarise").feedback
    assert hold(spec(1, "familiarise", "real", 1)) == pytest.approx(answered)
    # a recording (Exp. 1: no answer, no feedback): the whole recorded contact
    exp1 = load_protocol("interface_temperature")
    (block,) = exp1.blocks
    assert not block.response and not block.feedback
    r.session = LoggingSession(protocol=exp1)
    assert hold(spec(1, block.name, "real", 1)) == pytest.approx(
        max(answered, exp1.contact.record_s + HOLD_MARGIN_S))
    r.session = LoggingSession(protocol=protocol)
    given = SimulatedResponder(seed=1, skin_thickness_um=700.0, hold_s="3.0")
    given.session = LoggingSession(protocol=protocol)
    assert hold(spec(1, "familiarise", "real", 1), given) == 3.0      # an explicit option wins


def _real_stimulus(rid, force_N, n=2000):
    """A real trial's record with the four sensors summing to ``force_N`` from contact on."""
    t = np.arange(-50, n) / 100.0
    f = np.where(t[:, None] >= 0, force_N / 4, 0.0) * np.ones((1, 4))
    return TrialStimulus("real", rid, RA_UM[rid], time_s=t, forces_N=f,
                         sample={"label": f"{rid}#", "material": "stainless_steel",
                                 "roughness_m": RA_UM[rid] * 1e-6, "thickness_m": 3e-3,
                                 "temperature_C": 20.0})


def test_contact_force_is_the_mean_summed_force_from_contact_on():
    from experiments.responders.base import contact_force
    t = np.array([-0.2, -0.1, 0.0, 0.1, 0.2, 0.3])
    f = np.array([[1, 1, 1, 1], [0.5] * 4, [0.5] * 4, [0.75] * 4, [0.0] * 4, [0.01] * 4])
    # before contact and after release (sum < 0.1 N) do not count: (2 + 3) / 2
    assert contact_force(t, f) == pytest.approx(2.5)
    assert contact_force(t[:2], f[:2]) is None
    assert _real_stimulus(1, 1.5).contact_force_N == pytest.approx(1.5)


def test_real_trial_is_felt_at_the_force_the_display_measured():
    # Eq. 5: a lighter press is a larger contact resistance, a warmer receptor (the
    # trial's measured force, not the scripted press, sets R in the real-sample percept).
    r = SimulatedResponder(seed=4, skin_thickness_um=650.0, skin_temperature_sd_C=0.0,
                           skin_temperature_C=35.5)
    trial = spec(9, "real", "real", 1)
    _, light, _ = r.feel(trial, _real_stimulus(1, 1.5))
    _, firm, _ = r.feel(trial, _real_stimulus(1, 2.5))
    person = r._ensure_person()
    _, expect = person.feel_real(1.6e-6, sample_thickness_m=3e-3, material_temperature_C=20.0,
                                 skin_temperature_C=35.5, force_N=1.5)
    np.testing.assert_allclose(light, expect, atol=1e-12)
    assert np.max(light[1:] - firm[1:]) > 0.2       # K: the force matters at the 0.3 K floor
