"""Every exported column is a valid R identifier in snake_case with a codebook entry, as R reads it.

R's ``read.csv(check.names = TRUE)`` (the default) renames any column that is not a syntactic
name ("time-out" becomes "time.out"); the test reads every CSV of an analysis in R and compares
the names R ends up with to the header and to ``codebook.json``.
"""
from __future__ import annotations

import json
import re
import shutil
import subprocess

import pandas as pd
import pytest

from analysis import analyze

#: lower-case words joined by underscores; unit and group suffixes keep their case (_C, _N, _A)
SNAKE = re.compile(r"^[a-z][a-z0-9]*(_[A-Za-z0-9]+)*$")

R_NAMES = r"""
args <- commandArgs(trailingOnly = TRUE)
for (f in args) {
  d <- read.csv(f, check.names = TRUE, nrows = 5)
  cat(basename(f), paste(names(d), collapse = ","), "\n", sep = "\t")
}
"""


@pytest.fixture(scope="module")
def out(tmp_path_factory):
    from _study_writer import paper_like_cells, write_study
    tmp = tmp_path_factory.mktemp("tidy")
    write_study(tmp / "data", paper_like_cells(), n_per_group=3, sigma=0.5, seed=5)
    analyze(tmp / "data", tmp / "out", n_boot=20)
    return tmp / "out"


def test_every_column_is_snake_case_with_a_codebook_entry(out):
    book = json.loads((out / "codebook.json").read_text())
    files = sorted(out.glob("*.csv"))
    assert {"missing.csv", "fidelity.csv", "tests.csv", "all_trials.csv"} <= {f.name for f in files}
    for f in files:
        header = list(pd.read_csv(f, nrows=0).columns)
        bad = [c for c in header if not SNAKE.match(c)]
        assert not bad, f"{f.name}: columns not in snake_case: {bad}"
        assert list(book[f.name]) == header, f.name
        assert all(v["unit"] and v["meaning"] for v in book[f.name].values()), f.name


@pytest.mark.skipif(shutil.which("Rscript") is None, reason="Rscript missing: ./scripts/setup")
def test_r_reads_every_export_with_the_names_written(out, tmp_path):
    script = tmp_path / "names.R"
    script.write_text(R_NAMES)
    files = [str(f) for f in sorted(out.glob("*.csv"))
             if pd.read_csv(f, nrows=0).shape[1] > 0]
    done = subprocess.run(["Rscript", str(script), *files], capture_output=True, text=True,
                          timeout=240, check=True)
    read = {}
    for line in done.stdout.splitlines():
        name, _, columns = line.partition("\t")
        read[name] = columns.strip().split(",")
    assert set(read) == {f.rsplit("/", 1)[1] for f in files}
    for f in files:
        name = f.rsplit("/", 1)[1]
        header = list(pd.read_csv(f, nrows=0).columns)
        assert read[name] == header, f"{name}: R renamed {set(header) - set(read[name])}"
