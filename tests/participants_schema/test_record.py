"""The frozen Participant record (participants_schema.record): read once, SI inside."""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from participants_schema import Participant, ParticipantError, skin_um

EXAMPLES = Path(__file__).resolve().parents[2] / "participants" / "examples"


def test_read_gives_each_skin_thickness_its_own_name_in_metres():
    p = Participant.read(EXAMPLES / "P01.json")      # total 680 µm, dermis 410 µm, no calibration
    assert p.id == "P01"
    assert p.measured_skin_m == pytest.approx(680e-6, rel=1e-12)
    assert p.dermis_fraction == pytest.approx(410 / 680)
    assert p.fitted_skin_m is None and p.calibration is None
    assert p.initial_skin_temperature_C == 35.7 and p.sex == "female"
    assert p.source == str(EXAMPLES / "P01.json")


def test_the_fitted_skin_is_apart_from_the_measured_one():
    record = json.loads((EXAMPLES / "P01.json").read_text())
    record["calibration"] = {"method": "test", "date": "2026-11-22", "skin_thickness_um": 912.5}
    p = Participant.from_record(record, source="P01.json")
    assert p.measured_skin_m == pytest.approx(680e-6, rel=1e-12)
    assert p.fitted_skin_m == pytest.approx(912.5e-6, rel=1e-12)
    assert p.calibration["skin_thickness_um"] == 912.5


def test_the_record_is_frozen_and_its_json_comes_back_unchanged():
    record = json.loads((EXAMPLES / "P02.json").read_text())
    p = Participant.from_record(record)
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.measured_skin_m = 1e-3
    copy = p.record()
    assert copy == record and list(copy) == list(record)
    copy["skin_thickness"]["total_um"] = 1        # a caller's copy: the participant keeps its own
    assert p.record()["skin_thickness"]["total_um"] == 1050


def test_a_bad_record_is_refused_at_the_edge_naming_the_file_and_field(tmp_path):
    record = json.loads((EXAMPLES / "P01.json").read_text())
    record["skin_thickness"]["total_um"] = -5
    path = tmp_path / "P01.json"
    path.write_text(json.dumps(record))
    with pytest.raises(ParticipantError) as ei:
        Participant.read(path)
    assert str(ei.value) == f"{path}: skin_thickness.total_um: expected a number > 0, got -5"


@pytest.mark.parametrize("um, shown", [(680, 680), (712.5, 712.5), (1050, 1050), (0.7, 0.7)])
def test_skin_um_gives_the_files_the_micrometres_the_record_had(um, shown):
    value = skin_um(float(um) * 1e-6)
    assert value == shown and type(value) is type(shown)
