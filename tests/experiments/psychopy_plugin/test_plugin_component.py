"""The Thermal cue component's parameters and the code PsychoPy's compiler writes for it.

No window, no display: the experiment is built with PsychoPy's own classes, saved and loaded
as a ``.psyexp``, and its script compiled by Python (the run itself is test_plugin_builder).
"""
from __future__ import annotations

from pathlib import Path

import pytest


DOC = Path(__file__).resolve().parents[3] / "docs" / "psychopy-plugin.md"


@pytest.fixture(scope="module")
def Component():
    from psychopy import plugins
    plugins.activatePlugins()
    from psychopy.experiment.components import getAllComponents
    return getAllComponents()["ThermalCueComponent"]


def _experiment(Component, tmp_path, **params):
    from psychopy import experiment
    exp = experiment.Experiment()
    rt = exp.addRoutine("trial")
    exp.flow.addRoutine(rt, 0)
    comp = Component(exp, "trial", name="cue", **params)
    rt.addComponent(comp)
    path = tmp_path / "exp.psyexp"
    exp.saveToXML(str(path))
    loaded = experiment.Experiment()
    loaded.loadFromXML(str(path))
    return loaded, path


def test_psyexp_round_trip_keeps_the_parameters(Component, tmp_path):
    exp, _ = _experiment(Component, tmp_path, profileSource="profile file",
                         profileFile="cue.csv", trigger="routine start", forceThreshold="1.5",
                         url="/dev/ttyUSB0")
    (comp,) = [c for c in exp.routines["trial"] if c.params["name"].val == "cue"]
    assert type(comp).__name__ == "ThermalCueComponent"
    assert comp.params["profileSource"].val == "profile file"
    assert comp.params["profileFile"].val == "cue.csv"
    assert comp.params["trigger"].val == "routine start"
    assert comp.params["url"].val == "/dev/ttyUSB0"


def test_generated_code_arms_polls_ends_and_neutralises(Component, tmp_path):
    exp, _ = _experiment(Component, tmp_path, profileSource="profile file",
                         profileFile="cue.csv", forceEndRoutine=True, stopVal=5.0)
    script = exp.writeScript(target="PsychoPy")
    compile(script, "exp.py", "exec")                       # valid Python
    assert "from experiments.psychopy_plugin import ThermalCue" in script
    assert "deviceClass='experiments.psychopy_plugin.device.ThermalCueDevice'" in script
    assert "runAtExit.append(cue.stop)" in script           # neutral on quit
    assert "cue.prepare(profile_file='cue.csv')" in script  # routine start
    assert "cue.start(routineTimer)" in script              # component start: arm
    body = script[script.index("if cue.status == STARTED:"):]
    assert body.index("if cue.poll():") < body.index("continueRoutine = False")
    assert "cue.stop()" in script                           # the stop time
    assert "cue.end(routineTimer, globalClock).items()" in script   # routine end: data
    assert "thisExp.addData(_key, _val)" in script


def test_protocol_source_passes_the_sample_each_routine(Component, tmp_path):
    exp, _ = _experiment(Component, tmp_path, sample="$sample", participantFile="P07.json")
    script = exp.writeScript(target="PsychoPy")
    assert "cue.prepare(sample=sample)" in script
    assert "participant='P07.json'" in script
    after_poll = script.split("if cue.poll():")[1].splitlines()[1:3]
    assert not any("continueRoutine" in line for line in after_poll)   # forceEndRoutine off


def test_every_parameter_is_documented(Component, tmp_path):
    from psychopy import experiment
    comp = Component(experiment.Experiment(), "trial")
    doc = DOC.read_text(encoding="utf-8")
    own = ["profileSource", "protocol", "participantFile", "sample", "profileFile", "trigger",
           "forceThreshold", "contactDuration", "forceEndRoutine", "url", "deviceName",
           "simulateTouch", "touchAfter"]
    for name in own:
        assert f"| {comp.params[name].label} |" in doc, name


def test_icons_for_every_app_theme(Component):
    # The Builder app looks for <iconFile's folder>/<theme>/<stem>*.png and crashes at start-up
    # (IndexError in psychopy_app.themes.icons) when a plugin component has none: found by
    # opening the Builder under Xvfb with only the flat icon shipped.
    from PIL import Image
    icon = Path(Component.iconFile)
    for theme in ("light", "dark", "classic"):
        for name, size in ((f"{icon.stem}.png", 48), (f"{icon.stem}@2x.png", 96)):
            with Image.open(icon.parent / theme / name) as im:
                assert im.size == (size, size)
