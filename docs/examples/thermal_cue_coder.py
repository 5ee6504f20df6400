"""Coder example: thermal cues through PsychoPy's DeviceManager, no Builder.

For each sample: the profile the protocol gives this participant is uploaded, the display is
armed (it starts the profile at contact), the window asks for an answer, the contact arrives as
a PsychoPy response with its place on PsychoPy's clock, and the answer (keys 1-4) ends the
trial: neutral, then the display's recording goes into PsychoPy's data file.

    python docs/examples/thermal_cue_coder.py --display /dev/ttyUSB0 --participant P07.json
    python docs/examples/thermal_cue_coder.py --dry-run          # emulator://, a scripted finger

``--dry-run`` scripts the emulator's finger (no one at the display); on hardware leave it out.
Esc quits (the display goes to neutral). Needs ``pip install thermocue[gui]``.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from psychopy import plugins

plugins.activatePlugins()          # registers the thermal display with PsychoPy

from psychopy import core, data, visual  # noqa: E402
from psychopy.hardware import DeviceManager, keyboard  # noqa: E402

from experiments.psychopy_plugin.profiles import protocol_profile  # noqa: E402

HERE = Path(__file__).resolve().parent
P01 = HERE.parent.parent / "participants" / "examples" / "P01.json"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--display", default="emulator://", help="serial device, pty or emulator://")
    ap.add_argument("--protocol", default="roughness_recognition")
    ap.add_argument("--participant", default=str(P01))
    ap.add_argument("--samples", type=int, nargs="+", default=[1, 3])
    ap.add_argument("--data", default=str(Path("data") / "thermal_cue_coder"),
                    help="data file name without extension (default data/thermal_cue_coder)")
    ap.add_argument("--dry-run", action="store_true", help="emulator: a scripted finger presses")
    ns = ap.parse_args(argv)

    # the display, opened by PsychoPy's DeviceManager ("thermocue" is the device's alias)
    display = DeviceManager.addDevice(deviceClass="thermocue", deviceName="thermal",
                                      url=ns.display, protocol=ns.protocol)
    protocol = display.protocol
    win = visual.Window((640, 480), units="height", checkTiming=False)
    text = visual.TextStim(win, "", height=0.04, wrapWidth=0.9)
    kb = keyboard.Keyboard()
    Path(ns.data).parent.mkdir(parents=True, exist_ok=True)
    exp = data.ExperimentHandler(name="thermal_cue_coder", dataFileName=ns.data,
                                 savePickle=False, saveWideText=False)
    trial_clock = core.Clock()
    quitting = False
    try:
        for sample in ns.samples:
            profile = protocol_profile(protocol, ns.participant, sample)
            display.uploadProfile(profile.times_s, profile.target_C)   # checked against limits
            display.resetClockMap()
            display.syncClock()                     # device time -> PsychoPy time (offset)
            display.arm(forceThreshold_N=protocol.contact.force_threshold_N,
                        maxDuration_s=protocol.contact.max_contact_s)
            if ns.dry_run:
                display.display.sim_finger(press_after_s=0.3, force_N=2.5, hold_s=25.0)
            text.text = "Touch the display, then press the number of the sample (1-4)"
            trial_clock.reset()
            kb.clearEvents()
            answer = None
            while answer is None:
                display.dispatchMessages()          # contact/release -> display.responses
                contact = next((r for r in display.responses if r.kind == "contact"), None)
                for key in kb.getKeys(keyList=["1", "2", "3", "4", "escape"]):
                    if key.name == "escape":
                        quitting = True
                    elif contact is not None:       # answers count once the cue has started
                        answer = key
                if quitting:
                    break
                text.draw()
                win.flip()
            if quitting:
                break
            rec = display.finishTrial()             # neutral now; the display's recording
            display.syncClock()                     # second burst: drift over the trial
            onset = display.toPsychopyTime(rec.contact_time_s)
            exp.addData("sample", sample)
            exp.addData("answer.keys", answer.name)
            exp.addData("answer.rt_s", answer.rt)
            exp.addData("thermal.status", rec.status)
            exp.addData("thermal.tracking_rms_C", rec.tracking_rms_C)
            exp.addData("thermal.contact_device_s", rec.contact_time_s)
            # contact onset on the trial clock: PsychoPy time of the contact minus the trial start;
            # nothing when the map is implausible (it says why: clock_status)
            cmap = display.clockMap
            mapped = cmap.unmapped is None
            exp.addData("thermal.clock_status", "mapped" if mapped else f"unmapped: {cmap.unmapped}")
            exp.addData("thermal.contact_trial_s",
                        trial_clock.getTime() - (display.clockNow() - onset) if mapped else "")
            exp.addData("thermal.clock_uncertainty_s", cmap.uncertainty_s if mapped else "")
            exp.addData("thermal.contact_force_N", contact.force_N)
            exp.nextEntry()
    finally:
        display.neutral()                           # also on Esc or an error
        exp.saveAsWideText(ns.data + ".csv", fileCollisionMethod="overwrite")
        win.close()
        DeviceManager.closeAll()                    # closes the display (neutral, port closed)
    return 1 if quitting else 0


if __name__ == "__main__":
    raise SystemExit(main())
