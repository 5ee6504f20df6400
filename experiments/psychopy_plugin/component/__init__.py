"""The "Thermal cue" Builder component: play a thermal profile on the display at contact.

Registered by the ``psychopy.experiment.components`` entry point. The generated code (Python
only) opens the display through PsychoPy's DeviceManager (:mod:`..device`), then per routine:

- routine start: make the profile (a protocol sample for the participant, or a profile file),
  check it against the protocol's safety limits and upload it;
- component start: map the device clock to PsychoPy's (heartbeat burst), arm: the display
  brings the pad to the profile's first sample and starts the profile when the summed force
  reaches the threshold (trigger "contact force"), or as soon as it is there with the finger
  already resting on it (trigger "routine start");
- each frame: route the display's messages (contact and release become responses); the
  component finishes when the display's trial ends; "Force end of Routine" ends the routine then;
- routine end: neutral (aborting a profile still playing), a second clock burst (drift), and
  the columns ``<name>.status``, ``.contact_routine_s``, ``.contact_device_s``,
  ``.tracking_rms_C``, ``.clock_offset_s``, ``.clock_uncertainty_s``... in ``thisExp``;
- quit (Esc, end of experiment, a crash): neutral (``runAtExit``; the device's ``close`` on
  PsychoPy's exit handler as well).
"""
from __future__ import annotations

from pathlib import Path

from psychopy.experiment.components import BaseComponent, Param, getInitVals
from psychopy.localization import _translate

__all__ = ["ThermalCueComponent"]

# A script PsychoPy compiled without this plugin imports this module on its first lines
# (plugins.activatePlugins()): stop it there with the fix rather than with a NameError later.
from .stripped import check_main_script  # noqa: E402

check_main_script()

# Every Builder script shows PsychoPy's experiment-info dialog unless "Show info dlg" is off: where
# Qt cannot start (its X11 libraries missing), ask it on the terminal rather than abort.
from .info_dialog import install as _install_info_dialog  # noqa: E402

_install_info_dialog()

_HERE = Path(__file__).parent


#: The component's own parameters, in the dialog's order: (name, valType, inputType, category,
#: label, hint[, allowed values]); "Basic": the profile and when it plays.
_PARAMS = (
    ("profileSource", "str", "choice", "Basic", "Profile source",
     "A sample of the protocol computed for the participant (as `thermocue run` does), or a CSV "
     "file with time_s and target_C", ["protocol sample", "profile file"]),
    ("protocol", "str", "single", "Basic", "Protocol",
     "Packaged protocol name or TOML file: its [display] safety limits and neutral temperature "
     "always apply; its samples, contact threshold and maximum contact time are the defaults"),
    ("participantFile", "file", "file", "Basic", "Participant file",
     "The participant's JSON record (group and skin thickness)"),
    ("sample", "code", "single", "Basic", "Sample id",
     "The protocol's sample to simulate, evaluated at each routine start (e.g. $sample from a "
     "conditions file)"),
    ("profileFile", "file", "file", "Basic", "Profile file",
     "CSV with columns time_s (uniform from 0) and target_C, read at each routine start"),
    ("trigger", "str", "choice", "Basic", "Trigger",
     "contact force: the profile starts when the finger presses with the threshold force; "
     "routine start: the finger rests on the display and the profile starts as soon as the pad "
     "is at its first sample", ["contact force", "routine start"]),
    ("forceThreshold", "code", "single", "Basic", "Force threshold (N)",
     "Summed force that starts the profile; blank: the protocol's [contact] force_threshold_N"),
    ("contactDuration", "code", "single", "Basic", "Max contact duration (s)",
     "The display ends the profile this long after contact; blank: the protocol's [contact] "
     "max_contact_s"),
    ("forceEndRoutine", "bool", "bool", "Basic", "End Routine when the cue ends",
     "End the routine when the display's trial ends (profile complete, finger released, maximum "
     "duration or a fault)"),
    ("url", "str", "single", "Device", "Display URL",
     "Serial device (/dev/ttyUSB0, COM3), a pty path, or emulator://"),
    ("deviceName", "str", "single", "Device", "Device name",
     "Name of the display in PsychoPy's DeviceManager (components with the same name share one "
     "display)"),
    ("simulateTouch", "bool", "bool", "Testing", "Emulated finger (dry run)",
     "emulator:// or `thermocue emulator` only: a scripted finger presses after arming, so the "
     "experiment runs with no one at the display"),
    ("touchAfter", "code", "single", "Testing", "Emulated press after (s)",
     "When the emulated finger presses, from the pad being ready"),
)
#: (parameter, the parameter it depends on, the condition that shows it)
_DEPENDS = (("participantFile", "profileSource", "== 'protocol sample'"),
            ("sample", "profileSource", "== 'protocol sample'"),
            ("profileFile", "profileSource", "== 'profile file'"),
            ("touchAfter", "simulateTouch", "== True"))


class ThermalCueComponent(BaseComponent):
    """A thermal cue on the thermocue Peltier display (or its emulator)."""

    categories = ["Stimuli", "I/O"]
    targets = ["PsychoPy"]
    version = "2026.2.0"
    iconFile = _HERE / "thermal_cue.png"
    tooltip = _translate("Thermal cue: play a temperature profile on the thermal display at contact")
    beta = True
    plugin = "thermocue"

    def __init__(self, exp, parentName, name="thermal",
                 startType="time (s)", startVal=0.0, stopType="duration (s)", stopVal="",
                 startEstim="", durationEstim="",
                 url="emulator://", deviceName="thermal_display",
                 protocol="roughness_recognition", profileSource="protocol sample",
                 participantFile="", sample="1", profileFile="",
                 trigger="contact force", forceThreshold="", contactDuration="",
                 forceEndRoutine=False, simulateTouch=False, touchAfter=0.5,
                 saveStartStop=True, syncScreenRefresh=False, disabled=False):
        super().__init__(exp, parentName, name=name, startType=startType, startVal=startVal,
                         stopType=stopType, stopVal=stopVal, startEstim=startEstim,
                         durationEstim=durationEstim, saveStartStop=saveStartStop,
                         syncScreenRefresh=syncScreenRefresh, disabled=disabled)
        self.type = "ThermalCue"
        self.url = "https://github.com/thermocue/thermocue/blob/main/docs/psychopy-plugin.md"
        self.exp.requirePsychopyLibs(["hardware"])
        self.exp.requireImport(importName="ThermalCue", importFrom="experiments.psychopy_plugin")
        self.order += [name for name, *_ in _PARAMS]
        given = dict(profileSource=profileSource, protocol=protocol, participantFile=participantFile,
                     sample=sample, profileFile=profileFile, trigger=trigger,
                     forceThreshold=forceThreshold, contactDuration=contactDuration,
                     forceEndRoutine=forceEndRoutine, url=url, deviceName=deviceName,
                     simulateTouch=simulateTouch, touchAfter=touchAfter)
        for name, val_type, input_type, categ, label, hint, *allowed in _PARAMS:
            extra = {"allowedVals": list(allowed[0])} if allowed else {}   # a list of its own
            self.params[name] = Param(given[name], valType=val_type, inputType=input_type,
                                      categ=categ, **extra, label=_translate(label),
                                      hint=_translate(hint))
        for dep, on, cond in _DEPENDS:
            self.depends.append({"dependsOn": on, "condition": cond, "param": dep,
                                 "true": "show", "false": "hide"})

    # ------------------------------------------------------------------ code
    def writeStartCode(self, buff):
        inits = getInitVals(self.params, "PsychoPy")
        code = (
            "# --- thermal display for %(name)s (thermocue) ---\n"
            "%(name)sDevice = deviceManager.getDevice(%(deviceName)s)\n"
            "if %(name)sDevice is None:\n"
            "    %(name)sDevice = deviceManager.addDevice(\n"
            "        deviceClass='experiments.psychopy_plugin.device.ThermalCueDevice',\n"
            "        deviceName=%(deviceName)s, url=%(url)s, protocol=%(protocol)s or None)\n"
            "%(name)s = ThermalCue(\n"
            "    '%(name)s', %(name)sDevice, source=%(profileSource)s, protocol=%(protocol)s,\n"
            "    participant=%(participantFile)s, profile_file=%(profileFile)s,\n"
            "    trigger=%(trigger)s, force_threshold_N=%(forceThreshold)s,\n"
            "    duration_s=%(contactDuration)s, simulate_touch=%(simulateTouch)s,\n"
            "    touch_after_s=%(touchAfter)s)\n"
            "# neutral on quit (Esc, end of experiment); the device also closes at exit\n"
            "runAtExit.append(%(name)s.stop)\n"
        )
        buff.writeIndentedLines(code % inits)

    def writeRoutineStartCode(self, buff):
        inits = getInitVals(self.params, "PsychoPy")
        if self.params["profileSource"].val == "profile file":
            code = "%(name)s.prepare(profile_file=%(profileFile)s)\n"
        else:
            code = "%(name)s.prepare(sample=%(sample)s)\n"
        buff.writeIndentedLines(
            "# %(name)s: make and upload this routine's profile (checked against the safety limits)\n"
            % inits + code % inits)

    def writeFrameCode(self, buff):
        buff.writeIndented("\n")
        buff.writeIndented("# *%s* updates\n" % self.params["name"])
        indented = self.writeStartTestCode(buff)
        if indented:
            code = (
                "# arm the display: it waits for contact (clock mapped first)\n"
                "%(name)s.start(routineTimer)\n"
            )
            buff.writeIndentedLines(code % self.params)
            buff.setIndentLevel(-indented, relative=True)
        code = (
            "if %(name)s.status == STARTED:\n"
            "    # route the display's messages; its trial has ended?\n"
            "    if %(name)s.poll():\n"
            "        %(name)s.status = FINISHED\n"
        )
        if self.params["forceEndRoutine"].val:
            code += "        continueRoutine = False\n"
        buff.writeIndentedLines(code % self.params)
        indented = self.writeStopTestCode(buff)
        if indented:
            buff.writeIndentedLines("# stop time reached: neutral now (data at routine end)\n"
                                    "%(name)s.stop()\n" % self.params)
            buff.setIndentLevel(-indented, relative=True)

    def writeRoutineEndCode(self, buff):
        code = (
            "# %(name)s: neutral, the display's recording and the clock mapping\n"
            "for _key, _val in %(name)s.end(routineTimer, globalClock).items():\n"
            "    thisExp.addData(_key, _val)\n"
        )
        buff.writeIndentedLines(code % self.params)
        super().writeRoutineEndCode(buff)
