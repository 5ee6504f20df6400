"""How parsed protocol content (a TOML file's tables, or ``session.json``'s copy) becomes a
:class:`~experiments.protocol.model.Protocol`: every table read strictly with the shared table
reader (:mod:`experiments.records`), each value checked against its range
(:mod:`experiments.protocol.limits`) and the cross-field rules (max ≥ min, record ≤ contact, ...).

A wrong type, an out-of-range value, a missing key or an unknown key raises
:class:`experiments.errors.ProtocolError` with one line naming the file and the field.
"""
from __future__ import annotations

import copy
import hashlib
from pathlib import Path
from typing import Any

from experiments.errors import ProtocolError
from experiments.protocol.hashing import canonical_json
from experiments.protocol.limits import (MAX_ID, MAX_REPETITIONS, MAX_TRIALS, MAX_WAIT_S, SKIN_SAFE_MAX_C,
                                         SKIN_SAFE_MIN_C)
from experiments.protocol.limits import SKIN_WHY as _SKIN_WHY
from experiments.protocol.limits import WAIT_WHY as _WAIT_WHY
from experiments.protocol.model import (SIM_CONTACT_MODELS, DEFAULT_EQUIVALENCE_MARGIN_PP, AnalysisSettings,
                                        BLOCK_ORDERS, DEFAULT_PAD_MATERIAL, DEFAULT_PAD_ROUGHNESS_UM, MODES,
                                        ORDERS, SIM_METHODS, SIM_RATE_LIMITS, SIM_REPLAYED_MATERIALS, SIM_TARGET_SIDES,
                                        SIM_THICKNESS, Block, ContactSettings, DisplaySettings,
                                        Environment, Presentation, Protocol, Sample, SampleMaterial,
                                        Simulation)
from experiments.records import TableReader as _Table
from experiments.records import Verbatim as _Note
from experiments.records import number_text as _fmt
from participants_schema import GroupRule

#: ``[presentation] answer_mode`` values: the participant keys the answer, or says it.
ANSWER_MODES = ("keyed", "spoken")


def _pad_material(s: _Table) -> str:
    """``[simulation] pad_material``: a ``stimuli.MATERIALS`` name (aliases allowed)."""
    from stimuli import MATERIALS, ModelInputError, material  # lazy: numpy/scipy
    name = s.string("pad_material", DEFAULT_PAD_MATERIAL)
    try:
        material(name)
    except ModelInputError:
        s.fail("pad_material", "one of " + ", ".join(repr(k) for k in sorted(MATERIALS)), name)
    return name


def _read_samples(top: _Table) -> tuple[Sample, ...]:
    out, ids, labels = [], set(), set()
    for t in top.tables("samples"):
        sid = t.integer("id", ge=0, le=MAX_ID)
        label = t.string("label", str(sid))
        r = t.number("roughness_um", gt=0, le=10_000, why="Ra beyond 1 cm is no surface finish")
        t.done()
        if sid in ids:
            t.fail("id", "an id not used by another sample", sid)
        if label in labels:
            t.fail("label", "a label not used by another sample", label)
        ids.add(sid)
        labels.add(label)
        out.append(Sample(sid, label, r))
    return tuple(out)


def _read_blocks(top: _Table, samples: tuple[Sample, ...]) -> tuple[Block, ...]:
    ids = [s.id for s in samples]
    out, names = [], set()
    for t in top.tables("blocks"):
        name = t.string("name")
        if name in names:
            t.fail("name", "a name not used by another block", name)
        names.add(name)
        mode = t.string("mode", choices=MODES)
        reps = t.integer("repetitions", ge=1, le=MAX_REPETITIONS,
                         why="a session is at most a few hundred trials")
        order = t.string("order", "random", choices=ORDERS)
        chosen = t._get("samples", list(ids), "a list of sample ids")
        if not isinstance(chosen, list) or not chosen or any(
                isinstance(c, bool) or not isinstance(c, int) for c in chosen):
            t.fail("samples", "a non-empty list of sample ids", chosen)
        for c in chosen:
            if c not in ids:
                t.fail("samples", f"ids of listed samples ({', '.join(map(str, ids))})", c)
        if len(set(chosen)) != len(chosen):
            t.fail("samples", "each sample id once", chosen)
        response = t.boolean("response", True)
        scored = t.boolean("scored", response)
        if scored and not response:
            t.fail("scored", "false when response = false", scored)
        feedback = t.boolean("feedback", False)
        nir = t.boolean("no_immediate_repeats", False)
        if nir and len(chosen) < 2 and reps > 1:
            t.fail("no_immediate_repeats", "false with a single sample", nir)
        instructions = t.string("instructions", "", nonempty=False)
        t.done()
        out.append(Block(name, mode, reps, order, tuple(chosen), scored, feedback, response,
                         nir, instructions))
    return tuple(out)


def _read_authors(p: _Table) -> tuple[str, ...]:
    """``[protocol] authors``: the study's authors, one name per item (the BIDS export's
    ``dataset_description.json`` ``Authors``); default none."""
    listed = p._get("authors", [], "a list of author names (strings)")
    if not isinstance(listed, list) or any(not isinstance(a, str) or not a.strip() for a in listed):
        p.fail("authors", "a list of author names, one non-empty string per author", listed)
    if len({a.strip() for a in listed}) != len(listed):
        p.fail("authors", "each author once", listed)
    return tuple(a.strip() for a in listed)


def build_protocol(source: str, data: Any, path: Path | None) -> Protocol:
    top = _Table(source, data, "")
    p = top.table("protocol")
    name = p.string("name")
    title = p.string("title", name)
    description = p.string("description", "", nonempty=False).strip()
    experiment = p.integer("experiment", 0, ge=0, le=MAX_ID)
    version = p.integer("version", 1, ge=1, le=MAX_ID)
    authors = _read_authors(p)
    p.done()

    e = top.table("environment")
    env = Environment(
        room_temperature_C=e.number("room_temperature_C", ge=-10, le=50),
        skin_temperature_min_C=e.number("skin_temperature_min_C", ge=20, le=42),
        skin_temperature_max_C=e.number("skin_temperature_max_C", ge=20, le=42),
        measure_skin_temperature=e.boolean("measure_skin_temperature", True),
    )
    if env.skin_temperature_max_C < env.skin_temperature_min_C:
        e.fail("skin_temperature_max_C",
               f"a number ≥ skin_temperature_min_C ({_fmt(env.skin_temperature_min_C)})",
               env.skin_temperature_max_C)
    e.done()

    m = top.table("material")
    mat = SampleMaterial(m.string("name"), m.number("thickness_mm", None, gt=0, le=1000,
                                                    why="a sample a finger can touch"))
    m.done()

    samples = _read_samples(top)

    c = top.table("contact")
    contact = ContactSettings(
        force_threshold_N=c.number("force_threshold_N", gt=0, le=50),
        max_contact_s=c.number("max_contact_s", gt=0, le=600),
        record_s=c.number("record_s", gt=0, le=600),
        trial_timeout_s=c.number("trial_timeout_s", gt=0, le=MAX_WAIT_S, why=_WAIT_WHY),
        rewarm_s=c.number("rewarm_s", ge=0, le=MAX_WAIT_S, why=_WAIT_WHY),
        max_attempts=c.integer("max_attempts", 3, ge=1, le=100),
    )
    if contact.record_s > contact.max_contact_s:
        c.fail("record_s", f"a number ≤ max_contact_s ({_fmt(contact.max_contact_s)})", contact.record_s)
    c.done()

    d = top.table("display")
    display = DisplaySettings(
        min_C=d.number("min_C", ge=SKIN_SAFE_MIN_C, le=SKIN_SAFE_MAX_C),
        max_C=d.number("max_C", ge=SKIN_SAFE_MIN_C, le=SKIN_SAFE_MAX_C),
        max_rate_C_per_s=d.number("max_rate_C_per_s", gt=0, le=100),
        neutral_C=d.number("neutral_C", ge=SKIN_SAFE_MIN_C, le=SKIN_SAFE_MAX_C),
    )
    if not display.max_C > display.min_C:
        d.fail("max_C", f"a number > min_C ({_fmt(display.min_C)})", display.max_C)
    if not display.min_C <= display.neutral_C <= display.max_C:
        d.fail("neutral_C", f"a number from min_C to max_C ({_fmt(display.min_C)}-{_fmt(display.max_C)})",
               display.neutral_C)
    d.done()

    grouping = None
    g = top.table("grouping", required=False)
    if g is not None:
        below = g.string("below", "A")
        above = g.string("above", "B")
        if above == below:
            g.fail("above", "a group name different from below", above)
        grouping = GroupRule(threshold_um=g.number("threshold_um", gt=0, le=10_000, why=_SKIN_WHY),
                             margin_um=g.number("margin_um", 50.0, ge=0, le=10_000, why=_SKIN_WHY),
                             below=below, above=above)
        g.done()

    simulation = None
    s = top.table("simulation", required=False)
    if s is not None:
        how = s.string("skin_thickness", "group", choices=SIM_THICKNESS)
        gst = s.table("group_skin_thickness_um", required=(how == "group"))
        per_group = {}
        if gst is not None:
            for key in list(gst.data):
                per_group[key] = gst.number(key, gt=0, le=10_000, why=_SKIN_WHY)
            gst.done()
        if how == "group":
            if grouping is None:
                s.fail("skin_thickness", "'participant' when the protocol has no [grouping]", how)
            for grp in (grouping.below, grouping.above):
                if grp not in per_group:
                    gst.fail(grp, "the group's skin thickness in µm, a number > 0")
        simulation = Simulation(
            skin_thickness=how,
            group_skin_thickness_um=per_group,
            dermis_fraction=s.number("dermis_fraction", 0.6, gt=0, lt=1),
            skin_temperature_C=s.number("skin_temperature_C", ge=20, le=42),
            material_temperature_C=s.number("material_temperature_C", ge=-10, le=60),
            duration_s=s.number("duration_s", gt=0, le=600),
            rate_Hz=s.number("rate_Hz", 100.0, gt=0, le=10000),
            resolution_C=s.number("resolution_C", 0.01, gt=0, le=1),
            method=s.string("method", "exact", choices=SIM_METHODS),
            target_side=s.string("target_side", "material", choices=SIM_TARGET_SIDES),
            pad_roughness_um=s.number("pad_roughness_um", DEFAULT_PAD_ROUGHNESS_UM, ge=0, le=1000),
            pad_material=_pad_material(s),
            rate_limit=s.string("rate_limit", "refuse", choices=SIM_RATE_LIMITS),
            max_tracking_error_C=s.number("max_tracking_error_C", 1.0, gt=0, le=10),
            contact_model=s.string("contact_model", "press", choices=SIM_CONTACT_MODELS),
            replayed_material=s.string("replayed_material", "sample",
                                       choices=SIM_REPLAYED_MATERIALS),
        )
        if (simulation.contact_model == "resting"
                and abs(display.neutral_C - simulation.skin_temperature_C) > 1e-9):
            s.fail("contact_model", f"a resting probe at the skin temperature: display.neutral_C "
                                    f"= simulation.skin_temperature_C "
                                    f"({_fmt(simulation.skin_temperature_C)} °C)",
                   _Note(f"'resting' with display.neutral_C = {_fmt(display.neutral_C)}"))
        s.done()

    sch = top.table("schedule", required=False)
    block_order = "fixed"
    if sch is not None:
        block_order = sch.string("block_order", "fixed", choices=BLOCK_ORDERS)
        sch.done()

    presentation = Presentation()
    pr = top.table("presentation", required=False)
    if pr is not None:
        presentation = Presentation(
            instructions_key=pr.boolean("instructions_key", True),
            instructions_min_s=pr.number("instructions_min_s", 2.0, ge=0, le=600),
            text_min_s=pr.number("text_min_s", 1.0, ge=0, le=60),
            answer_during_contact=pr.boolean("answer_during_contact", False),
            feedback_s=pr.number("feedback_s", 1.5, ge=0, le=60),
            answer_mode=pr.string("answer_mode", "keyed", choices=ANSWER_MODES),
        )
        pr.done()

    analysis = AnalysisSettings()
    an = top.table("analysis", required=False)
    if an is not None:
        analysis = AnalysisSettings(equivalence_margin_pp=an.number(
            "equivalence_margin_pp", DEFAULT_EQUIVALENCE_MARGIN_PP, gt=0, lt=50,
            why="percentage points of proportion correct"))
        an.done()

    blocks = _read_blocks(top, samples)
    n_trials = sum(b.n_trials for b in blocks)
    if n_trials > MAX_TRIALS:
        top.fail("blocks", f"at most {MAX_TRIALS} trials in all (samples × repetitions; a session "
                           f"is hours, not days)", _Note(f"{n_trials} trials"))
    if simulation is None:
        for i, b in enumerate(blocks):
            if b.mode == "simulated":
                raise ProtocolError(f"{source}: simulation: expected a [simulation] table because "
                                    f"blocks[{i}] is simulated, got nothing")
    top.done()

    canonical = canonical_json(data)
    return Protocol(name=name, title=title, description=description, experiment=experiment,
                    version=version, samples=samples, environment=env, material=mat,
                    contact=contact, display=display, grouping=grouping, simulation=simulation,
                    block_order=block_order, blocks=blocks, presentation=presentation,
                    analysis=analysis, authors=authors,
                    hash=hashlib.sha256(canonical).hexdigest(), path=path,
                    data=copy.deepcopy(dict(data)))

