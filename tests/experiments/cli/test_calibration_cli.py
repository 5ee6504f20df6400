"""`thermocue calibrate` on session directories (hand-built, and one from the real engine)."""
import csv
import json
import shutil

import numpy as np
import pytest

from _calibration_helpers import EXAMPLE, make_session
from experiments.cli import main
from participants_schema import load_participant
from stimuli import Skin, contact_resistance, material


def test_calibrate_end_to_end_and_write_back(tmp_path, capsys):
    sdir = make_session(tmp_path / "DATA")
    pfile = tmp_path / "P01.json"
    shutil.copy(EXAMPLE, pfile)
    out = tmp_path / "cal"
    status = main(["calibrate", str(sdir), "--out", str(out), "--sample-thickness-um", "3000",
                   "--write-participant", str(pfile)])
    assert status == 0, capsys.readouterr().err
    for f in ("residuals.png", "resistances.csv", "skin.csv", "parameters.md", "fit.json"):
        assert (out / f).stat().st_size > 0, f
    assert (out / "residuals.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with open(out / "resistances.csv") as fh:
        res = list(csv.DictReader(fh))
    assert [float(r["roughness_um"]) for r in res] == [1.6, 12.5, 50.0, 100.0]
    for r in res:
        truth = float(contact_resistance(float(r["roughness_um"]) * 1e-6))
        half = (np.log(float(r["R_high_m2K_W"])) - np.log(float(r["R_low_m2K_W"]))) / 2
        assert abs(np.log(float(r["R_m2K_W"]) / truth)) <= 2 * half    # ~4 standard errors
        assert abs(float(r["R_m2K_W"]) / truth - 1) < 0.05
        assert float(r["R_eq5_m2K_W"]) == pytest.approx(truth, rel=1e-5)   # 6 digits in the CSV
    with open(out / "skin.csv") as fh:
        skin = next(csv.DictReader(fh))
    assert abs(float(skin["skin_thickness_um"]) - 700.0) < 10.0
    assert float(skin["skin_thickness_low_um"]) < float(skin["skin_thickness_um"]) < float(skin["skin_thickness_high_um"])
    rec = load_participant(pfile)
    assert rec["calibration"]["skin_thickness_um"] == pytest.approx(float(skin["skin_thickness_um"]), rel=1e-4)
    assert rec["calibration"]["sensor_side"] == "material"
    assert "calibrate:" in capsys.readouterr().out


def test_flat_traces_exit_2_naming_file_and_field(tmp_path, capsys):
    sdir = make_session(tmp_path / "DATA", flat=True)
    assert main(["calibrate", str(sdir), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "trial-001.csv: contact_C" in err and "flat" in err


def test_truncated_traces_exit_2(tmp_path, capsys):
    sdir = make_session(tmp_path / "DATA", duration_s=1.0)
    assert main(["calibrate", str(sdir), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "time_s" in err and "truncated" in err and "Traceback" not in err


def test_missing_column_exit_2(tmp_path, capsys):
    sdir = make_session(tmp_path / "DATA", drop_column="contact_C")
    assert main(["calibrate", str(sdir), "--out", str(tmp_path / "o")]) == 2
    assert "trial-001.csv: contact_C: expected a column" in capsys.readouterr().err


def test_unidentifiable_fit_is_refused_with_reasons(tmp_path, capsys):
    # 3 s on half-space samples with a 2 mm skin: L cannot be determined
    sdir = make_session(tmp_path / "DATA", duration_s=3.0, half_space=True, skin_thickness=2e-3,
                        samples=(1, 4))
    out = tmp_path / "o"
    assert main(["calibrate", str(sdir), "--out", str(out), "--sample-thickness-um", "inf"]) == 2
    err = capsys.readouterr().err
    assert "calibration refused" in err and "L is not identifiable" in err
    refusal = json.loads((out / "refusal.json").read_text())
    assert refusal["reasons"] and "condition_number" in refusal["diagnostics"]
    assert not (out / "fit.json").exists()


def test_bad_options_exit_2(tmp_path, capsys):
    sdir = make_session(tmp_path / "DATA", samples=(1,), duration_s=5.0)
    assert main(["calibrate", str(sdir), "--out", str(tmp_path / "o"), "--sample-thickness-um", "-3"]) == 2
    assert "--sample-thickness-um" in capsys.readouterr().err
    assert main(["calibrate", str(tmp_path / "nope"), "--out", str(tmp_path / "o")]) == 2
    assert "expected a session directory" in capsys.readouterr().err


@pytest.mark.slow   # end to end; `./scripts/test -m slow` (CI) runs it
def test_calibrate_an_emulated_exp1_session(tmp_path, capsys):
    """Exp. 1 through the real session engine on the emulated display, then calibrate.

    The emulator's sample sensor follows stimuli's exact Contact (material side) with Eq. 5's
    R for each sample and the participant's skin thickness (P01: 680 µm); the simulated
    participant rewarms to a slightly different skin temperature on every touch, so the
    initial skin temperature is fitted per trace (the CLI's default).
    """
    from experiments.protocol import PROTOCOLS_DIR
    text = (PROTOCOLS_DIR / "interface_temperature.toml").read_text()
    if "[grouping]" not in text:   # the session engine needs a group rule to start a session
        text += '\n[grouping]\nthreshold_um = 800.0\nmargin_um = 50.0\nbelow = "A"\nabove = "B"\n'
    proto = tmp_path / "interface_temperature.toml"
    proto.write_text(text)
    pfile = tmp_path / "P01.json"
    shutil.copy(EXAMPLE, pfile)
    data = tmp_path / "DATA"
    # every press at the lab's 2.5 N (no touch-to-touch spread): the truth below is Eq. 5 at
    # that one force
    status = main(["run", str(proto), "--participant", str(pfile), "--display", "emulator://?clock=virtual",
                   "--responder", "simulated", "--responder-option", "force_sd_N=0",
                   "--data", str(data), "--seed", "1"])
    assert status == 0, capsys.readouterr().err
    (sdir,) = [p for p in (data / "P01").iterdir() if p.is_dir()]
    out = tmp_path / "cal"
    assert main(["calibrate", str(sdir), "--out", str(out), "--write-participant", str(pfile)]) == 0, \
        capsys.readouterr().err
    summary = json.loads((out / "fit.json").read_text())
    L = summary["skin_thickness_m"]
    assert L["low"] <= 680e-6 <= L["high"] and abs(L["value"] / 680e-6 - 1) < 0.01
    skin = Skin(680e-6)
    steel = material("stainless_steel", thickness=3e-3)
    assert len(summary["samples"]) == 5
    for s in summary["samples"]:
        # the emulated finger presses 2.5 N (the protocol's 2 N threshold + 0.5 N) and the
        # emulator's sample contact follows Eq. 5 at that force
        truth = float(contact_resistance(s["roughness_um"] * 1e-6, skin=skin, material=steel,
                                         force=2.5))
        half = (np.log(s["high_m2K_W"]) - np.log(s["low_m2K_W"])) / 2
        assert abs(np.log(s["resistance_m2K_W"] / truth)) <= 2 * half, (s, truth)
        assert abs(s["resistance_m2K_W"] / truth - 1) < 0.02
    rec = load_participant(pfile)
    assert abs(rec["calibration"]["skin_thickness_um"] - 680.0) < 5.0


def test_bootstrap_intervals_and_help(tmp_path, capsys):
    sdir = make_session(tmp_path / "DATA", samples=(1, 4), duration_s=6.0)
    out = tmp_path / "o"
    assert main(["calibrate", str(sdir), "--out", str(out), "--interval", "bootstrap",
                 "--bootstrap-samples", "40", "--fit-skin-temperature", "none", "--seed", "3"]) == 0, \
        capsys.readouterr().err
    summary = json.loads((out / "fit.json").read_text())
    assert summary["interval_method"] == "bootstrap"
    L = summary["skin_thickness_m"]
    assert L["low"] < L["value"] < L["high"]
    with pytest.raises(SystemExit):
        main(["calibrate", "--help"])
    text = capsys.readouterr().out
    for option in ("--sensor-side", "--sample-thickness-um", "--write-participant", "--out",
                   "--fit-skin-temperature", "--interval"):
        assert option in text


def test_write_participant_refuses_another_participants_record(tmp_path, capsys):
    sdir = make_session(tmp_path / "DATA", samples=(1,), duration_s=5.0)
    other = tmp_path / "P02.json"
    shutil.copy(EXAMPLE.with_name("P02.json"), other)
    before = other.read_bytes()
    assert main(["calibrate", str(sdir), "--out", str(tmp_path / "o"), "--write-participant", str(other)]) == 2
    assert "P02.json: id: expected the session's participant 'P01'" in capsys.readouterr().err
    assert other.read_bytes() == before


def test_non_physical_trace_exit_2(tmp_path, capsys):
    sdir = make_session(tmp_path / "DATA", samples=(1, 2), duration_s=5.0)
    path = sdir / "traces" / "trial-002.csv"
    lines = path.read_text().splitlines()
    cells = lines[60].split(",")
    cells[2] = "48.5"                     # contact_C hotter than the 35 °C skin, 2 s after the touch
    lines[60] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    assert main(["calibrate", str(sdir), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "trial-002.csv: contact_C" in err and "non-physical" in err and "48.5" in err
