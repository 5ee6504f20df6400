"""stimuli.paper: the paper's constants and names have one home, and every user reads them from it."""
from __future__ import annotations

import subprocess
import sys

import pytest

from stimuli import paper


def test_importing_the_constants_loads_neither_numpy_nor_the_model():
    # The command line reads its choices= from stimuli.paper; importing it must stay cheap.
    code = ("import sys, stimuli.paper; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('numpy', 'scipy') "
            "or m in ('stimuli.contact', 'stimuli.target', 'stimuli.properties')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_the_package_still_exports_its_model_on_first_use():
    import stimuli
    from stimuli import Contact, Skin, target_profile
    from stimuli.contact import Contact as direct
    assert Contact is direct and stimuli.Skin is Skin and callable(target_profile)
    assert stimuli.scene.__name__ == "stimuli.scene"          # a submodule by attribute
    assert set(stimuli.__all__) <= set(dir(stimuli))
    with pytest.raises(AttributeError, match="no_such_name"):
        stimuli.no_such_name


def test_the_packaged_protocol_states_the_papers_samples_and_groups():
    from experiments.protocol import load_protocol
    proto = load_protocol("roughness_recognition")
    assert tuple(s.label for s in proto.samples) == paper.SAMPLE_NAMES
    assert tuple(s.roughness_um for s in proto.samples) == paper.SAMPLE_ROUGHNESS_UM
    sim = proto.simulation
    assert dict(sim.group_skin_thickness_um) == paper.GROUP_TARGET_THICKNESS_UM
    assert sim.skin_temperature_C == paper.TARGET_SKIN_TEMPERATURE_C
    assert (sim.pad_roughness_um, sim.pad_material) == (paper.PAD_ROUGHNESS_UM, paper.PAD_MATERIAL)


def test_users_read_the_names_from_here_not_from_copies():
    from experiments import protocol
    from stimuli import target
    assert protocol.SIM_TARGET_SIDES is paper.TARGET_SIDES and target.SIDES is paper.TARGET_SIDES
    assert protocol.SIM_RATE_LIMITS is paper.RATE_LIMITS and protocol.MODES is paper.MODES
    assert protocol.DEFAULT_PAD_MATERIAL is paper.PAD_MATERIAL


def test_command_line_choices_are_the_papers_names():
    from experiments.cli import build_parser
    parser = build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices

    def choices(command, option):
        action = commands[command]._option_string_actions[option]
        return action.choices

    assert choices("reproduce", "--target-side") is paper.TARGET_SIDES
    assert choices("reproduce", "--replay") is paper.REPLAY_NAMES
    assert choices("reproduce", "--rate-limit") is paper.RATE_LIMITS
    assert choices("run", "--responder") is paper.RESPONDER_NAMES
    assert choices("resume", "--responder") is paper.RESPONDER_NAMES
    assert choices("power", "--mode") is paper.MODES


def test_replay_hypotheses_are_the_names_reproduce_offers():
    # reproduce --replay takes its choices from REPLAY_NAMES on the strength of this
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    assert tuple(REPLAY_HYPOTHESES) == paper.REPLAY_NAMES
    assert all(h.target_side in paper.TARGET_SIDES for h in REPLAY_HYPOTHESES.values())
    assert all(h.rate_limit in paper.RATE_LIMITS for h in REPLAY_HYPOTHESES.values())


def test_responder_names_are_the_registered_responders():
    from experiments.responders import get_responder
    for name in paper.RESPONDER_NAMES:
        assert type(get_responder(name)).name == name


def test_cohort_ranges_are_the_papers():
    from experiments.participant_model.cohort import PAPER_GROUPS, paper_cohort
    assert {g.name: g.thickness_um for g in PAPER_GROUPS} == paper.GROUP_THICKNESS_UM
    for record in paper_cohort(seed=4):
        low, high = paper.GROUP_THICKNESS_UM[record["x_simulation"]["group"]]
        assert low <= record["skin_thickness"]["total_um"] <= high
        t_low, t_high = paper.SKIN_TEMPERATURE_RANGE_C
        assert t_low <= record["initial_skin_temperature_C"] <= t_high
