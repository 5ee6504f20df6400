"""Replay hypotheses are protocol variants built from the protocol's data."""
import json

import pytest

from experiments.errors import UserInputError
from experiments.protocol import load_protocol
from experiments.simulation.replay import (REPLAY_HYPOTHESES, protocol_variant,
                                           with_display_familiarisation)


def test_each_hypothesis_is_a_parsed_variant():
    base = load_protocol("roughness_recognition")
    assert base.simulation.target_side == "material"
    seen = set()
    for name, hyp in REPLAY_HYPOTHESES.items():
        v = protocol_variant(base, name)
        assert v.simulation.target_side == hyp.target_side
        assert v.simulation.rate_limit == hyp.rate_limit
        assert v.simulation.method == hyp.method
        assert v.simulation.replayed_material == hyp.replayed_material
        assert v.path is None
        assert [b.name for b in v.blocks] == [b.name for b in base.blocks]
        seen.add(v.hash)
    assert len(seen) == 5
    # the exact 3 mm slab's material side is the protocol as written: same content, same hash
    assert protocol_variant(base, "slab").hash == base.hash
    printed = protocol_variant(base, "printed").data["simulation"]
    assert (printed["method"], printed["replayed_material"]) == ("paper-as-printed", "half-space")
    assert base.data["simulation"]["target_side"] == "material"      # original untouched


def test_display_familiarisation_block_before_the_simulated_block():
    v = protocol_variant("roughness_recognition", "compensated", display_familiarisation=True)
    names = [b.name for b in v.blocks]
    assert names == ["familiarise", "real", "familiarise_display", "simulated"]
    block = v.block("familiarise_display")
    assert block.mode == "simulated" and not block.scored and block.feedback and block.response
    again = with_display_familiarisation(v)
    assert [b.name for b in again.blocks] == names


def test_unknown_hypothesis_is_a_user_error():
    with pytest.raises(UserInputError, match="--replay: expected one of printed, halfspace, slab, skin, compensated"):
        protocol_variant("roughness_recognition", "pad")


@pytest.mark.slow
def test_display_learned_observer_learns_on_the_display_in_a_session(tmp_path):

    from experiments.participant_model.cohort import write_cohort
    from experiments.simulation.figure9.study import run_participant
    (path,) = write_cohort(tmp_path / "people", seed=2)[:1]
    proto = protocol_variant("roughness_recognition", "compensated", display_familiarisation=True)
    runs = {}
    for observer in ("display_learned", "absolute"):
        res = run_participant(path, tmp_path / observer, seed=2, protocol=proto,
                              responder_options={"observer": observer}, durable=False)
        with open(f"{res['session_dir']}/events.jsonl") as fh:
            runs[observer] = [e for e in map(json.loads, fh) if e.get("event") == "simulated_percept"]
    # 12 real + 12 simulated answers judged; the display's familiarisation is only learned
    learned = {e["felt_as"]: e["templates"] for e in runs["display_learned"]}
    assert learned == {"real": "real", "simulated": "simulated"}
    assert {e["felt_as"]: e["templates"] for e in runs["absolute"]} == {"real": "real",
                                                                         "simulated": "real"}
