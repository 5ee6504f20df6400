"""Conditions are data: sessions of two displays (the thermocue display's emulator and the TCS II
emulator) in one data folder are never pooled into one test. On the old code such a folder gave
a report that named neither display, and a design with a group lacking real trials ended in
ZeroDivisionError in tests_table."""
from __future__ import annotations

import csv
import json
import re
import sys
from importlib.resources import files
from pathlib import Path

import pandas as pd
import pytest

from analysis import LogError, analyze
from analysis.conditions import choose_condition, session_condition
from analysis.load import load_trials
from experiments.cli import main

sys.path.insert(0, str(Path(__file__).parent))
from test_load_sessions import ROOT, Answers  # noqa: E402 - the tests' own responder

from _study_writer import paper_like_cells, write_study  # noqa: E402


def _short(folder: Path, name: str) -> Path:
    """A packaged protocol with 2 s contacts and one repetition (a quick session)."""
    text = (files("experiments") / "protocols" / f"{name}.toml").read_text("utf-8")
    for key in ("max_contact_s", "record_s", "duration_s"):
        text = re.sub(rf"^{key} = 20\.0", f"{key} = 2.0", text, flags=re.M)
    text = re.sub(r"^repetitions = [36]", "repetitions = 1", text, flags=re.M)
    path = folder / f"{name}.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _participant(folder: Path, pid: str, thickness_um: int) -> Path:
    record = json.loads((ROOT / "participants" / "examples" / "P01.json").read_text())
    record["id"] = pid
    record["skin_thickness"]["total_um"] = thickness_um
    record["skin_thickness"]["dermis_um"] = thickness_um - record["skin_thickness"]["epidermis_um"]
    path = folder / f"{pid}.json"
    path.write_text(json.dumps(record))
    return path


@pytest.fixture(scope="module")
def mixed(tmp_path_factory):
    """Two participants (A, B) on the thermocue display's emulator (press-to-touch, real and
    simulated blocks) and two on the TCS II emulator (resting probe, simulated only)."""
    from experiments.session import create_session
    tmp = tmp_path_factory.mktemp("mixed")
    data = tmp / "data"
    plan = [("PA1", 680, "emulator://?clock=virtual&seed=1", "roughness_recognition"),
            ("PB1", 1000, "emulator://?clock=virtual&seed=2", "roughness_recognition"),
            ("TA1", 680, "tcs2://emulator?clock=virtual&seed=3", "roughness_recognition_tcs2"),
            ("TB1", 1000, "tcs2://emulator?clock=virtual&seed=4", "roughness_recognition_tcs2")]
    for i, (pid, thickness, url, protocol) in enumerate(plan):
        s = create_session(_short(tmp, protocol), _participant(tmp, pid, thickness), data, url,
                           seed=i, responder_name="answers-until-test", clock="virtual")
        assert s.run(Answers(None)) == 0
    return data


@pytest.mark.slow
def test_mixed_backends_are_refused_in_one_line_naming_both_conditions(mixed, tmp_path, capsys):
    with pytest.raises(LogError) as err:
        load_trials(mixed)
    text = str(err.value)
    assert "emulator/press" in text and "tcs2/resting" in text and "--condition" in text
    assert "PA1" in text and "TA1" in text and "\n" not in text
    assert main(["analyze", str(mixed), "--out", str(tmp_path / "out"), "--bootstrap", "20",
                 "--no-mixed"]) == 2
    err_text = capsys.readouterr().err
    assert "tcs2/resting" in err_text and "--condition" in err_text
    assert "Traceback" not in err_text
    assert not (tmp_path / "out" / "report.md").exists()


@pytest.mark.slow
def test_each_condition_is_analysed_alone_and_named(mixed, tmp_path):
    for condition, mine, other in (("emulator/press", {"PA1", "PB1"}, {"TA1", "TB1"}),
                                   ("tcs2/resting", {"TA1", "TB1"}, {"PA1", "PB1"})):
        out = tmp_path / condition.replace("/", "_")
        assert main(["analyze", str(mixed), "--out", str(out), "--bootstrap", "20", "--no-mixed",
                     "--condition", condition]) == 0
        trials = pd.read_csv(out / "all_trials.csv", keep_default_na=False)
        used = trials[trials["included"] == 1]
        assert set(used["participant"]) == mine
        backend, contact = condition.split("/")
        assert set(used["display_backend"]) == {backend} and set(used["contact_model"]) == {contact}
        assert set(used["protocol_name"]) == ({"roughness_recognition_tcs2"}
                                              if backend == "tcs2" else {"roughness_recognition"})
        left = trials[trials["participant"].isin(other)]
        assert not left["included"].any()
        assert set(left["exclusion"]) == {"another condition (see --condition)"}
        sessions = pd.read_csv(out / "sessions.csv", keep_default_na=False)
        assert set(sessions["display_backend"]) == {"emulator", "tcs2"}
        assert set(sessions["contact_model"]) == {"press", "resting"}
        assert (sessions["protocol_hash"].str.len() == 64).all()
        assert set(sessions.loc[sessions["analysed"] == 1, "participant"]) == mine
        report = (out / "report.md").read_text()
        assert f"Condition analysed: display backend `{backend}`, contact model `{contact}`" in report
        assert "are not pooled with it" in report
        # one participant per group: every comparison of the groups says why it is not tested
        tests = pd.read_csv(out / "tests.csv", keep_default_na=False)
        assert tests["test"].str.startswith("not tested").all(), tests["test"].tolist()


def test_unrecorded_values_join_the_one_recorded_condition():
    rows = pd.DataFrame({"path": ["a", "b", "c"], "skipped": ["", "", ""],
                         "display_backend": ["tcs2", "", "tcs2"],
                         "contact_model": ["resting", "", ""]})
    kept, label = choose_condition(rows, None)
    assert label == "tcs2/resting" and (kept["skipped"] == "").all()
    rows.loc[2, "display_backend"] = "serial"
    with pytest.raises(LogError, match="--condition"):
        choose_condition(rows, None)
    kept, label = choose_condition(rows, "serial/resting")
    assert list(kept["skipped"].str.startswith("condition ")) == [True, False, False]
    with pytest.raises(LogError, match="--condition: expected one of"):
        choose_condition(rows, "qemu-firmware/press")


def test_session_condition_reads_display_device_firmware_and_contact_model():
    meta = {"display_url": "/dev/ttyACM0", "protocol_name": "x", "protocol_hash": "ab",
            "protocol": {"simulation": {"contact_model": "resting"}},
            "displays": [{"url": "/dev/ttyACM0", "device_id": "TC-0042", "image_id": "f00d"},
                         {"url": "/dev/ttyACM0", "device_id": "TC-0042", "image_id": "f00d"}]}
    assert session_condition(meta) == {"display_backend": "serial", "device_id": "TC-0042",
                                       "firmware_image_id": "f00d", "contact_model": "resting",
                                       "protocol_name": "x", "protocol_hash": "ab"}
    # resumed on another device: both named, in the order they were opened
    meta["displays"].append({"url": "/dev/ttyACM1", "device_id": "TC-0043", "image_id": "beef"})
    got = session_condition(meta)
    assert (got["device_id"], got["firmware_image_id"]) == ("TC-0042 + TC-0043", "f00d + beef")
    assert session_condition({"display_url": "loop://", "protocol": {}})["contact_model"] == "press"
    assert session_condition({"display_url": "loop://"})["display_backend"] == "serial"
    assert session_condition({}) == dict.fromkeys(session_condition({}), "")


def test_a_group_without_real_trials_is_not_tested_not_a_traceback(tmp_path):
    """The issue's design (simulated-only sessions beside sessions with both modes): before,
    ZeroDivisionError in tests_table (it['log_odds'] / it['se'])."""
    data = tmp_path / "data"
    write_study(data, paper_like_cells(), n_per_group=3, sigma=0.5, seed=1, write_events=False)
    for folder in data.glob("A*/S1"):
        with open(folder / "trials.csv", newline="") as fh:
            rows = [r for r in csv.DictReader(fh) if r["mode"] != "real"]
        with open(folder / "trials.csv", "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    result = analyze(data, tmp_path / "out", n_boot=20)
    tests = result.tests.set_index("role")
    assert tests.loc["primary", "test"] == "not tested: group A has no real trials"
    inter = result.tests[result.tests["role"] == "interaction"]
    assert (inter["test"] == "not tested: group A has no real trials").all()
    real = result.tests[(result.tests["role"] == "per-sample")
                        & result.tests["compares"].str.contains("real")]
    assert len(real) == 4 and real["test"].str.startswith("not tested: group A has no real").all()
    assert real["p_value"].isna().all()
    fid = result.fidelity[(result.fidelity["model"] == "gee") & (result.fidelity["group"] != "B")]
    assert fid["test"].str.startswith("not tested: group A has no real trials").all()
    assert fid["p_value"].isna().all()
    report = (tmp_path / "out" / "report.md").read_text()
    assert "nan" not in report.split("## Proportion correct")[0]
    assert "Not tested (primary, per-sample, interaction" in report
