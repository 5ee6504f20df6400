"""The emulated hand (experiments.responders.hand): written once, used by every caller."""
from __future__ import annotations

import ast
from pathlib import Path

import numpy as np

from experiments.display import open_display
from experiments.responders.hand import press

ROOT = Path(__file__).resolve().parents[3]


class _Recorder:
    """Records the emulator-scripting calls it receives (only to see what press forwards)."""

    def __init__(self):
        self.calls = []

    def sim_sample(self, **kwargs):
        self.calls.append(("sim_sample", kwargs))

    def sim_finger(self, **kwargs):
        self.calls.append(("sim_finger", kwargs))


def test_press_places_the_sample_then_presses_the_finger_it_is_given():
    d = _Recorder()
    sample = dict(material="stainless_steel", roughness_m=12.5e-6, thickness_m=3e-3, temperature_C=22.0)
    press(d, sample=sample, press_after_s=0.3, force_N=2.5, hold_s=4.0, skin_thickness_m=800e-6,
          skin_temperature_C=35.7)
    assert d.calls == [("sim_sample", sample),
                       ("sim_finger", dict(press_after_s=0.3, force_N=2.5, hold_s=4.0,
                                           skin_thickness_m=800e-6, skin_temperature_C=35.7))]


def test_a_finger_not_described_is_the_emulators_own_default_finger():
    d = _Recorder()
    press(d, sample=None, press_after_s=0.2, hold_s=3.0)
    assert d.calls == [("sim_finger", dict(press_after_s=0.2, hold_s=3.0))]


def _trial(script):
    with open_display("emulator://?clock=virtual&seed=20261124") as d:
        t = np.linspace(0.0, 2.0, 201)
        d.upload_profile(t, 32.0 - 0.5 * t)
        d.arm("playback", max_duration_s=3.0)
        script(d)
        return d.run_trial(timeout_s=30.0)


def test_press_on_the_emulator_is_the_direct_script_it_replaces():
    # the bench's and the PsychoPy cue's old calls, against press with the same finger
    by_press = _trial(lambda d: press(d, sample=None, press_after_s=0.2, hold_s=5.0))
    direct = _trial(lambda d: d.sim_finger(press_after_s=0.2, hold_s=5.0))
    assert by_press.status == direct.status and by_press.frames == direct.frames > 0
    assert by_press.tracking_rms_C == direct.tracking_rms_C


def test_only_the_hand_scripts_the_emulated_finger_and_sample():
    # the hardware layer implements the commands; everything else goes through press
    callers = []
    for path in sorted((ROOT / "experiments").rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        if rel.startswith("experiments/display/") or rel == "experiments/responders/hand.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                    and node.func.attr in ("sim_finger", "sim_sample")):
                callers.append(f"{rel}:{node.lineno}")
    assert callers == []
