"""One validation stack: the protocol, session.json (and its planned trials) and the participant
record are each a JSON Schema (Draft 2020-12) checked by participants_schema.schema_check; the
code after it only builds typed objects and checks what a schema cannot say."""
from __future__ import annotations

import copy
import dataclasses
import json
import tomllib
from pathlib import Path

import pytest

from experiments.errors import ProtocolError, SessionError
from experiments.protocol import PROTOCOLS_DIR, load_protocol, parse_protocol, protocol_names
from experiments.protocol import limits, model
from experiments.protocol.build import ANSWER_MODES
from experiments.protocol.build import SCHEMA_PATH as PROTOCOL_SCHEMA
from experiments.schedule import TRIAL_SCHEMA, TrialSpec
from experiments.session.store import SCHEMA_PATH as SESSION_SCHEMA
from participants_schema import SCHEMA_PATH as PARTICIPANT_SCHEMA
from participants_schema import GroupRule, ParticipantError, validate_participant
from participants_schema.schema_check import check_against_schema, load_schema_file, schema_problems

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((ROOT / "participants" / "examples").glob("*.json"))
SCHEMAS = [PROTOCOL_SCHEMA, SESSION_SCHEMA, TRIAL_SCHEMA, PARTICIPANT_SCHEMA]


def _rr() -> dict:
    return tomllib.loads((PROTOCOLS_DIR / "roughness_recognition.toml").read_text(encoding="utf-8"))


def _session() -> dict:
    rr = _rr()
    return {"format": "thermocue-session/1", "session": "P01-1", "participant": {}, "protocol": rr,
            "protocol_hash": "ab", "seed": 1, "schedule": [], "display_url": "emulator://",
            "group": "A", "max_consecutive_faults": 3, "clock": "virtual"}


def _trial() -> dict:
    return {"trial_index": 1, "block": "real", "mode": "real", "roughness_id": 2,
            "roughness_um": 12.5, "repetition": 1}


def _participant() -> dict:
    return json.loads(EXAMPLES[0].read_text(encoding="utf-8"))


@pytest.mark.parametrize("schema", SCHEMAS, ids=lambda p: p.name)
def test_every_schema_is_draft_2020_12_and_closed(schema):
    s = load_schema_file(str(schema))           # checked against the meta-schema on loading
    assert s["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    assert s["additionalProperties"] is False


# (schema, a valid document, a change, the field named, the words of the message)
CASES = [
    (PROTOCOL_SCHEMA, _rr, ("display", "colour", "red"), "display.colour",
     "expected one of the known keys (max_C, max_rate_C_per_s, min_C, neutral_C), got an unknown key 'colour'"),
    (PROTOCOL_SCHEMA, _rr, ("display", "max_rate_C_per_s", "10"), "display.max_rate_C_per_s",
     "expected a number > 0 and ≤ 100, got '10'"),
    (PROTOCOL_SCHEMA, _rr, ("display", "max_rate_C_per_s", 120.0), "display.max_rate_C_per_s",
     "expected a number > 0 and ≤ 100, got 120.0"),
    (PROTOCOL_SCHEMA, _rr, ("contact", "rewarm_s", 7200.0), "contact.rewarm_s",
     f"expected a number ≥ 0 and ≤ 3600 ({limits.WAIT_WHY}), got 7200.0"),
    (SESSION_SCHEMA, _session, (None, "colour", "red"), "colour", "got an unknown key 'colour'"),
    (SESSION_SCHEMA, _session, (None, "seed", "1"), "seed", "expected an integer ≥ 0, got '1'"),
    (SESSION_SCHEMA, _session, (None, "seed", -1), "seed", "expected an integer ≥ 0, got -1"),
    (SESSION_SCHEMA, _session, (None, "max_consecutive_faults", 5000), "max_consecutive_faults",
     "expected an integer ≥ 1 and ≤ 1000 (faults in a row before a session stops), got 5000"),
    (TRIAL_SCHEMA, _trial, (None, "response_id", 2), "response_id", "got an unknown key 'response_id'"),
    (TRIAL_SCHEMA, _trial, (None, "roughness_id", 2.0), "roughness_id", "expected an integer, got 2.0"),
    (TRIAL_SCHEMA, _trial, (None, "roughness_um", float("inf")), "roughness_um", "expected a number, got inf"),
    (PARTICIPANT_SCHEMA, _participant, (None, "colour", "red"), "colour", "got an unknown field 'colour'"),
    (PARTICIPANT_SCHEMA, _participant, ("skin_thickness", "total_um", "700"), "skin_thickness.total_um",
     "expected a number > 0, got '700'"),
    (PARTICIPANT_SCHEMA, _participant, (None, "age", 131), "age", "expected an integer ≥ 0 and ≤ 130, got 131"),
]


@pytest.mark.parametrize("schema, valid, change, field, words", CASES,
                         ids=[f"{c[0].name}:{c[3]}:{i}" for i, c in enumerate(CASES)])
def test_each_schema_refuses_unknown_keys_wrong_types_and_bounds_naming_the_field(
        schema, valid, change, field, words):
    doc = valid()
    assert schema_problems(doc, schema) == []
    table, key, value = change
    (doc[table] if table else doc)[key] = value
    with pytest.raises(ValueError) as ei:
        check_against_schema(doc, schema, "f.json")
    assert str(ei.value).startswith(f"f.json: {field}: ") and str(ei.value).endswith(words), str(ei.value)
    assert "\n" not in str(ei.value)


def test_the_loaders_raise_their_own_errors_through_the_stack(tmp_path):
    data = _rr()
    data["display"]["max_rate_C_per_s"] = 120.0
    with pytest.raises(ProtocolError, match=r"^p\.toml: display\.max_rate_C_per_s: expected a number > 0 "
                                            r"and ≤ 100, got 120\.0$"):
        parse_protocol(data, source="p.toml")
    rec = _participant()
    rec["colour"] = "red"
    with pytest.raises(ParticipantError, match=r"^P\.json: colour: expected one of the known fields"):
        validate_participant(rec, source="P.json")
    with pytest.raises(ValueError, match=r"^TrialSpec: block: expected a string, got 3$"):
        TrialSpec.from_dict(dict(_trial(), block=3))
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "session.json").write_text(json.dumps(dict(_session(), seed=True)))
    from experiments.session.store import read_session_json
    with pytest.raises(SessionError, match=r"session\.json: seed: expected an integer ≥ 0, got True$"):
        read_session_json(tmp_path / "s")
    (tmp_path / "s" / "session.json").write_text(json.dumps(dict(  # checked after the protocol's hash
        _session(), protocol_hash=load_protocol("roughness_recognition").hash, participant=_participant(),
        schedule=[
        _trial(), dict(_trial(), response_id=2)])))
    with pytest.raises(SessionError, match=r"session\.json: schedule\[1\]\.response_id: expected one of "
                                           r"the known keys \(.*\), got an unknown key 'response_id'$"):
        read_session_json(tmp_path / "s")


@pytest.mark.parametrize("name", protocol_names())
def test_the_bundled_protocols_validate(name):
    data = tomllib.loads((PROTOCOLS_DIR / f"{name}.toml").read_text(encoding="utf-8"))
    assert schema_problems(data, PROTOCOL_SCHEMA) == []


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_the_example_participants_validate(path):
    assert schema_problems(json.loads(path.read_text(encoding="utf-8")), PARTICIPANT_SCHEMA) == []


def test_the_bundled_protocols_hashes_are_pinned():
    # taken from main before the protocol moved onto its schema: the hash (and so every
    # schedule and stored session) must not change with the reader
    assert {n: load_protocol(n).hash for n in protocol_names()} == {
        "interface_temperature": "88127e878dfbc980dde6e1822f3e1071203eb55d7f67fe9fc35c872381571db4",
        "roughness_recognition": "228565fac136bb6affdd928efa9095f9c07b41461878275fdaadfbc134f14086",
        "roughness_recognition_tcs2": "4f44a2e77894d0c0fdfc571e7d6cadd9a431456e8994b6fbff3d447d0341d778",
    }


#: each table of the schema and the dataclass it becomes
TABLES = {"environment": model.Environment, "material": model.SampleMaterial, "samples": model.Sample,
          "contact": model.ContactSettings, "display": model.DisplaySettings, "grouping": GroupRule,
          "simulation": model.Simulation, "presentation": model.Presentation,
          "analysis": model.AnalysisSettings, "blocks": model.Block}


def _props(key: str) -> dict:
    s = load_schema_file(str(PROTOCOL_SCHEMA))["properties"][key]
    return (s.get("items") or s)["properties"]


def test_the_protocol_schema_and_the_dataclasses_have_the_same_fields():
    schema = load_schema_file(str(PROTOCOL_SCHEMA))["properties"]
    assert set(schema) == set(TABLES) | {"protocol", "schedule"}
    for key, cls in TABLES.items():
        assert set(_props(key)) == {f.name for f in dataclasses.fields(cls)}, key
    protocol_fields = {f.name for f in dataclasses.fields(model.Protocol)}
    # [protocol]'s keys, [schedule] block_order, one field per table, and what build adds
    assert set(_props("protocol")) | {"block_order"} | set(TABLES) | {"hash", "path", "data"} \
        == protocol_fields
    assert set(_props("schedule")) == {"block_order"}


def test_the_protocol_schema_states_the_models_choices_and_limits():
    enums = {("blocks", "mode"): model.MODES, ("blocks", "order"): model.ORDERS,
             ("schedule", "block_order"): model.BLOCK_ORDERS,
             ("simulation", "skin_thickness"): model.SIM_THICKNESS, ("simulation", "method"): model.SIM_METHODS,
             ("simulation", "target_side"): model.SIM_TARGET_SIDES,
             ("simulation", "rate_limit"): model.SIM_RATE_LIMITS,
             ("simulation", "contact_model"): model.SIM_CONTACT_MODELS,
             ("simulation", "replayed_material"): model.SIM_REPLAYED_MATERIALS,
             ("presentation", "answer_mode"): ANSWER_MODES}
    for (table, key), values in enums.items():
        assert tuple(_props(table)[key]["enum"]) == tuple(values), (table, key)
    for key in ("min_C", "max_C", "neutral_C"):
        assert (_props("display")[key]["minimum"], _props("display")[key]["maximum"]) == \
            (limits.SKIN_SAFE_MIN_C, limits.SKIN_SAFE_MAX_C)
    assert _props("blocks")["repetitions"]["maximum"] == limits.MAX_REPETITIONS
    assert _props("samples")["id"]["maximum"] == _props("protocol")["version"]["maximum"] == limits.MAX_ID
    assert _props("contact")["rewarm_s"]["maximum"] == _props("contact")["trial_timeout_s"]["maximum"] \
        == limits.MAX_WAIT_S


def _every_optional_key_set(data: dict) -> dict:
    """The paper's protocol with every key the schema allows given a value other than its default."""
    data = copy.deepcopy(data)
    data["protocol"].update(title="T", description="D", experiment=7, version=3, authors=["A. B."])
    data["environment"]["measure_skin_temperature"] = False
    data["contact"]["max_attempts"] = 5
    data["grouping"].update(margin_um=25.0, below="thin", above="thick")
    data["simulation"].update(group_skin_thickness_um={"thin": 600.0, "thick": 900.0}, dermis_fraction=0.5,
                              rate_Hz=50.0, resolution_C=0.02, method="numerical", target_side="skin",
                              pad_roughness_um=0.8, pad_material="aluminium", rate_limit="slew",
                              max_tracking_error_C=2.0, contact_model="press", replayed_material="half-space")
    data["schedule"]["block_order"] = "counterbalanced"
    data["presentation"] = {"instructions_key": False, "instructions_min_s": 3.0, "text_min_s": 2.0,
                            "answer_during_contact": True, "feedback_s": 0.5, "answer_mode": "spoken"}
    data["analysis"] = {"equivalence_margin_pp": 7.5}
    data["blocks"][1].update(samples=[2, 1], feedback=True, no_immediate_repeats=True, order="by_repetition")
    return data


def test_build_uses_every_key_the_schema_allows():
    data = _every_optional_key_set(_rr())
    p = parse_protocol(data, source="all.toml")
    as_built = {"protocol": p, "schedule": p}
    for key in load_schema_file(str(PROTOCOL_SCHEMA))["properties"]:
        items = data[key] if isinstance(data[key], list) else [data[key]]
        built = getattr(p, key) if isinstance(data[key], list) else [as_built.get(key) or getattr(p, key)]
        for given, obj in zip(items, built, strict=True):
            for k, v in given.items():
                got = getattr(obj, k)
                want = v.strip() if k == "description" else tuple(v) if isinstance(v, list) else v
                assert got == want, f"{key}.{k}: built {got!r} from {v!r}"
