"""Helpers for the session tests: a short protocol, participant records, a scripted responder,
and a scripted stand-in display for the engine's unit tests (the emulator is used elsewhere)."""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from experiments.errors import DisplayError, DisplayTimeout
from experiments.display.thermocue.driver import TrialRecording
from experiments.display.base import EmulatedDisplay
from experiments.display.types import DeviceInfo, Status, Telemetry
from experiments.responders.base import Responder, Response

ROOT = Path(__file__).resolve().parents[2]
P01 = ROOT / "participants" / "examples" / "P01.json"

MINI_PROTOCOL = """
[protocol]
name = "{name}"
title = "{title}"

[environment]
room_temperature_C = 20.0
skin_temperature_min_C = 35.5
skin_temperature_max_C = 36.0

[material]
name = "stainless_steel"
thickness_mm = 3.0

[[samples]]
id = 1
label = "1#"
roughness_um = 1.6

[[samples]]
id = 2
label = "2#"
roughness_um = 12.5

[[samples]]
id = 3
label = "3#"
roughness_um = 50.0

[[samples]]
id = 4
label = "4#"
roughness_um = 100.0

[contact]
force_threshold_N = 2.0
max_contact_s = {contact_s}
record_s = {contact_s}
trial_timeout_s = 5.0
rewarm_s = {rewarm_s}

[display]
min_C = 15.0
max_C = 42.0
max_rate_C_per_s = 10.0
neutral_C = 32.0

[grouping]
threshold_um = 800.0
margin_um = 50.0

[simulation]
skin_thickness = "group"
group_skin_thickness_um = {{ A = 650.0, B = 1000.0 }}
skin_temperature_C = 35.5
material_temperature_C = 20.0
duration_s = {contact_s}
rate_Hz = 50.0
resolution_C = 0.01
method = "exact"

[[blocks]]
name = "real"
mode = "real"
repetitions = {real_reps}
samples = {real_samples}
order = "random"

[[blocks]]
name = "simulated"
mode = "simulated"
repetitions = {sim_reps}
samples = {sim_samples}
order = "random"
"""


def write_protocol(folder: Path, *, contact_s=1.0, rewarm_s=0.0, real_samples=(1, 2, 3, 4),
                   sim_samples=(1, 2, 3, 4), name="mini.toml", real_reps=1, sim_reps=1,
                   protocol_name="mini", title="A short session for tests") -> Path:
    """A protocol with a real and a simulated block over the paper's four samples.

    Also the fault campaign's protocol (``benchmarks/fault_campaign.py`` imports this helper).
    """
    text = MINI_PROTOCOL.format(contact_s=contact_s, rewarm_s=rewarm_s,
                                real_samples=list(real_samples), sim_samples=list(sim_samples),
                                real_reps=real_reps, sim_reps=sim_reps, name=protocol_name,
                                title=title)
    if not sim_samples:
        text = text.split("[[blocks]]\nname = \"simulated\"")[0]
    if not real_samples:
        head, _, rest = text.partition("[[blocks]]\nname = \"real\"")
        text = head + rest[rest.index("[[blocks]]"):]
    path = Path(folder) / name
    path.write_text(text, encoding="utf-8")
    return path


class ScriptedResponder(Responder, name="scripted-test"):
    """Answers from a fixed list (cycled) and drives the emulator's finger like a person."""

    human = False

    def __init__(self, answers=(1, 2, 3, 4), rt_s=0.5, press=True):
        super().__init__()
        self.answers = list(answers)
        self.rt_s = rt_s
        self.press = press
        self.calls = []
        self.n = 0

    def begin_session(self, session):
        super().begin_session(session)
        self.calls.append(("begin",))

    def end_session(self):
        self.calls.append(("end",))

    def prompt_experimenter(self, text):
        self.calls.append(("prompt", text))

    def cue(self):
        self.calls.append(("cue",))
        return True

    def touch(self, trial, display):
        self.calls.append(("touch", trial.trial_index))
        if self.press:
            self.session.emulated_touch(trial, display)

    def respond(self, trial, stimulus):
        answer = self.answers[self.n % len(self.answers)]
        self.n += 1
        self.calls.append(("respond", trial.trial_index, stimulus.status, len(stimulus.time_s)))
        return Response(answer, self.rt_s, source="scripted")


# --------------------------------------------------------------------------- stand-in display
def Info():
    return DeviceInfo(device_id="scripted", firmware="0", capabilities=("sim",), telemetry_hz=10.0,
                      hard_min_C=10.0, hard_max_C=44.5, max_rate_C_per_s=100.0, neutral_C=32.0,
                      max_points=65536, min_dt_s=0.001)


@dataclass
class ScriptedDisplay(EmulatedDisplay):
    """Follows the driver's contract (a subclass of :class:`experiments.display.base.EmulatedDisplay`,
    frames and recordings of the contract's types); ``script`` says per run_trial call what happens:
    ``"ok"``, ``"fault"`` (faulted recording), ``"raise"`` (DisplayError), ``"timeout"``
    (DisplayTimeout) or ``"no_contact"``."""

    script: list = field(default_factory=list)
    calls: list = field(default_factory=list)
    info: Info = field(default_factory=Info)
    n_runs: int = 0
    mode: str = "playback"
    #: The real driver's host-side check, so an engine test cannot upload what a display refuses.
    limits: object = None

    def set_neutral(self, c):
        self.calls.append(("set_neutral", c))

    def upload_profile(self, t, y):
        from experiments.display.safety import SafetyLimits, check_profile
        check_profile(t, y, self.limits or SafetyLimits())
        self.calls.append(("upload", len(t)))

    def arm(self, **kw):
        self.mode = kw["mode"]
        self.calls.append(("arm", kw["mode"]))

    def abort(self):
        self.calls.append(("abort",))

    def sim_sample(self, **kw):
        self.calls.append(("sim_sample", kw["roughness_m"]))

    def sim_finger(self, **kw):
        self.calls.append(("sim_finger",))

    def poll(self, on_telemetry=None, on_event=None):
        return False

    def status(self):
        return Status("IDLE", None, 0.0, 32.0, 32.0, 20.0, 35.0, (0.0,) * 4, 32.0, 0, None, None,
                      self.n_runs)

    def heartbeat(self):
        return 0.0

    def close(self):
        pass

    def run_trial(self, timeout_s, on_telemetry=None):
        what = self.script[self.n_runs] if self.n_runs < len(self.script) else "ok"
        self.n_runs += 1
        self.calls.append(("run_trial", what))
        if what == "raise":
            raise DisplayError("serial link lost")
        if what == "timeout":
            raise DisplayTimeout("no answer in 1 s")
        if what == "no_contact":
            for i in range(3):
                on_telemetry(Telemetry(i, i * 0.1, 32.0, 32.0, 20.0, 35.0, (0.0,) * 4, "ARMED", None))
            return TrialRecording("fault", "TRIAL_TIMEOUT", "no end of trial within 5 s", None, 3, 0,
                                  None, None, mode=self.mode)
        for i in range(10):
            state = "ARMED" if i < 2 else "RECORDING"
            on_telemetry(Telemetry(i, i * 0.1, 30.0, 30.1, 20.0, 35.0, (0.5,) * 4, state, None))
        if what == "fault":
            return TrialRecording("fault", "OVER_TEMPERATURE", "pad above limit", 0.2, 10, 0, 0.1, 0.2,
                                  mode=self.mode, end_reason="fault")
        return TrialRecording("ok", None, None, 0.2, 10, 0, 0.05, 0.1, mode=self.mode,
                              end_reason="complete")


def read_json_lines(path):
    return [json.loads(line) for line in Path(path).read_text().splitlines() if line.strip()]
