import csv

import numpy as np
import pytest

from experiments.reproduction.model_figures import FIGURES, METHODS, figure_rows
from experiments.cli import main


def test_fig3_exact_receptor_starts_at_skin_and_drops():
    header, rows = figure_rows("fig3")
    assert header == ["time_s", "epidermis_um", "R_m2K_per_W", "method", "receptor_C"]
    exact = [r for r in rows if r[3] == "exact"]
    assert {r[3] for r in rows} == set(METHODS)
    assert all(r[4] == 36.0 for r in exact if r[0] == 0.0)
    assert all(20.0 < r[4] < 36.0 for r in exact if r[0] > 0)


def test_fig4b_exact_rises_with_roughness():
    header, rows = figure_rows("fig4b")
    y = [r[3] for r in rows if r[2] == "exact"]
    assert np.all(np.diff(y) > 0)


@pytest.mark.slow
def test_cli_figures(tmp_path):
    assert main(["reproduce", "figures", "--out", str(tmp_path)]) == 0
    for name in FIGURES:
        assert (tmp_path / f"{name}.png").stat().st_size > 1000
        with open(tmp_path / f"{name}.csv") as fh:
            head = next(csv.reader(fh))
        assert any(h.endswith(("_C", "psi")) for h in head)
