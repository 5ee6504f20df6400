"""Group assignment from fingertip skin thickness.

The paper splits its participants at 800 µm: group A thinner (600-750 µm measured), group B
thicker (about 900-1200 µm).  The protocol states the rule (:class:`GroupRule`); a record
close to the threshold, or whose skin layers do not add up, is assigned all the same and
the reasons for doubt are returned with the group, so the experimenter sees them.
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, Mapping

from participants_schema.errors import ParticipantError
from participants_schema.validate import participant_warnings

__all__ = ["GroupRule", "GroupAssignment", "assign_group"]


@dataclass(frozen=True)
class GroupRule:
    """How skin thickness decides the group.

    Parameters
    ----------
    threshold_um : float, µm
        Thickness ``< threshold_um`` goes to ``below``, anything else to ``above``.
    margin_um : float, µm
        Records within this distance of the threshold get a warning.
    below, above : str
        Group names (the paper: ``"A"`` thinner, ``"B"`` thicker).
    """

    threshold_um: float = 800.0
    margin_um: float = 50.0
    below: str = "A"
    above: str = "B"

    def __post_init__(self):
        for name in ("threshold_um", "margin_um"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not v >= 0:
                raise ValueError(f"GroupRule: {name}: expected a number ≥ 0, got {v!r}")
        if self.threshold_um <= 0:
            raise ValueError(f"GroupRule: threshold_um: expected a number > 0, got {self.threshold_um!r}")
        if self.below == self.above:
            raise ValueError(f"GroupRule: above: expected a name different from below, got {self.above!r}")

    def group_of(self, thickness_um: float) -> str:
        """Return the group for a thickness in µm."""
        return self.below if thickness_um < self.threshold_um else self.above

    @classmethod
    def coerce(cls, rule: Any) -> "GroupRule":
        """A ``GroupRule`` from a rule, a mapping of its fields, an object with them, or None."""
        if rule is None:
            return cls()
        if isinstance(rule, cls):
            return rule
        names = [f.name for f in fields(cls)]
        if isinstance(rule, Mapping):
            unknown = sorted(set(rule) - set(names))
            if unknown:
                raise ValueError(f"GroupRule: {unknown[0]}: expected one of {', '.join(names)}, "
                                 f"got an unknown key")
            return cls(**dict(rule))
        if all(hasattr(rule, n) for n in names):
            return cls(**{n: getattr(rule, n) for n in names})
        raise TypeError(f"GroupRule: expected a GroupRule, a mapping or None, got {rule!r}")


@dataclass(frozen=True)
class GroupAssignment:
    """The group of one participant, with the reasons to double-check it.

    Attributes
    ----------
    group : str
        ``rule.below`` or ``rule.above`` (``"A"`` or ``"B"``).
    thickness_um : float, µm
        The thickness used: ``skin_thickness.total_um``.
    margin_um : float, µm
        ``thickness_um - rule.threshold_um`` (negative: thinner than the threshold).
    warnings : tuple of str
        Boundary, layer and plausibility remarks; empty when all is clear.
    near_boundary : bool
        ``abs(margin_um) <= rule.margin_um``.
    rule : GroupRule
    """

    group: str
    thickness_um: float
    margin_um: float
    warnings: tuple[str, ...] = ()
    near_boundary: bool = False
    rule: GroupRule = GroupRule()

    def describe(self) -> str:
        """One line for the experimenter, e.g. ``"group A: 720 µm, 80 µm below the 800 µm threshold"``."""
        side = "below" if self.margin_um < 0 else "above" if self.margin_um > 0 else "at"
        text = (f"group {self.group}: {self.thickness_um:g} µm, {abs(self.margin_um):g} µm {side} "
                f"the {self.rule.threshold_um:g} µm threshold")
        if side == "at":
            text = (f"group {self.group}: {self.thickness_um:g} µm, exactly at the "
                    f"{self.rule.threshold_um:g} µm threshold")
        return text + "".join(f"; WARNING: {w}" for w in self.warnings)

    def to_dict(self) -> dict:
        """JSON-ready form (for session.json)."""
        return {"group": self.group, "thickness_um": self.thickness_um,
                "margin_um": self.margin_um, "warnings": list(self.warnings),
                "near_boundary": self.near_boundary,
                "rule": {f.name: getattr(self.rule, f.name) for f in fields(GroupRule)}}


def assign_group(record: Mapping[str, Any], rule: Any = None) -> GroupAssignment:
    """Assign a participant to a group by fingertip skin thickness.

    Parameters
    ----------
    record : Participant or dict
        A participant (:meth:`participants_schema.Participant.read`) or its validated JSON
        record (:func:`participants_schema.load_participant`).
    rule : GroupRule, mapping or None
        The protocol's rule (``Protocol.grouping``); None means the paper's
        (800 µm threshold, 50 µm margin, A thinner, B thicker).

    Returns
    -------
    GroupAssignment

    Raises
    ------
    ParticipantError
        If the record has no ``skin_thickness.total_um``.

    Notes
    -----
    Warnings are given when the thickness lies within ``rule.margin_um`` of the threshold
    (exactly at the threshold the record goes to ``rule.above``), when the layers do not
    sum to the total, when the thickness is unusual for a fingertip, and when a
    calibration-fitted thickness (``calibration.skin_thickness_um``) falls in the other group.

    Examples
    --------
    >>> rec = {"id": "P01", "skin_thickness": {"total_um": 780.0, "method": "bio-speckle"}}
    >>> g = assign_group(rec)
    >>> g.group, g.margin_um, g.near_boundary
    ('A', -20.0, True)
    """
    rule = GroupRule.coerce(rule)
    if hasattr(record, "record") and not isinstance(record, Mapping):    # a Participant
        record = record.record()
    source = str(record.get("id", "<participant>")) if isinstance(record, Mapping) else "<participant>"
    try:
        thickness = record["skin_thickness"]["total_um"]
    except (KeyError, TypeError):
        raise ParticipantError(f"{source}: skin_thickness.total_um: expected a number > 0, got nothing",
                               source=source, field="skin_thickness.total_um") from None
    if isinstance(thickness, bool) or not isinstance(thickness, (int, float)) or not thickness > 0:
        raise ParticipantError(f"{source}: skin_thickness.total_um: expected a number > 0, got {thickness!r}",
                               source=source, field="skin_thickness.total_um")
    thickness = float(thickness)
    group = rule.group_of(thickness)
    margin = thickness - rule.threshold_um
    near = abs(margin) <= rule.margin_um
    warnings = []
    if margin == 0:
        warnings.append(f"skin thickness {thickness:g} µm is exactly at the {rule.threshold_um:g} µm "
                        f"threshold; assigned to group {group}")
    elif near:
        warnings.append(f"skin thickness {thickness:g} µm is within {rule.margin_um:g} µm of the "
                        f"{rule.threshold_um:g} µm threshold ({abs(margin):g} µm "
                        f"{'below' if margin < 0 else 'above'}); group {group} is uncertain")
    try:
        warnings.extend(participant_warnings(record))
    except (KeyError, TypeError):  # an unvalidated record: the boundary check is still useful
        pass
    cal = record.get("calibration") or {}
    cal_t = cal.get("skin_thickness_um") if isinstance(cal, Mapping) else None
    if isinstance(cal_t, (int, float)) and not isinstance(cal_t, bool) and rule.group_of(cal_t) != group:
        warnings.append(f"calibration.skin_thickness_um = {cal_t:g} µm would put the participant in "
                        f"group {rule.group_of(cal_t)}, the measured {thickness:g} µm in group {group}")
    return GroupAssignment(group=group, thickness_um=thickness, margin_um=margin,
                           warnings=tuple(warnings), near_boundary=near, rule=rule)
