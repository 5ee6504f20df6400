"""Protocols: the paper's two experiments as data, strict one-line errors, a stable hash."""
from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path

import pytest

from experiments.errors import ProtocolError, UserInputError
from experiments.protocol import PROTOCOLS_DIR, load_protocol, parse_protocol, protocol_names

RR = PROTOCOLS_DIR / "roughness_recognition.toml"


def variant(tmp_path, old, new, name="roughness_recognition.toml", source=RR):
    text = source.read_text(encoding="utf-8")
    assert old in text, f"test setup: {old!r} not in {source.name}"
    path = tmp_path / name
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    return path


def test_packaged_protocols():
    assert protocol_names() == ["interface_temperature", "roughness_recognition",
                                "roughness_recognition_tcs2"]


def test_roughness_recognition_matches_the_paper():
    p = load_protocol("roughness_recognition")
    assert p.path == RR
    # Table 3
    assert [(s.id, s.label, s.roughness_um) for s in p.samples] == [
        (1, "1#", 1.6), (2, "2#", 12.5), (3, "3#", 50.0), (4, "4#", 100.0)]
    assert p.sample(3).roughness_m == pytest.approx(50e-6)
    assert p.material.name == "stainless_steel" and p.material.thickness_m == pytest.approx(3e-3)
    assert p.environment.room_temperature_C == 20.0
    assert (p.environment.skin_temperature_min_C, p.environment.skin_temperature_max_C) == (35.5, 36.0)
    assert p.contact.max_contact_s == 20.0 and p.contact.force_threshold_N == 2.0
    assert p.grouping.threshold_um == 800.0 and (p.grouping.below, p.grouping.above) == ("A", "B")
    assert p.simulation.skin_thickness_for("A") == 650.0
    assert p.simulation.skin_thickness_for("B") == 1000.0
    assert p.simulation.material_temperature_C == 20.0
    fam, real, sim = p.blocks
    assert (fam.name, fam.scored, fam.feedback, fam.mode) == ("familiarise", False, True, "real")
    assert (real.mode, real.repetitions, real.samples, real.order) == ("real", 3, (1, 2, 3, 4), "random")
    assert (sim.mode, sim.repetitions, sim.samples, sim.order) == ("simulated", 3, (1, 2, 3, 4), "random")
    assert real.n_trials == sim.n_trials == 12
    assert p.n_trials == 28
    assert p.block("simulated") is sim
    d = p.display
    assert d.min_C < d.neutral_C < d.max_C and d.max_rate_C_per_s > 0


def test_interface_temperature_matches_the_paper():
    p = load_protocol("interface_temperature")
    assert [s.roughness_um for s in p.samples] == [0.4, 1.6, 12.5, 50.0, 100.0]   # Table 2
    assert p.contact.record_s == 25.0
    assert p.environment.room_temperature_C == 24.0
    assert p.environment.skin_temperature_min_C <= 35.0 <= p.environment.skin_temperature_max_C
    assert p.material.thickness_mm == 3.0
    assert [b.response for b in p.blocks] == [False]
    assert not p.blocks[0].scored
    assert p.simulation is None and p.grouping is None


def test_display_fields_match_the_driver_safety_limits():
    # docs/internal-contracts.md: SafetyLimits(min_C, max_C, max_rate_C_per_s, neutral_C)
    names = [f.name for f in dataclasses.fields(load_protocol("roughness_recognition").display)]
    assert names == ["min_C", "max_C", "max_rate_C_per_s", "neutral_C"]


def test_display_settings_build_the_driver_safety_limits():
    from experiments.display.safety import SafetyLimits
    limits = load_protocol("roughness_recognition").display.safety_limits()
    # experiments/protocols/roughness_recognition.toml [display]; the window is the driver's default
    assert limits == SafetyLimits(min_C=15.0, max_C=42.0, max_rate_C_per_s=10.0, neutral_C=32.0)
    assert limits.rate_window_s == 0.1


def test_protocol_is_frozen():
    p = load_protocol("roughness_recognition")
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.name = "x"


def test_hash_ignores_layout_and_follows_content(tmp_path):
    p = load_protocol("roughness_recognition")
    assert len(p.hash) == 64 and int(p.hash, 16) >= 0
    same = variant(tmp_path, "[contact]", "# a comment\n\n[contact]")
    assert load_protocol(same).hash == p.hash
    other = variant(tmp_path, "rewarm_s = 30.0", "rewarm_s = 31.0", name="other.toml")
    assert load_protocol(other).hash != p.hash


def test_hash_is_sha256_of_canonical_json():
    import tomllib   # here, not at the top: Python 3.10 (supported) has no tomllib

    data = tomllib.loads(RR.read_text(encoding="utf-8"))
    canonical = json.dumps(data, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    assert load_protocol(RR).hash == hashlib.sha256(canonical.encode()).hexdigest()


def test_parse_protocol_round_trip_keeps_hash():
    p = load_protocol("roughness_recognition")
    q = parse_protocol(json.loads(json.dumps(p.data)), source="session.json")
    assert q.hash == p.hash
    assert q.blocks == p.blocks and q.samples == p.samples and q.simulation == p.simulation


def test_name_or_path(tmp_path):
    assert load_protocol(str(RR)).hash == load_protocol("roughness_recognition").hash
    with pytest.raises(ProtocolError) as ei:
        load_protocol("roughness_recogniton")
    assert str(ei.value) == ("roughness_recogniton: expected a protocol file or one of the packaged "
                             "protocols (interface_temperature, roughness_recognition, "
                             "roughness_recognition_tcs2), got no such file")
    assert isinstance(ei.value, UserInputError)
    with pytest.raises(ProtocolError, match="nothere.toml: expected a protocol file"):
        load_protocol(tmp_path / "nothere.toml")


@pytest.mark.parametrize("old, new, message", [
    # the example of STYLE.md
    ("repetitions = 3", 'repetitions = "three"', "blocks[1].repetitions: expected an integer ≥ 1, got 'three'"),
    ("repetitions = 3", "repetitions = 0", "blocks[1].repetitions: expected an integer ≥ 1, got 0"),
    ('mode = "simulated"', 'mode = "virtual"', "blocks[2].mode: expected one of 'real', 'simulated', got 'virtual'"),
    ("rewarm_s = 30.0", "rewarm_s = 30.0\ncolour = 'red'",
     "contact.colour: expected one of the known keys (force_threshold_N, max_attempts, max_contact_s, record_s, "
     "rewarm_s, trial_timeout_s), got an unknown key 'colour'"),
    ("[display]", "[displays]",
     "display: expected a table, got nothing (the key is required; is 'displays' a misspelling?)"),
    ("[display]", "[screen]", "display: expected a table, got nothing (the key is required)"),
    ("[contact]", "[contact]\nverbose = true", "contact.verbose: expected one of the known keys"),
    ("neutral_C = 32.0", "neutral_C = 44.0", "display.neutral_C: expected a number from min_C to max_C (15-42), got 44.0"),
    # the skin-safe range of the pad: 5-45 °C (heat pain from ~45 °C)
    ("max_C = 42.0", "max_C = 50.0", "display.max_C: expected a number ≥ 5 and ≤ 45, got 50.0"),
    ("min_C = 15.0", "min_C = 2.0", "display.min_C: expected a number ≥ 5 and ≤ 45, got 2.0"),
    ("neutral_C = 32.0", "neutral_C = 50.0", "display.neutral_C: expected a number ≥ 5 and ≤ 45, got 50.0"),
    ("max_rate_C_per_s = 10.0", "max_rate_C_per_s = -1.0", "display.max_rate_C_per_s: expected a number > 0 and ≤ 100, got -1.0"),
    ("max_contact_s = 20.0", "max_contact_s = nan", "contact.max_contact_s: expected a number > 0 and ≤ 600, got nan"),
    ("record_s = 20.0", "record_s = 25.0", "contact.record_s: expected a number ≤ max_contact_s (20), got 25.0"),
    ("force_threshold_N = 2.0", "force_threshold_N = '2 N'", "contact.force_threshold_N: expected a number > 0 and ≤ 50, got '2 N'"),
    ("skin_temperature_max_C = 36.0", "skin_temperature_max_C = 35.0",
     "environment.skin_temperature_max_C: expected a number ≥ skin_temperature_min_C (35.5), got 35.0"),
    ("{ A = 650.0, B = 1000.0 }", "{ A = 650.0 }", "simulation.group_skin_thickness_um.B: expected the group's skin thickness"),
    ("{ A = 650.0, B = 1000.0 }", "{ A = 650.0, B = -1.0 }", "simulation.group_skin_thickness_um.B: expected a number > 0, got -1.0"),
    ("id = 2\n", "id = 1\n", "samples[1].id: expected an id not used by another sample, got 1"),
    ('label = "2#"', 'label = "1#"', "samples[1].label: expected a label not used by another sample, got '1#'"),
    ("roughness_um = 50.0", "roughness_um = 0", "samples[2].roughness_um: expected a number > 0, got 0"),
    ('name = "real"', 'name = "familiarise"', "blocks[1].name: expected a name not used by another block, got 'familiarise'"),
    ('name = "real"', 'name = "real"\nsamples = [1, 5]', "blocks[1].samples: expected ids of listed samples (1, 2, 3, 4), got 5"),
    ("scored = false", "scored = true", "blocks[0].scored: expected false when response = false, got True"),
    ('block_order = "fixed"', 'block_order = "alternate"', "schedule.block_order: expected one of 'fixed', 'counterbalanced', 'random', got 'alternate'"),
    ("threshold_um = 800.0", "threshold_um = 800.0\nthreshold_mm = 0.8", "grouping.threshold_mm: expected one of the known keys"),
    ('method = "exact"', 'method = "magic"', "simulation.method: expected one of 'exact', 'paper', 'paper-as-printed', 'numerical', got 'magic'"),
])
def test_bad_field_gives_one_line_naming_file_and_field(tmp_path, old, new, message):
    path = variant(tmp_path, old, new)
    with pytest.raises(ProtocolError) as ei:
        load_protocol(path)
    msg = str(ei.value)
    assert "\n" not in msg
    assert msg.startswith(f"{path}: {message}")


def test_the_skin_safe_bounds_are_inclusive_and_hold_the_packaged_protocols(tmp_path):
    from experiments.protocol import SKIN_SAFE_MAX_C, SKIN_SAFE_MIN_C
    assert (SKIN_SAFE_MIN_C, SKIN_SAFE_MAX_C) == (5.0, 45.0)
    for name in protocol_names():
        d = load_protocol(name).display
        assert SKIN_SAFE_MIN_C <= d.min_C < d.max_C <= SKIN_SAFE_MAX_C
    p = load_protocol(variant(tmp_path, "min_C = 15.0\nmax_C = 42.0", "min_C = 5.0\nmax_C = 45.0"))
    assert (p.display.min_C, p.display.max_C) == (5.0, 45.0)
    with pytest.raises(ProtocolError, match=r"display\.max_C: expected a number ≥ 5 and ≤ 45, got 45\.5"):
        load_protocol(variant(tmp_path, "max_C = 42.0", "max_C = 45.5"))


def test_missing_table(tmp_path):
    text = RR.read_text(encoding="utf-8")
    start, end = text.index("[display]"), text.index("[grouping]")
    path = tmp_path / "roughness_recognition.toml"
    path.write_text(text[:start] + text[end:], encoding="utf-8")
    with pytest.raises(ProtocolError) as ei:
        load_protocol(path)
    assert str(ei.value) == f"{path}: display: expected a table, got nothing (the key is required)"


def test_simulated_block_needs_simulation(tmp_path):
    text = RR.read_text(encoding="utf-8")
    start, end = text.index("[simulation]"), text.index("[schedule]")
    path = tmp_path / "roughness_recognition.toml"
    path.write_text(text[:start] + text[end:], encoding="utf-8")
    with pytest.raises(ProtocolError, match=r"simulation: expected a \[simulation\] table because blocks\[2\] is simulated"):
        load_protocol(path)


def test_toml_syntax_error(tmp_path):
    path = variant(tmp_path, "rewarm_s = 30.0", "rewarm_s = = 30.0")
    with pytest.raises(ProtocolError) as ei:
        load_protocol(path)
    assert str(ei.value).startswith(f"{path}: expected valid TOML, got ")
    assert "line" in str(ei.value)


def test_participant_thickness_mode_needs_no_groups(tmp_path):
    path = variant(tmp_path, 'skin_thickness = "group"', 'skin_thickness = "participant"')
    p = load_protocol(path)
    assert p.simulation.skin_thickness_for("A", 720.0) == 720.0


def test_bad_protocol_through_the_cli(tmp_path, capsys):
    from experiments.cli import main

    path = variant(tmp_path, "repetitions = 3", 'repetitions = "three"')
    participant = Path(__file__).resolve().parents[2] / "participants" / "examples" / "P01.json"
    status = main(["run", str(path), "--participant", str(participant), "--display",
                   "emulator://?clock=virtual", "--responder", "simulated", "--data", str(tmp_path / "data")])
    err = capsys.readouterr().err
    assert status == 2
    assert err == f"thermocue run: {path}: blocks[1].repetitions: expected an integer ≥ 1, got 'three'\n"


# -- [simulation] target side and finger–pad contact -------------------------------------------

def test_simulation_target_side_and_pad_defaults_are_the_papers_and_the_emulators():
    sim = load_protocol("roughness_recognition").simulation
    assert (sim.target_side, sim.pad_roughness_um, sim.pad_material, sim.rate_limit) == \
        ("material", 0.4, "copper", "refuse")
    # a [simulation] table that leaves them out gets the same defaults
    text = RR.read_text(encoding="utf-8")
    for line in ('target_side = "material"\n', "pad_roughness_um = 0.4\n", 'pad_material = "copper"\n',
                 'rate_limit = "refuse"\n'):
        assert line in text
        text = text.replace(line, "")
    p = parse_protocol(__import__("tomllib").loads(text), source="bare.toml")
    assert (p.simulation.target_side, p.simulation.pad_roughness_um, p.simulation.pad_material,
            p.simulation.rate_limit) == ("material", 0.4, "copper", "refuse")


def test_pad_resistance_is_the_emulated_pads():
    from experiments.emulators.thermocue.pad_physics import finger_pad_resistance
    sim = load_protocol("roughness_recognition").simulation
    assert sim.pad_resistance() == pytest.approx(finger_pad_resistance(), rel=1e-12)


@pytest.mark.parametrize("side", ["skin", "compensated"])
def test_target_side_choices(tmp_path, side):
    path = variant(tmp_path, 'target_side = "material"', f'target_side = "{side}"')
    assert load_protocol(path).simulation.target_side == side


@pytest.mark.parametrize("old, new, message", [
    ('target_side = "material"', 'target_side = "Material"',
     "simulation.target_side: expected one of 'material', 'skin', 'compensated', got 'Material'"),
    ('target_side = "material"', "target_side = 1",
     "simulation.target_side: expected one of 'material', 'skin', 'compensated', got 1"),
    ("pad_roughness_um = 0.4", "pad_roughness_um = -0.4",
     "simulation.pad_roughness_um: expected a number ≥ 0 and ≤ 1000, got -0.4"),
    ("pad_roughness_um = 0.4", 'pad_roughness_um = "0.4 um"',
     "simulation.pad_roughness_um: expected a number ≥ 0 and ≤ 1000, got '0.4 um'"),
    ("pad_roughness_um = 0.4", "pad_roughness_m = 0.4e-6",
     "simulation.pad_roughness_m: expected one of the known keys"),
    ('pad_material = "copper"', 'pad_material = "unobtainium"',
     "simulation.pad_material: expected one of 'aluminium', "),
    ('pad_material = "copper"', "pad_material = 29",
     "simulation.pad_material: expected a non-empty string, got 29"),
    ('rate_limit = "refuse"', 'rate_limit = "clamp"',
     "simulation.rate_limit: expected one of 'refuse', 'slew', got 'clamp'"),
])
def test_bad_simulation_fields_name_file_and_field(tmp_path, old, new, message):
    path = variant(tmp_path, old, new)
    with pytest.raises(ProtocolError) as ei:
        load_protocol(path)
    msg = str(ei.value)
    assert "\n" not in msg
    assert msg.startswith(f"{path}: {message}"), msg


def test_presentation_table_defaults_and_values(tmp_path):
    from experiments.protocol import Presentation
    assert load_protocol("roughness_recognition").presentation == Presentation()
    p = variant(tmp_path, "[schedule]", "[presentation]\ninstructions_key = false\n"
                "instructions_min_s = 5.0\ntext_min_s = 0.5\nanswer_during_contact = true\n\n[schedule]")
    shown = load_protocol(p).presentation
    assert (shown.instructions_key, shown.instructions_min_s, shown.text_min_s,
            shown.answer_during_contact) == (False, 5.0, 0.5, True)
    bad = variant(tmp_path, "[schedule]", "[presentation]\ntext_min_s = -1\n\n[schedule]", name="bad.toml")
    with pytest.raises(ProtocolError, match=r"bad\.toml: presentation\.text_min_s: expected a number ≥ 0"):
        load_protocol(bad)
