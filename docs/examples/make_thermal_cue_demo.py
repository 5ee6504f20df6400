"""Write ``thermal_cue_demo.psyexp`` with PsychoPy's own experiment API (as Builder saves it).

    python docs/examples/make_thermal_cue_demo.py [OUT.psyexp]

Two trials (``conditions.csv``: samples 1 and 3 of the packaged ``roughness_recognition``
protocol for participant ``participants/examples/P01.json``), each a routine with the Thermal cue
component, a text prompt and a keyboard (1-4) that ends the routine; PsychoPy's experiment-info
dialog (participant, session) opens first, as Builder's default settings have it. The display URL is
``$THERMOCUE_DISPLAY`` (default ``emulator://``) and the emulated finger is on, so it runs with no
one at the display. ``tests/experiments/psychopy_plugin/test_plugin_builder.py`` checks that the
committed file is what this script writes.
"""
from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def build():
    """The demo as a ``psychopy.experiment.Experiment``."""
    from psychopy import plugins
    plugins.activatePlugins()            # the Thermal cue component is a plugin's
    from psychopy import experiment
    from psychopy.experiment.components import getAllComponents
    from psychopy.experiment.loops import TrialHandler

    exp = experiment.Experiment()
    settings = exp.settings.params
    settings["expName"].val = "thermal_cue_demo"
    settings["Window size (pixels)"].val = [640, 480]
    settings["Full-screen window"].val = False
    settings["Save log file"].val = False
    settings["Save psydat file"].val = False
    # "Show info dlg" stays on (PsychoPy's default): the participant/session dialog opens first
    # (PsychoPy draws it with PyQt6; docs/psychopy-plugin.md says what it needs)

    comps = getAllComponents()
    trial = exp.addRoutine("trial")
    trial.addComponent(comps["ThermalCueComponent"](
        exp, "trial", name="thermal", url="$os.environ.get('THERMOCUE_DISPLAY', 'emulator://')",
        protocol="roughness_recognition", participantFile="../../participants/examples/P01.json",
        sample="$sample", simulateTouch=True, touchAfter=0.3))
    trial.addComponent(comps["TextComponent"](
        exp, "trial", name="prompt", letterHeight=0.05, stopVal="",
        text="Touch the display, then press the number of the sample it feels like (1-4)"))
    trial.addComponent(comps["KeyboardComponent"](
        exp, "trial", name="answer", allowedKeys="'1','2','3','4'", forceEndRoutine=True))
    exp.flow.addRoutine(trial, 0)
    loop = TrialHandler(exp, name="trials", loopType="sequential", nReps=1,
                        conditionsFile="conditions.csv", conditions=[], endPoints=[0, 1])
    exp.flow.addLoop(loop, startPos=0, endPos=1)
    return exp


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    out = Path(argv[0]) if argv else HERE / "thermal_cue_demo.psyexp"
    build().saveToXML(str(out), makeLegacy=False)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
