"""Fixtures of the analysis tests: ``study`` writes a synthetic study (:mod:`_study_writer`)."""
from __future__ import annotations

import pytest

from _study_writer import paper_like_cells, write_study


@pytest.fixture
def study(tmp_path):
    """Factory: ``study(cells=None, **options) -> (data_dir, cells)``."""
    def make(cells=None, name="data", **options):
        cells = paper_like_cells() if cells is None else cells
        data = tmp_path / name
        write_study(data, cells, **options)
        return data, cells
    return make
