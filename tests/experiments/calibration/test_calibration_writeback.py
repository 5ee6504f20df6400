"""The participant record's calibration field: written atomically, valid, and read back."""
import json
import shutil
from pathlib import Path

import jsonschema
import numpy as np
import pytest

from experiments.calibration import (calibrated_profile_parameters, calibration_record, fit_traces,
                                     synthetic_traces, write_participant_calibration)
from participants_schema import ParticipantError, load_participant, load_schema

EXAMPLE = Path(__file__).resolve().parents[3] / "participants" / "examples" / "P01.json"


@pytest.fixture(scope="module")
def fit():
    traces = synthetic_traces([6.5e-4, 1.6e-3], 900e-6, roughness_um=[1.6, 50.0], duration_s=10.0,
                              rng=np.random.default_rng(8))
    return fit_traces(traces)


def test_round_trip_validates_against_the_schema(tmp_path, fit):
    path = tmp_path / "P01.json"
    shutil.copy(EXAMPLE, path)
    before = json.loads(path.read_text())
    cal = calibration_record(fit, session="DATA/P01/S1", date="2026-11-22")
    write_participant_calibration(path, cal)
    rec = load_participant(path)                       # schema + semantic checks
    jsonschema.Draft202012Validator(load_schema()).validate(rec)
    assert {k: v for k, v in rec.items() if k != "calibration"} == before
    c = rec["calibration"]
    assert c["date"] == "2026-11-22" and "least squares" in c["method"] and "profile" in c["method"]
    assert c["skin_thickness_um"] == pytest.approx(fit.skin_thickness.value * 1e6)
    assert set(c["contact_resistance_m2K_W"]) == {"1.6", "50"}
    lo, hi = c["intervals"]["skin_thickness_um"]
    assert lo < c["skin_thickness_um"] < hi
    assert [p.name for p in tmp_path.iterdir()] == ["P01.json"]     # no temporary file left
    # later simulated trials of this participant use these values instead of the group mean
    got = calibrated_profile_parameters(rec, roughness_id=2, roughness_um=50.0)
    assert got["resistance"] == pytest.approx(fit.resistances()[1].value)
    assert got["skin_thickness"] == pytest.approx(fit.skin_thickness.value)
    assert calibrated_profile_parameters(rec, roughness_id=1)["resistance"] == pytest.approx(
        fit.resistances()[0].value)
    other = calibrated_profile_parameters(rec, roughness_id=4, roughness_um=100.0)   # not calibrated
    assert other["resistance"] is None and other["skin_thickness"] == got["skin_thickness"]
    assert calibrated_profile_parameters(before, roughness_id=1) is None


def test_invalid_calibration_leaves_the_record_untouched(tmp_path, fit):
    path = tmp_path / "P01.json"
    shutil.copy(EXAMPLE, path)
    before = path.read_bytes()
    cal = calibration_record(fit)
    cal["skin_thickness_um"] = 90000.0                # 9 cm: a unit mistake
    with pytest.raises(ParticipantError, match="calibration.skin_thickness_um"):
        write_participant_calibration(path, cal)
    cal = calibration_record(fit)
    cal["contact_resistance_m2K_W"]["1.6"] = -1.0
    with pytest.raises(ParticipantError, match="contact_resistance_m2K_W"):
        write_participant_calibration(path, cal)
    assert path.read_bytes() == before
