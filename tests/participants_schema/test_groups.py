"""Group assignment by skin thickness: the paper's 800 µm rule, boundary and layer warnings."""
from __future__ import annotations

import dataclasses
import json

import pytest

from participants_schema import GroupAssignment, GroupRule, ParticipantError, assign_group


def rec(total, epidermis=None, dermis=None, **extra):
    st = {"total_um": total, "method": "bio-speckle"}
    if epidermis is not None:
        st["epidermis_um"] = epidermis
    if dermis is not None:
        st["dermis_um"] = dermis
    return {"id": "P01", "skin_thickness": st, "consent": {"given": True, "date": "2026-11-20"}, **extra}


@pytest.mark.parametrize("total, group, margin", [
    (600, "A", -200), (750, "A", -50), (799.9, "A", -0.1), (800, "B", 0), (900, "B", 100), (1200, "B", 400),
])
def test_paper_rule(total, group, margin):
    g = assign_group(rec(total))
    assert isinstance(g, GroupAssignment)
    assert g.group == group
    assert g.thickness_um == total
    assert g.margin_um == pytest.approx(margin)


def test_clear_cases_have_no_warnings():
    assert assign_group(rec(680, 270, 410)).warnings == ()
    assert assign_group(rec(1050, 420, 630)).warnings == ()
    assert not assign_group(rec(680)).near_boundary


def test_near_boundary_is_reported():
    g = assign_group(rec(780))
    assert g.group == "A" and g.near_boundary
    assert len(g.warnings) == 1 and "within 50 µm of the 800 µm threshold (20 µm below)" in g.warnings[0]
    assert "WARNING" in g.describe()
    g = assign_group(rec(850))           # exactly the margin counts as near
    assert g.near_boundary and g.group == "B"
    assert not assign_group(rec(851)).near_boundary
    assert not assign_group(rec(749)).near_boundary


def test_at_threshold_goes_above_with_warning():
    g = assign_group(rec(800))
    assert g.group == "B"
    assert "exactly at the 800 µm threshold" in g.warnings[0]


def test_margin_is_configurable():
    assert assign_group(rec(780), GroupRule(margin_um=10)).warnings == ()
    assert assign_group(rec(700), GroupRule(margin_um=150)).near_boundary


def test_inconsistent_layers_are_reported():
    g = assign_group(rec(700, 300, 460))     # 760 != 700
    assert g.group == "A"
    assert any("epidermis_um + dermis_um = 760" in w for w in g.warnings)


def test_calibration_in_other_group_is_reported():
    g = assign_group(rec(780, calibration={"skin_thickness_um": 820}))
    assert any("would put the participant in group B" in w for w in g.warnings)


def test_rule_forms():
    custom = {"threshold_um": 900.0, "margin_um": 0.0, "below": "thin", "above": "thick"}
    assert assign_group(rec(850), custom).group == "thin"
    assert assign_group(rec(950), GroupRule(**custom)).group == "thick"
    from experiments.protocol import load_protocol

    rule = load_protocol("roughness_recognition").grouping
    assert assign_group(rec(700), rule).group == "A"
    assert assign_group(rec(1000), rule).group == "B"


@pytest.mark.parametrize("bad", [
    {"threshold_um": -1.0}, {"margin_um": "x"}, {"below": "A", "above": "A"}, {"colour": "red"},
])
def test_bad_rule(bad):
    with pytest.raises(ValueError):
        assign_group(rec(700), bad)


def test_missing_thickness():
    with pytest.raises(ParticipantError, match="P01: skin_thickness.total_um: expected a number > 0, got nothing"):
        assign_group({"id": "P01"})


def test_to_dict_is_json_ready():

    d = assign_group(rec(780)).to_dict()
    assert json.loads(json.dumps(d)) == d
    assert d["rule"] == dataclasses.asdict(GroupRule())
