"""The report's "Model decisions" section, from the profile_uploaded events."""
from __future__ import annotations

import json

import pandas as pd

from analysis import analyze
from analysis.model_decisions import model_decisions
from _study_writer import paper_like_cells, write_study


def _plan(bound_sensor, roughness):
    return {"model": "exact, slab, homogeneous skin", "bound_K": 1e-11, "tolerance_K": 0.005,
            "decisions": [{"effect": "sensor", "included": False, "bound_K": bound_sensor,
                           "note": "tau x max |dT/dt|"},
                          {"effect": "perfusion", "included": False, "bound_K": 0.002,
                           "note": "Pennes perfusion of the dermis"},
                          {"effect": "slab", "included": True, "bound_K": None,
                           "note": f"kept without evaluation ({roughness})"}]}


def _add_uploads(folder, bounds, damaged=False):
    with open(folder / "events.jsonl", "a") as fh:
        for i, b in enumerate(bounds):
            # each profile uploaded twice (two trials): counted once
            for _ in range(2):
                fh.write(json.dumps({"event": "profile_uploaded", "trial_index": 100 + i,
                                     "content_hash": f"h{i}", "parameters": {"plan": _plan(b, i)}})
                         + "\n")
        if damaged:
            fh.write("{damaged line\n")


def test_decisions_are_gathered_per_distinct_profile(tmp_path):
    write_study(tmp_path / "d", paper_like_cells(), n_per_group=1, reps=1)
    folders = sorted(p.parent for p in (tmp_path / "d").glob("*/*/events.jsonl"))
    _add_uploads(folders[0], [0.001, 0.004], damaged=True)
    _add_uploads(folders[1], [0.003])
    table = model_decisions(folders).set_index(["effect", "decision"])
    assert table.loc[("sensor", "neglected"), "n_profiles"] == 3
    assert table.loc[("sensor", "neglected"), "max_bound_K"] == 0.004
    assert table.loc[("perfusion", "neglected"), "max_bound_K"] == 0.002
    assert table.loc[("slab", "kept"), "n_profiles"] == 3
    assert pd.isna(table.loc[("slab", "kept"), "max_bound_K"])
    assert (table["tolerance_K"] == 0.005).all()


def test_report_has_a_model_decisions_section(tmp_path):
    write_study(tmp_path / "d", paper_like_cells(), n_per_group=3, reps=2, seed=4)
    for folder in sorted(p.parent for p in (tmp_path / "d").glob("*/*/events.jsonl")):
        _add_uploads(folder, [0.001, 0.004])
    analyze(tmp_path / "d", tmp_path / "out", n_boot=50, mixed=False)
    report = (tmp_path / "out" / "report.md").read_text()
    section = report.split("## Model decisions", 1)[1].split("\n## ", 1)[0]
    assert "Neglected: sensor (<= 0.004 K), perfusion (<= 0.002 K)." in section
    assert "| slab | kept |" in section.replace("| exact, slab, homogeneous skin ", "")
    csv = pd.read_csv(tmp_path / "out" / "model_decisions.csv")
    assert set(csv["effect"]) == {"sensor", "perfusion", "slab"}
    # sessions without planner decisions say so
    write_study(tmp_path / "old", paper_like_cells(), n_per_group=3, reps=2, seed=4)
    analyze(tmp_path / "old", tmp_path / "out_old", n_boot=50, mixed=False)
    assert "No simulated profile with the scene planner's decisions" in (
        tmp_path / "out_old" / "report.md").read_text()


def test_a_profile_played_by_the_method_asked_for_is_named_not_dropped(tmp_path):
    # the printed-Eq. 7 replay's profiles record their method, not planner decisions: the
    # report names that model rather than leaving it out
    write_study(tmp_path / "d", paper_like_cells(), n_per_group=1, reps=1)
    folder = sorted(p.parent for p in (tmp_path / "d").glob("*/*/events.jsonl"))[0]
    plan = {"model": "paper-as-printed, material side, half-space (as asked, not planned)",
            "method": "paper-as-printed", "bound_K": 0.66, "tolerance_K": None,
            "note": "method asked for by name", "planner": _plan(0.0, 0)}
    with open(folder / "events.jsonl", "a") as fh:
        fh.write(json.dumps({"event": "profile_uploaded", "content_hash": "p1",
                             "parameters": {"plan": plan}}) + "\n")
    table = model_decisions([folder])
    (row,) = table[table["decision"] == "as asked"].itertuples()
    assert row.model == plan["model"] and row.max_bound_K == 0.66 and row.n_profiles == 1
    from analysis.model_decisions import model_decisions_markdown
    text = "\n".join(model_decisions_markdown(table, lambda t: t.to_string()))
    assert "Computed by the method asked for, not planned: paper-as-printed" in text
