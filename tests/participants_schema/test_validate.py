"""Participant records: schema + semantic validation, one-line errors naming file and field."""
from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from participants_schema import (
    ParticipantError,
    SCHEMA_PATH,
    load_participant,
    participant_warnings,
    validate_participant,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "participants" / "examples"

GOOD = {
    "id": "P07",
    "age": 31,
    "sex": "female",
    "handedness": "right",
    "occupation": "farmer",
    "dominant_hand": "right",
    "skin_thickness": {"epidermis_um": 300, "dermis_um": 400, "total_um": 700,
                       "method": "bio-speckle", "measured_on": "2026-11-20"},
    "initial_skin_temperature_C": 35.6,
    "consent": {"given": True, "date": "2026-11-20"},
    "notes": "",
}


def write(tmp_path, record, name="P07.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(record), encoding="utf-8")
    return path


def changed(**paths):
    """GOOD with dotted paths set (value ... = delete)."""
    rec = copy.deepcopy(GOOD)
    for dotted, value in paths.items():
        keys = dotted.split("__")
        node = rec
        for k in keys[:-1]:
            node = node[k]
        if value is ...:
            del node[keys[-1]]
        else:
            node[keys[-1]] = value
    return rec


def test_schema_is_valid_draft_2020_12():
    from jsonschema import Draft202012Validator

    schema = json.loads(SCHEMA_PATH.read_text())
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    Draft202012Validator.check_schema(schema)


def test_good_record_loads_unchanged(tmp_path):
    path = write(tmp_path, GOOD)
    assert load_participant(path) == GOOD
    assert participant_warnings(GOOD) == []


@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.json")), ids=lambda p: p.name)
def test_examples_are_valid(path):
    rec = load_participant(path)
    assert rec["id"] == path.stem
    assert rec["consent"]["given"] is True


def test_examples_cover_both_groups():
    totals = [load_participant(p)["skin_thickness"]["total_um"] for p in EXAMPLES.glob("*.json")]
    assert any(t < 800 for t in totals) and any(t > 800 for t in totals)


def test_brief_example_message_exactly(tmp_path):
    path = write(tmp_path, changed(skin_thickness__total_um="abc"))
    with pytest.raises(ParticipantError) as ei:
        load_participant(path)
    assert str(ei.value) == f"{path}: skin_thickness.total_um: expected a number > 0, got 'abc'"
    assert ei.value.field == "skin_thickness.total_um"
    assert ei.value.source == str(path)


@pytest.mark.parametrize("change, field, fragment", [
    ({"skin_thickness__total_um": -5}, "skin_thickness.total_um", "expected a number > 0, got -5"),
    ({"skin_thickness__total_um": True}, "skin_thickness.total_um", "expected a number > 0, got True"),
    ({"skin_thickness__method": ...}, "skin_thickness.method", "got nothing (the field is required)"),
    ({"skin_thickness__measured_on": "2026-02-30"}, "skin_thickness.measured_on",
     "expected a date (YYYY-MM-DD), got '2026-02-30'"),
    ({"sex": "f"}, "sex", "expected one of 'female', 'male', 'other', 'undisclosed', got 'f'"),
    ({"age": 31.5}, "age", "expected an integer ≥ 0 and ≤ 130, got 31.5"),
    ({"id": "P 07/../x"}, "id", "got 'P 07/../x'"),
    ({"skin_thicknes": {}}, "skin_thicknes", "got an unknown field 'skin_thicknes'"),
    ({"consent__given": False}, "consent.given", "expected true (no session without consent), got False"),
    ({"consent": ...}, "consent", "got nothing (the field is required)"),
    ({"initial_skin_temperature_C": 3.5}, "initial_skin_temperature_C", "expected a number ≥ 20 and ≤ 42, got 3.5"),
    # millimetres typed where micrometres are expected
    ({"skin_thickness__total_um": 0.7, "skin_thickness__epidermis_um": ..., "skin_thickness__dermis_um": ...},
     "skin_thickness.total_um", "expected a fingertip skin thickness from 100 to 5000 µm, got 0.7"),
    ({"skin_thickness__epidermis_um": 800}, "skin_thickness.epidermis_um", "expected less than total_um (700), got 800"),
    ({"skin_thickness__dermis_um": 100}, "skin_thickness",
     "expected epidermis_um + dermis_um to equal total_um (700) within 25%, got 400"),
    ({"calibration": {"contact_resistance_m2K_W": {"1.6": -1e-4}}},
     "calibration.contact_resistance_m2K_W.1.6", "expected a number ≥ 0, got -0.0001"),
])
def test_bad_field_gives_one_line_naming_file_and_field(tmp_path, change, field, fragment):
    path = write(tmp_path, changed(**change))
    with pytest.raises(ParticipantError) as ei:
        load_participant(path)
    msg = str(ei.value)
    assert "\n" not in msg
    assert msg.startswith(f"{path}: {field}: ")
    assert msg.endswith(fragment)
    assert isinstance(ei.value, ValueError)


def test_all_errors_are_kept(tmp_path):
    path = write(tmp_path, changed(sex="f", handedness="both"))
    with pytest.raises(ParticipantError) as ei:
        load_participant(path)
    fields = [e.split(": ")[1] for e in ei.value.errors]
    assert fields == ["handedness", "sex"]


def test_not_json_names_line(tmp_path):
    path = tmp_path / "P07.json"
    path.write_text('{\n  "id": "P07",\n  "age": 31\n  "sex": "male"\n}\n')
    with pytest.raises(ParticipantError, match=r"P07\.json: line 4 column 3: expected valid JSON"):
        load_participant(path)


def test_missing_file(tmp_path):
    with pytest.raises(ParticipantError, match="P99.json: expected a participant file, got no such file"):
        load_participant(tmp_path / "P99.json")


def test_not_an_object(tmp_path):
    path = write(tmp_path, [GOOD])
    with pytest.raises(ParticipantError, match=r"P07\.json: \(record\): expected a JSON object"):
        load_participant(path)


def test_calibration_block_is_permissive():
    rec = changed(calibration={
        "method": "fit", "date": "2026-11-21", "skin_thickness_um": 690,
        "contact_resistance_m2K_W": {"1.6": 2e-4, "12.5": 3e-4, "50": 7e-4, "100": 1.2e-3},
        "intervals": {"skin_thickness_um": [650, 730]}, "residual_rms_C": 0.05, "software": "x"})
    assert validate_participant(rec) is rec


def test_lab_extension_fields_allowed():
    rec = changed(x_lab_room="B12")
    assert validate_participant(rec) is rec


def test_warnings_for_small_layer_mismatch_and_handedness():
    # 300 + 430 = 730 vs 700: 30 µm off, more than max(10, 2% of 700 = 14) but far under 25%
    rec = changed(skin_thickness__dermis_um=430, handedness="left")
    validate_participant(rec)
    w = participant_warnings(rec)
    assert any("epidermis_um + dermis_um = 730" in x and "by 30" in x for x in w)
    assert any("handedness 'left' contradicts dominant_hand 'right'" in x for x in w)
    # within tolerance: 300 + 410 = 710, 10 µm off, tolerance 14 µm
    assert participant_warnings(changed(skin_thickness__dermis_um=410)) == []


def test_unusual_but_possible_thickness_warns():
    rec = changed(skin_thickness={"total_um": 3000, "method": "ultrasound"})
    validate_participant(rec)
    assert any("outside the usual fingertip range" in w for w in participant_warnings(rec))


def test_bad_participant_through_the_cli(tmp_path, capsys):
    from experiments.cli import main

    path = write(tmp_path, changed(skin_thickness__total_um="abc"))
    status = main(["run", "roughness_recognition", "--participant", str(path), "--display",
                   "emulator://?clock=virtual", "--responder", "simulated", "--data", str(tmp_path / "data")])
    err = capsys.readouterr().err
    assert status == 2
    assert err == f"thermocue run: {path}: skin_thickness.total_um: expected a number > 0, got 'abc'\n"
