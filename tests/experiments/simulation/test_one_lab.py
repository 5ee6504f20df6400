"""One lab: the emulated study's touches and the Monte Carlo's come from the same distributions."""
import csv
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.stats import ks_2samp

from experiments.participant_model.lab import DEFAULT_LAB, FORCE_RANGE_N, LabVariability


def _monte_carlo_forces(lab, n=20_000, seed=11):
    # the Monte Carlo's own draw, on the generator simulate_studies seeds
    from experiments.simulation import studies
    assert studies.DEFAULT_LAB is DEFAULT_LAB          # the studies' default lab is this one
    return lab.draw_forces(np.random.default_rng(seed), (n,))


def test_the_simulated_responders_presses_are_the_monte_carlos_forces():
    from experiments.responders.simulated import SimulatedResponder
    responder = SimulatedResponder(seed=5, skin_thickness_um=700)
    pressed = np.array([responder._force(SimpleNamespace(trial_index=i)) for i in range(1500)])
    mc = _monte_carlo_forces(DEFAULT_LAB)
    assert ks_2samp(pressed, mc).pvalue > 1e-3
    # what the review found: one press of 2.497 N for everyone would fail this test
    assert ks_2samp(np.full(1500, 2.497), mc).pvalue < 1e-6
    # every press crosses the display's 2 N trigger
    assert pressed.min() >= FORCE_RANGE_N[0] and pressed.max() <= FORCE_RANGE_N[1]
    # the same trial presses the same (resuming a session changes nothing)
    assert responder._force(SimpleNamespace(trial_index=7)) == pressed[7]


def test_a_given_force_spread_reaches_the_responder_and_the_monte_carlo_alike():
    from experiments.responders.simulated import SimulatedResponder
    responder = SimulatedResponder(seed=5, skin_thickness_um=700, force_sd_N=0.5)
    pressed = np.array([responder._force(SimpleNamespace(trial_index=i)) for i in range(1500)])
    wide = LabVariability(force_sd_N=0.5)
    assert ks_2samp(pressed, _monte_carlo_forces(wide)).pvalue > 1e-3
    assert ks_2samp(pressed, _monte_carlo_forces(DEFAULT_LAB)).pvalue < 1e-6


def test_the_skin_temperature_per_touch_is_the_same_model():
    from experiments.participant_model.person import PerceptionParameters, SimulatedPerson
    person = SimulatedPerson(700e-6, 0.6, 35.7, PerceptionParameters())
    responder_side = np.array([person.trial_skin_temperature(np.random.default_rng([3, i]))
                               for i in range(1500)])
    mc = DEFAULT_LAB.draw_skin_temperatures(np.random.default_rng(4), 35.7, (20_000,))
    assert ks_2samp(responder_side, mc).pvalue > 1e-3


@pytest.mark.slow
def test_the_emulated_sessions_measured_forces_are_the_monte_carlos(tmp_path):
    # the force the display measured (trials.csv, Eq. 5's force for the person) in two
    # emulated sessions, against the Monte Carlo's draws
    from experiments.participant_model.cohort import write_cohort
    from experiments.simulation.figure9.study import run_participant
    paths = {p.stem: p for p in write_cohort(tmp_path / "people", seed=0)}
    measured = []
    for pid in ("P01", "P16"):
        result = run_participant(paths[pid], tmp_path / "data", seed=0, durable=False)
        with open(f"{result['session_dir']}/trials.csv") as fh:
            measured += [float(r["contact_force_N"]) for r in csv.DictReader(fh)
                         if r.get("contact_force_N")]
    measured = np.array(measured)
    assert measured.size >= 40
    assert ks_2samp(measured, _monte_carlo_forces(DEFAULT_LAB)).pvalue > 1e-3
    assert measured.std() > 0.1                 # not one press for every touch
