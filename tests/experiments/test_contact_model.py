"""The resting-probe contact model: the profile, the protocol option, and what a TCS II refuses."""
from __future__ import annotations

import numpy as np
import pytest

import stimuli
from experiments.contact_model import resting_profile
from experiments.errors import ProtocolError
from experiments.display.safety import profile_max_rate
from experiments.protocol import PROTOCOLS_DIR, load_protocol

TCS = PROTOCOLS_DIR / "roughness_recognition_tcs2.toml"


@pytest.mark.parametrize("roughness_m", [1.6e-6, 100e-6])
def test_resting_profile_starts_at_the_skin_ramps_at_the_limit_then_follows(roughness_m):
    p = stimuli.target_profile(roughness=roughness_m, duration=20.0, rate=100.0)
    x = np.asarray(p.temperature)
    y, change, catch_up = resting_profile(x, 0.01, 35.5, 10.0)
    assert y[0] == 35.5
    assert profile_max_rate(y, 0.01, 0.1) <= 10.0
    k = int(round(catch_up / 0.01))
    assert np.max(np.abs(y[k:] - x[k:])) <= 0.01 + 1e-9      # the target, once met
    # the ramp: (35.5 - where it meets the target) at 9.9 °C/s (10 less the rounding's share)
    assert catch_up == pytest.approx((35.5 - x[k]) / 9.9, abs=0.02)
    assert change == pytest.approx(35.5 - x[0], abs=0.01)


def test_the_option_is_validated(tmp_path):
    text = TCS.read_text(encoding="utf-8")
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("neutral_C = 35.5", "neutral_C = 32.0", 1), encoding="utf-8")
    with pytest.raises(ProtocolError) as exc:
        load_protocol(bad)
    msg = str(exc.value)
    assert "bad.toml: simulation.contact_model:" in msg and "display.neutral_C = 32" in msg
    assert "\n" not in msg
    bad.write_text(text.replace('contact_model = "resting"', 'contact_model = "hover"'), encoding="utf-8")
    with pytest.raises(ProtocolError, match="simulation.contact_model"):
        load_protocol(bad)
    assert load_protocol("roughness_recognition").simulation.contact_model == "press"


def test_a_tcs2_refuses_real_blocks_and_press_to_touch_before_opening(tmp_path):
    from experiments.session.setup import open_session_display
    with pytest.raises(ProtocolError, match=r"blocks\[0\]\.mode.*tcs2://"):
        open_session_display(load_protocol("roughness_recognition"), "tcs2://emulator?clock=virtual")
    press = tmp_path / "press.toml"
    text = TCS.read_text(encoding="utf-8").replace('contact_model = "resting"', 'contact_model = "press"')
    press.write_text(text, encoding="utf-8")
    with pytest.raises(ProtocolError, match="simulation.contact_model: expected 'resting'"):
        open_session_display(load_protocol(press), "tcs2://emulator?clock=virtual")


def test_the_cli_says_so_in_one_line(tmp_path, capsys):
    from experiments.cli import main
    from pathlib import Path
    p01 = Path(__file__).resolve().parents[2] / "participants" / "examples" / "P01.json"
    status = main(["run", "roughness_recognition", "--participant", str(p01), "--display",
                   "tcs2://emulator?clock=virtual", "--responder", "simulated", "--data",
                   str(tmp_path / "d")])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and "blocks[0].mode" in err
    assert not (tmp_path / "d" / "P01").exists()
