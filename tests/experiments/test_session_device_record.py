"""``session.json`` names the device and the image every opening of the display ran on."""
from __future__ import annotations

import json

from _session_helpers import P01, write_protocol
from experiments.cli import main
from experiments.session.making import open_session


def test_session_json_records_the_device_id_and_image_id_on_the_emulator(tmp_path):
    proto = write_protocol(tmp_path, real_samples=(), sim_samples=(4,), contact_s=0.5)
    data = tmp_path / "data"
    assert main(["run", str(proto), "--participant", str(P01), "--display",
                 "emulator://?clock=virtual", "--responder", "simulated", "--data", str(data),
                 "--session", "S01", "--quiet"]) == 0
    folder = data / "P01" / "S01"
    (shown,) = json.loads((folder / "session.json").read_text())["displays"]
    assert (shown["url"], shown["device_id"], shown["firmware"], shown["image_id"]) == (
        "emulator://?clock=virtual", "EMU-0001", "thermocue-emu 1.0.0", "emulator-1.0.0")
    assert shown["opened_at"]
    opened = [json.loads(line) for line in (folder / "events.jsonl").read_text().splitlines()
              if '"display_opened"' in line]
    assert opened[0]["image_id"] == "emulator-1.0.0"
    open_session(folder)       # the file with its displays list still reads back as a session


def test_the_tcs2_states_its_probe_id_and_firmware_and_session_json_keeps_them(tmp_path):
    from experiments.display import open_display
    from experiments.session.store import record_display
    from experiments.protocol import load_protocol
    limits = load_protocol("roughness_recognition_tcs2").display.safety_limits()
    with open_display("tcs2://emulator", limits) as disp:
        info = disp.info
    assert (info.device_id, info.image_id) == ("EM 00 00 00 00 00 00 01", "012 thermocue-emulator")
    (tmp_path / "session.json").write_text(json.dumps({"format": "x"}))
    record_display(tmp_path, "tcs2://emulator", info, durable=False)
    record_display(tmp_path, "tcs2://emulator", info, durable=False)     # a reconnect: a second entry
    meta = json.loads((tmp_path / "session.json").read_text())
    assert meta["format"] == "x" and len(meta["displays"]) == 2
    assert meta["displays"][1]["device_id"] == "EM 00 00 00 00 00 00 01"
    assert meta["displays"][1]["image_id"] == "012 thermocue-emulator"
