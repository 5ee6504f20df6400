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
