"""The one column table of ``trials.csv`` (sessionfiles.columns) and what is derived from it."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from sessionfiles import columns
from sessionfiles.columns import TRIALS, Column, markdown_table

ROOT = Path(__file__).resolve().parents[2]


def test_the_docs_table_is_the_generated_one():
    text = (ROOT / "docs" / "session.md").read_text(encoding="utf-8")
    found = re.search(r"<!-- trials columns: begin [^>]*-->\n(.*?)<!-- trials columns: end -->",
                      text, re.S)
    assert found, "docs/session.md: expected the generated table of the trials columns"
    assert found.group(1).rstrip("\n") == markdown_table()


def test_every_column_is_in_the_docs_table_once():
    rows = markdown_table().splitlines()[2:]
    assert [re.match(r"\| `([^`]+)` \|", r).group(1) for r in rows] == [c.name for c in TRIALS]


def test_names_are_unique_and_units_are_named_in_the_column():
    assert len({c.name for c in TRIALS}) == len(TRIALS)
    suffix = {"um": "_um", "s": "_s", "degC": "_C", "N": "_N", "m^2*K/W": "_m2K_W"}
    for c in TRIALS:
        if c.unit in suffix:
            assert c.name.endswith(suffix[c.unit]), c.name


def test_a_bad_entry_is_refused_with_its_name():
    with pytest.raises(ValueError, match="'x'"):
        Column("x", "identity", "bool", meaning="a flag")
    with pytest.raises(ValueError, match="'y'"):
        Column("y", "nowhere", "str", meaning="text")


def test_derived_lists_follow_the_table():
    from sessionfiles.logformat import (COLUMN_DECIMALS, OPTIONAL_COLUMNS, PSYCHOPY_COLUMNS,
                                        REQUIRED_COLUMNS, TRIAL_COLUMNS)
    from sessionfiles.session_reader import DOMAIN
    assert TRIAL_COLUMNS[:3] == ("participant", "session", "group")
    assert TRIAL_COLUMNS[-1] == "contact_force_N" and len(TRIAL_COLUMNS) == 50
    assert PSYCHOPY_COLUMNS == ("date", "expName", "expStart", "psychopyVersion", "frameRate",
                                "thisN", "thisRepN")
    # analysis' order of the columns it reads is all_trials.csv's (kept)
    assert REQUIRED_COLUMNS == ("participant", "group", "session", "block", "trial_index", "mode",
                                "roughness_id", "response_id", "correct", "status")
    assert list(OPTIONAL_COLUMNS)[:3] == ["attempt", "roughness_um", "repetition"]
    assert OPTIONAL_COLUMNS["skin_temperature_in_range"] == "flag"
    assert COLUMN_DECIMALS["skin_temperature_C"] == 2 and COLUMN_DECIMALS["rt_s"] == 4
    assert DOMAIN["trial_index"] == ("int", 1, None, "an integer >= 1")
    assert DOMAIN["correct"][0] == "flag"
    assert set(columns.QUIET_COLUMNS) == {"answer_mode", "answer_keyed_after_cue_s",
                                          "skin_temperature_C", "skin_temperature_in_range",
                                          "contact_force_N", "abort_reason"}


def test_every_column_analysis_reads_has_a_codebook_entry():
    assert {c.name for c in TRIALS if c.analysis} == set(columns.CODEBOOK)
    from analysis.exports import COLUMNS
    assert all(COLUMNS[name] == entry for name, entry in columns.CODEBOOK.items())
