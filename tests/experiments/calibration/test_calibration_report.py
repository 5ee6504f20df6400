"""The report files say what the fit found (tables, figure, fit.json)."""
import csv
import json

import numpy as np
import pytest

from experiments.calibration import fit_traces, synthetic_traces, write_report
from stimuli import contact_resistance


def test_report_files(tmp_path):
    ra = [12.5, 100.0]
    traces = synthetic_traces([float(contact_resistance(r * 1e-6)) for r in ra], 900e-6, roughness_um=ra,
                              duration_s=8.0, rng=np.random.default_rng(4))
    fit = fit_traces(traces, fit_skin_temperature="shared")
    write_report(fit, tmp_path, extra={"session": "S"})
    with open(tmp_path / "resistances.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["roughness_um"] for r in rows] == ["12.5", "100"]
    for r, p in zip(rows, fit.resistances()):
        assert float(r["R_m2K_W"]) == pytest.approx(p.value, rel=1e-5)
        assert float(r["R_low_m2K_W"]) < float(r["R_m2K_W"]) < float(r["R_high_m2K_W"])
        assert float(r["R_eq5_m2K_W"]) == pytest.approx(float(contact_resistance(float(r["roughness_um"]) * 1e-6)),
                                                      rel=1e-5)
        assert 0.01 < float(r["rms_residual_C"]) < 0.03          # the 0.02 °C noise put in
    with open(tmp_path / "skin.csv") as fh:
        skin = next(csv.DictReader(fh))
    assert float(skin["skin_thickness_um"]) == pytest.approx(fit.skin_thickness.value * 1e6, rel=1e-5)
    assert skin["skin_temperature_fitted"] == "shared"
    assert float(skin["skin_temperature_low_C"]) < 35.0 < float(skin["skin_temperature_high_C"])
    md = (tmp_path / "parameters.md").read_text()
    assert "skin thickness L (µm)" in md and "| 12.5 | 1 |" in md and "Jacobian rank 4 of 4" in md
    data = json.loads((tmp_path / "fit.json").read_text())
    assert data["session"] == "S" and data["level"] == 0.95 and len(data["traces"]) == 2
    assert (tmp_path / "residuals.png").read_bytes()[:4] == b"\x89PNG"
