"""How parsed protocol content (a TOML file's tables, or ``session.json``'s copy) becomes a
:class:`~experiments.protocol.model.Protocol`.

Types, bounds, required and unknown keys are declared in ``protocol.schema.json`` beside this
module and checked by the one validation stack (:mod:`participants_schema.schema_check`); what
is left here is turning the checked tables into the dataclasses (numbers as floats, the defaults
of the optional keys) and the cross-field rules a schema cannot say (max ≥ min, record ≤
contact, ids and names used once, a simulated block needs ``[simulation]``, ...).

Every problem raises :class:`experiments.errors.ProtocolError` with one line naming the file and
the field.
"""
from __future__ import annotations

import copy
import hashlib
from pathlib import Path
from typing import Any, Mapping

from experiments.errors import ProtocolError
from experiments.protocol.hashing import canonical_json
from experiments.protocol.limits import MAX_TRIALS
from experiments.protocol.model import (AnalysisSettings, Block, ContactSettings, DisplaySettings,
                                        Environment, Presentation, Protocol, Sample, SampleMaterial,
                                        Simulation)
from participants_schema import GroupRule
from participants_schema.schema_check import check_against_schema, load_schema_file

#: The protocol's JSON Schema (Draft 2020-12): every table, key, type, bound and unit.
SCHEMA_PATH = Path(__file__).with_name("protocol.schema.json")

#: ``[presentation] answer_mode`` values: the participant keys the answer, or says it.
ANSWER_MODES = ("keyed", "spoken")


class _Fields:
    """The checked tables of one protocol file, and its one-line error."""

    def __init__(self, source: str, data: Mapping[str, Any]):
        self.source, self.data = source, data
        self.schema = load_schema_file(str(SCHEMA_PATH))["properties"]

    def fail(self, field: str, what: str, got: Any) -> None:
        raise ProtocolError(f"{self.source}: {field}: expected {what}, got {got}")

    def table(self, key: str, item: Mapping[str, Any] | None = None) -> dict | None:
        """Table ``key`` (or one ``item`` of the array ``key``), numbers as floats; None if absent."""
        schema = self.schema[key]
        table = item if item is not None else self.data.get(key)
        if table is None:
            return None
        props = (schema["items"] if item is not None else schema)["properties"]
        return {k: float(v) if props[k]["type"] == "number" else v for k, v in table.items()}


def _f(x: float) -> str:
    return f"{x:g}"


def _check_unique(t: _Fields, key: str, field: str, what: str) -> None:
    seen = set()
    for i, item in enumerate(t.data[key]):
        value = item.get(field, item.get("id")) if field == "label" else item[field]
        value = str(value) if field == "label" else value
        if value in seen:
            t.fail(f"{key}[{i}].{field}", f"{what} not used by another {key[:-1]}", repr(value))
        seen.add(value)


def _samples(t: _Fields) -> tuple[Sample, ...]:
    _check_unique(t, "samples", "id", "an id")
    _check_unique(t, "samples", "label", "a label")
    return tuple(Sample(s["id"], s.get("label", str(s["id"])), s["roughness_um"])
                 for s in (t.table("samples", item) for item in t.data["samples"]))


def _blocks(t: _Fields, samples: tuple[Sample, ...], simulated_ok: bool) -> tuple[Block, ...]:
    ids = [s.id for s in samples]
    _check_unique(t, "blocks", "name", "a name")
    out = []
    for i, b in enumerate(t.data["blocks"]):
        at = f"blocks[{i}]"
        chosen = b.get("samples", list(ids))
        for c in chosen:
            if c not in ids:
                t.fail(f"{at}.samples", f"ids of listed samples ({', '.join(map(str, ids))})", c)
        if len(set(chosen)) != len(chosen):
            t.fail(f"{at}.samples", "each sample id once", chosen)
        response = b.get("response", True)
        scored = b.get("scored", response)
        if scored and not response:
            t.fail(f"{at}.scored", "false when response = false", scored)
        nir = b.get("no_immediate_repeats", False)
        if nir and len(chosen) < 2 and b["repetitions"] > 1:
            t.fail(f"{at}.no_immediate_repeats", "false with a single sample", nir)
        if b["mode"] == "simulated" and not simulated_ok:
            t.fail("simulation", f"a [simulation] table because {at} is simulated", "nothing")
        out.append(Block(b["name"], b["mode"], b["repetitions"], b.get("order", "random"), tuple(chosen),
                         scored, b.get("feedback", False), response, nir, b.get("instructions", "")))
    n_trials = sum(b.n_trials for b in out)
    if n_trials > MAX_TRIALS:
        t.fail("blocks", f"at most {MAX_TRIALS} trials in all (samples × repetitions; a session "
                         f"is hours, not days)", f"{n_trials} trials")
    return tuple(out)


def _authors(t: _Fields) -> tuple[str, ...]:
    listed = [a.strip() for a in t.data["protocol"].get("authors", [])]
    if len(set(listed)) != len(listed):
        t.fail("protocol.authors", "each author once", t.data["protocol"]["authors"])
    return tuple(listed)


def _ranges(t: _Fields, env: Environment, contact: ContactSettings, display: DisplaySettings) -> None:
    if env.skin_temperature_max_C < env.skin_temperature_min_C:
        t.fail("environment.skin_temperature_max_C", f"a number ≥ skin_temperature_min_C "
               f"({_f(env.skin_temperature_min_C)})", env.skin_temperature_max_C)
    if contact.record_s > contact.max_contact_s:
        t.fail("contact.record_s", f"a number ≤ max_contact_s ({_f(contact.max_contact_s)})", contact.record_s)
    if not display.max_C > display.min_C:
        t.fail("display.max_C", f"a number > min_C ({_f(display.min_C)})", display.max_C)
    if not display.min_C <= display.neutral_C <= display.max_C:
        t.fail("display.neutral_C", f"a number from min_C to max_C ({_f(display.min_C)}-"
               f"{_f(display.max_C)})", display.neutral_C)


def _grouping(t: _Fields) -> GroupRule | None:
    g = t.table("grouping")
    if g is None:
        return None
    rule = GroupRule(**{"below": "A", "above": "B", "margin_um": 50.0, **g})
    if rule.above == rule.below:
        t.fail("grouping.above", "a group name different from below", repr(rule.above))
    return rule


def _simulation(t: _Fields, grouping: GroupRule | None, display: DisplaySettings) -> Simulation | None:
    s = t.table("simulation")
    if s is None:
        return None
    s = {"skin_thickness": "group", "dermis_fraction": 0.6, "rate_Hz": 100.0, "resolution_C": 0.01,
         "method": "exact", **s}
    s["group_skin_thickness_um"] = {k: float(v) for k, v in s.get("group_skin_thickness_um", {}).items()}
    if s["skin_thickness"] == "group":
        if grouping is None:
            t.fail("simulation.skin_thickness", "'participant' when the protocol has no [grouping]", "'group'")
        if "group_skin_thickness_um" not in t.data["simulation"]:
            t.fail("simulation.group_skin_thickness_um", "a table", "nothing (the key is required)")
        for grp in (grouping.below, grouping.above):
            if grp not in s["group_skin_thickness_um"]:
                t.fail(f"simulation.group_skin_thickness_um.{grp}", "the group's skin thickness in µm, "
                       "a number > 0", "nothing (the key is required)")
    _pad_material(t, s.get("pad_material"))
    sim = Simulation(**s)
    if sim.contact_model == "resting" and abs(display.neutral_C - sim.skin_temperature_C) > 1e-9:
        t.fail("simulation.contact_model", f"a resting probe at the skin temperature: display.neutral_C "
               f"= simulation.skin_temperature_C ({_f(sim.skin_temperature_C)} °C)",
               f"'resting' with display.neutral_C = {_f(display.neutral_C)}")
    return sim


def _pad_material(t: _Fields, name: str | None) -> None:
    """``[simulation] pad_material``: a ``stimuli.MATERIALS`` name (aliases allowed)."""
    from stimuli import MATERIALS, ModelInputError, material  # lazy: numpy/scipy
    if name is not None:
        try:
            material(name)
        except ModelInputError:
            t.fail("simulation.pad_material", "one of " + ", ".join(repr(k) for k in sorted(MATERIALS)),
                   repr(name))


def build_protocol(source: str, data: Any, path: Path | None) -> Protocol:
    """Check ``data`` against the protocol schema, then build the :class:`Protocol`."""
    check_against_schema(data, SCHEMA_PATH, source, ProtocolError)
    t = _Fields(source, data)
    p = data["protocol"]
    env, contact = Environment(**t.table("environment")), ContactSettings(**t.table("contact"))
    display = DisplaySettings(**t.table("display"))
    _ranges(t, env, contact, display)
    samples = _samples(t)
    grouping = _grouping(t)
    simulation = _simulation(t, grouping, display)
    return Protocol(name=p["name"], title=p.get("title", p["name"]),
                    description=p.get("description", "").strip(), experiment=p.get("experiment", 0),
                    version=p.get("version", 1), samples=samples, environment=env,
                    material=SampleMaterial(**t.table("material")), contact=contact, display=display,
                    grouping=grouping, simulation=simulation,
                    block_order=data.get("schedule", {}).get("block_order", "fixed"),
                    blocks=_blocks(t, samples, simulation is not None),
                    presentation=Presentation(**t.table("presentation") or {}),
                    analysis=AnalysisSettings(**t.table("analysis") or {}), authors=_authors(t),
                    hash=hashlib.sha256(canonical_json(data)).hexdigest(), path=path,
                    data=copy.deepcopy(dict(data)))
