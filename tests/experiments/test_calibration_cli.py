"""`thermocue calibrate` on session directories built like the session engine writes them.

The traces are the exact model + the stated noise (0.02 °C white, 1 mK quantisation) at
20 Hz, with 1 s before the touch (forces 0, the sensor on the sample reads the sample).
"""
import csv
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from experiments.calibration import ContactSetup, Sensor, sensor_temperature
from experiments.cli import main
from experiments.protocol import load_protocol
from participants_schema import load_participant
from stimuli import Skin, contact_resistance, material

EXAMPLE = Path(__file__).resolve().parents[2] / "participants" / "examples" / "P01.json"
T_S0, T_M0, L_TRUE = 35.0, 24.0, 700e-6
# DESIGN.md's session-directory columns (traces/trial-NNN.csv and the trials table)
TRACE_COLUMNS = ["time_s", "target_C", "contact_C", "ambient_C", "finger_C",
                 "force1_N", "force2_N", "force3_N", "force4_N", "state"]
TRIAL_COLUMNS = ["participant", "group", "session", "block", "trial_index", "mode", "roughness_id",
                 "roughness_um", "repetition", "response_id", "correct", "rt_s", "status",
                 "tracking_rms_C"]


def make_session(root: Path, *, duration_s=25.0, samples=(1, 2, 3, 4), rate=20.0, flat=False,
                 drop_column=None, half_space=False, skin_thickness=L_TRUE, seed=0):
    protocol = load_protocol("interface_temperature")
    record = json.loads(EXAMPLE.read_text())
    sdir = root / "P01" / "S1"
    (sdir / "traces").mkdir(parents=True)
    (sdir / "session.json").write_text(json.dumps({
        "format": "thermocue-session/1", "participant_id": "P01", "participant": record,
        "protocol_name": protocol.name, "protocol_hash": protocol.hash, "protocol": protocol.data}))
    rng = np.random.default_rng(seed)
    steel = material("stainless_steel", thickness=None if half_space else 3e-3)
    setup = ContactSetup(steel, Sensor("material"))
    rows = []
    for i, sid in enumerate(samples, start=1):
        ra = protocol.sample(sid).roughness_um
        R = float(contact_resistance(ra * 1e-6))
        t = np.arange(0, int(round((duration_s + 1.0) * rate))) / rate
        touching = t >= 1.0
        y = sensor_temperature(t - 1.0, R, skin_thickness, T_S0, T_M0, setup)
        if flat:
            y = np.full_like(t, T_M0)
        y = np.round((y + 0.02 * rng.standard_normal(t.size)) * 1000) / 1000
        name = f"trial-{i:03d}.csv"
        with open(sdir / "traces" / name, "w", newline="") as fh:
            w = csv.writer(fh)
            cols = [c for c in TRACE_COLUMNS if c != drop_column]
            w.writerow(cols)
            for k in range(t.size):
                f = 0.625 if touching[k] else 0.0
                vals = {"time_s": t[k], "target_C": "", "contact_C": y[k], "ambient_C": 24.0,
                        "finger_C": T_S0, "force1_N": f, "force2_N": f, "force3_N": f, "force4_N": f,
                        "state": "record" if touching[k] else "armed"}
                w.writerow([vals[c] for c in cols])
        rows.append({"participant": "P01", "session": "S1", "block": "contact", "trial_index": i,
                     "mode": "real", "roughness_id": sid, "roughness_um": ra, "repetition": 1,
                     "status": "ok"})   # the trace is found as traces/trial-NNN.csv
    with open(sdir / "trials.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, TRIAL_COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow(r)
    return sdir


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
    status = main(["run", str(proto), "--participant", str(pfile), "--display", "emulator://?clock=virtual",
                   "--responder", "simulated", "--data", str(data), "--seed", "1"])
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
        truth = float(contact_resistance(s["roughness_um"] * 1e-6, skin=skin, material=steel))
        half = (np.log(s["high_m2K_W"]) - np.log(s["low_m2K_W"])) / 2
        assert abs(np.log(s["resistance_m2K_W"] / truth)) <= 2 * half, (s, truth)
        assert abs(s["resistance_m2K_W"] / truth - 1) < 0.02
    rec = load_participant(pfile)
    assert abs(rec["calibration"]["skin_thickness_um"] - 680.0) < 5.0
