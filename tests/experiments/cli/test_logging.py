"""The ``thermocue`` logger: configured once by the command line (stderr, INFO; --quiet: WARNING),
silent when the library is used on its own."""
from __future__ import annotations

import logging
import re

import pandas as pd
import pytest

from experiments.cli import main
from experiments.cli.logs import configure_logging


def _cells(path):
    rows = [(g, m, r, 0.25 + 0.15 * (r - 1)) for g in "AB" for m in ("real", "simulated")
            for r in (1, 2, 3, 4)]
    pd.DataFrame(rows, columns=["group", "mode", "roughness_id", "p_correct"]).to_csv(path, index=False)


@pytest.mark.parametrize("quiet", [None, "before", "after"])
def test_progress_lines_on_stderr_unless_quiet(tmp_path, capsys, quiet):
    cells = tmp_path / "cells.csv"
    _cells(cells)
    args = ["power", "--cells", str(cells), "--n-per-group", "5", "--simulations", "3",
            "--test", "cluster-t", "--out", str(tmp_path / "out")]
    if quiet == "before":
        args = ["--quiet", *args]                    # before the command name
    elif quiet == "after":
        args = [*args, "--quiet"]
    assert main(args) == 0
    captured = capsys.readouterr()
    progress = [line for line in captured.err.splitlines() if re.match(r"\[ *\d+\.\d s\] ", line)]
    if quiet:
        assert progress == [] and captured.err == ""
    else:                                            # the steps, with the time so far
        assert any("n = 5 per group" in line for line in progress), captured.err
        assert any("wrote" in line for line in progress), captured.err
    assert "n per group for 80 % power" in captured.out      # results are not progress


def test_quiet_keeps_warnings_and_main_leaves_logging_as_it_was(capsys):
    logger = logging.getLogger("thermocue")
    before = (logger.level, list(logger.handlers))
    with configure_logging(quiet=True):
        logging.getLogger("thermocue.study").info("an info line")
        logging.getLogger("thermocue.analysis").warning("a warning line")
    with configure_logging():
        logging.getLogger("thermocue.study").info("shown while a command runs")
    assert (logger.level, list(logger.handlers)) == before
    logging.getLogger("thermocue.study").info("library use: not shown")
    assert capsys.readouterr().err == "a warning line\nshown while a command runs\n"


def test_study_progress_says_elapsed_and_eta(tmp_path, capsys):
    from experiments.simulation.figure9 import run_figure9_study
    with configure_logging():
        run_figure9_study(tmp_path, seed=2, participants=1, workers=1, analyze=False)
    err = capsys.readouterr().err
    assert re.search(r"^figure9: participant 1 of 1 done \(P01\); elapsed +\d+\.\d s, ETA +0\.0 s$",
                     err, re.M), err
    # one line per participant: the sessions' own lines (the group line, trial n of N) stay out
    assert [line for line in err.splitlines() if not line.startswith("figure9: ")] == [], err
    run_figure9_study(tmp_path / "again", seed=2, participants=1, workers=1, analyze=False)
    assert capsys.readouterr().err == ""             # the library alone configures nothing


def test_a_closed_stdout_is_one_line_not_a_traceback():
    """`thermocue displays --json | head -0`: the reader has gone before the output is written."""
    import subprocess
    import sys
    p = subprocess.Popen([sys.executable, "-m", "experiments", "displays", "--json"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait(timeout=60) == 1
    assert err == "thermocue displays: output closed early (broken pipe)\n", err
