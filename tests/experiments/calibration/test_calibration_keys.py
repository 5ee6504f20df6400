"""One key convention for a record's fitted resistances.

``thermocue calibrate`` keys ``calibration.contact_resistance_m2K_W`` by the sample's Ra in µm
("1.6", "12.5", ...); the schema, the shipped example P03 and the session use the same keys. On
the old code P03 keyed them "1#".."4#" and every session with it fell back to Eq. 5 silently.
"""
from __future__ import annotations

import json

import pytest

from _session_helpers import ROOT, write_protocol
from experiments.calibration import CalibrationError
from experiments.calibration.writeback import calibration_key, check_calibration_samples
from experiments.session import plan_session
from participants_schema import ParticipantError, load_participant

P03 = ROOT / "participants" / "examples" / "P03.json"


def test_the_shipped_calibrated_example_is_used_by_a_session(tmp_path):
    proto = write_protocol(tmp_path, real_samples=(), sim_samples=(1, 2, 3, 4))
    plan = plan_session(proto, P03, tmp_path / "data", "emulator://?clock=virtual", seed=1)
    sources = {k[1]: p.parameters["resistance_source"] for k, p in plan.profiles.items()}
    assert sources == {1.6: "calibration", 12.5: "calibration", 50.0: "calibration",
                       100.0: "calibration"}
    record = load_participant(P03)
    for (_, um), p in plan.profiles.items():   # the record's own numbers, not Eq. 5's
        assert p.parameters["resistance_m2K_per_W"] == \
            record["calibration"]["contact_resistance_m2K_W"][calibration_key(um)]


def test_sample_labels_as_keys_are_refused_by_the_schema(tmp_path):
    record = json.loads(P03.read_text())
    record["calibration"]["contact_resistance_m2K_W"] = {"1#": 2.1e-4, "2#": 3.4e-4}
    path = tmp_path / "P03.json"
    path.write_text(json.dumps(record))
    with pytest.raises(ParticipantError) as err:
        load_participant(path)
    assert str(err.value) == (
        f"{path}: calibration.contact_resistance_m2K_W: expected keys naming samples by their "
        "roughness Ra in µm, as `thermocue calibrate` writes them (e.g. '1.6', '12.5', '50', "
        "'100'), got '1#'")


def test_a_calibration_for_no_sample_of_the_protocol_is_refused(tmp_path):
    record = json.loads(P03.read_text())
    record["calibration"]["contact_resistance_m2K_W"] = {"2.5": 2.1e-4, "25": 3.4e-4}
    path = tmp_path / "P03.json"
    path.write_text(json.dumps(record))
    proto = write_protocol(tmp_path, real_samples=(), sim_samples=(1, 2))
    with pytest.raises(CalibrationError) as err:
        plan_session(proto, path, tmp_path / "data", "emulator://?clock=virtual", seed=1)
    assert str(err.value) == (
        f"{path}: calibration.contact_resistance_m2K_W: expected keys naming the protocol's "
        "samples by Ra in µm ('1.6', '12.5', '50', '100'), got '2.5', '25': no fitted "
        "resistance would be used")
    assert not (tmp_path / "data").exists()
    # One matching key is enough (the other samples use Eq. 5, as documented).
    check_calibration_samples({"calibration": {"contact_resistance_m2K_W": {"12.5": 1e-4}}},
                              [1.6, 12.5])
