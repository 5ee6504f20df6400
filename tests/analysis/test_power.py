"""Power simulation: size under no effect, power under a large one, the CLI."""
from __future__ import annotations

import sys
import types

import numpy as np
import pandas as pd
import pytest

from analysis import LogError, power_curve
from analysis.power import read_cells
from experiments.cli import main


def _cells(delta):
    """A above B by ``delta`` (probability) in real mode; equal in simulated mode."""
    base = {1: 0.35, 2: 0.45, 3: 0.55, 4: 0.6}
    out = {}
    for r, p in base.items():
        out[("A", "real", r)] = p + delta
        out[("B", "real", r)] = p
        out[("A", "simulated", r)] = out[("B", "simulated", r)] = p
    return out


def test_no_group_difference_rejects_at_about_alpha():
    res = power_curve(_cells(0.0), (10, 30), simulations=4000, participant_sd=0.6, seed=3)
    # 4000 cohorts: the rejection rate's SE is sqrt(0.05*0.95/4000) = 0.0034; Welch's t on
    # per-participant proportions is close to exact here (measured 0.044-0.049); band +-4.5 SE
    assert ((res.table["power"] > 0.035) & (res.table["power"] < 0.065)).all(), res.table
    assert (res.table["expected_difference_A_minus_B"] == 0).all()
    assert (res.table["mean_difference_A_minus_B"].abs() < 0.005).all()


def test_power_grows_with_cohort_size_and_matches_the_expected_difference():
    res = power_curve(_cells(0.25), (5, 10, 30), simulations=2000, participant_sd=0.0, seed=4)
    t = res.table
    assert t["power"].is_monotonic_increasing and t["power"].iloc[-1] > 0.99
    assert t["power"].iloc[0] < 0.9
    # sd 0: the expected difference is the mean of the cell differences exactly
    assert t["expected_difference_A_minus_B"].iloc[0] == pytest.approx(0.25, abs=1e-6)
    # simulated mean difference: SE ~ sqrt(2 * 0.25 / (12 n)) / sqrt(2000) < 0.003 at n = 5
    assert np.allclose(t["mean_difference_A_minus_B"], 0.25, atol=0.012)
    assert (t["power_low"] <= t["power"]).all() and (t["power"] <= t["power_high"]).all()


def test_gee_test_agrees_with_the_cluster_t_on_a_clear_effect():
    res = power_curve(_cells(0.3), (12,), simulations=30, participant_sd=0.3, test="gee", seed=5)
    assert res.table["power"].iloc[0] > 0.8 and res.settings["test"] == "gee"


def test_cells_validation_names_file_and_column(tmp_path):
    bad = tmp_path / "cells.csv"
    pd.DataFrame({"group": ["A"], "mode": ["real"], "roughness_id": [1]}).to_csv(bad, index=False)
    with pytest.raises(LogError, match=rf"^{bad}: p_correct: expected a column"):
        read_cells(bad)
    pd.DataFrame({"group": ["A"], "mode": ["real"], "roughness_id": [1],
                  "p_correct": [1.7]}).to_csv(bad, index=False)
    with pytest.raises(LogError, match=rf"^{bad}: p_correct: expected a probability"):
        read_cells(bad)
    with pytest.raises(LogError, match="groups A and B"):
        power_curve({("A", "real", 1): 0.5}, (5,), simulations=10)


def _write_cells(path, cells):
    pd.DataFrame([(g, m, r, p) for (g, m, r), p in cells.items()],
                 columns=["group", "mode", "roughness_id", "p_correct"]).to_csv(path, index=False)


def test_cli_power_with_cells_file(tmp_path, capsys):
    cells = tmp_path / "cells.csv"
    _write_cells(cells, _cells(0.2))
    out = tmp_path / "power"
    status = main(["power", "--cells", str(cells), "--n-per-group", "5,15",
                   "--simulations", "300", "--out", str(out)])
    assert status == 0
    table = pd.read_csv(out / "power.csv")
    assert list(table["n_per_group"]) == [5, 15] and (table["simulations"] == 300).all()
    assert (out / "power.png").stat().st_size > 10_000
    err = capsys.readouterr().err
    assert "n = 5 per group" in err and "n = 15 per group" in err


def test_cli_power_uses_the_participant_model_when_no_cells(tmp_path, monkeypatch, capsys):
    fake = types.ModuleType("experiments.participant_model")
    fake.predicted_cell_probabilities = lambda: pd.DataFrame(
        [(g, m, r, p) for (g, m, r), p in _cells(0.1).items()],
        columns=["group", "mode", "roughness_id", "p_correct"])
    monkeypatch.setitem(sys.modules, "experiments.participant_model", fake)
    status = main(["power", "--n-per-group", "6", "--simulations", "100", "--out", str(tmp_path)])
    assert status == 0
    assert "simulated-participant model" in capsys.readouterr().err
    cells = pd.read_csv(tmp_path / "cells.csv")
    assert len(cells) == 16


def test_cli_power_bad_input_exits_2(tmp_path, monkeypatch, capsys):
    assert main(["power", "--n-per-group", "5,x", "--cells", "c.csv", "--out", str(tmp_path)]) == 2
    assert "--n-per-group: expected comma-separated integers" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "experiments.participant_model", None)   # import fails
    assert main(["power", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("thermocue power: --cells: expected a CSV") and "\n" not in err
