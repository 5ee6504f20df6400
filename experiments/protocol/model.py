"""The protocol's typed parts: frozen dataclasses a validated protocol is made of.

One concept, what a protocol holds (:class:`Protocol` and its parts) and the names its fields may
take; how a file becomes them is :mod:`experiments.protocol.build`.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

from participants_schema import GroupRule
from stimuli import paper

MODES = paper.MODES
ORDERS = ("random", "by_repetition", "fixed")
BLOCK_ORDERS = ("fixed", "counterbalanced", "random")
SIM_THICKNESS = ("group", "participant")
SIM_METHODS = ("exact", "paper", "paper-as-printed", "numerical")
SIM_TARGET_SIDES = paper.TARGET_SIDES
SIM_RATE_LIMITS = paper.RATE_LIMITS
#: How the finger meets the display: ``press`` (the finger presses on a pad already at the
#: profile's start, the paper's display) or ``resting`` (the probe rests on the skin at the
#: neutral temperature, a thermode such as the TCS II: the profile starts at skin temperature).
SIM_CONTACT_MODELS = ("press", "resting")
#: ``[simulation] replayed_material``: the profile is computed for the protocol's sample
#: (``[material]``, e.g. a 3 mm slab) or for a half-space of the same material (the closed forms).
SIM_REPLAYED_MATERIALS = ("sample", "half-space")
#: The emulated display's pad face (``experiments.emulators.thermocue.pad_physics.finger_pad_resistance``):
#: polished copper, R_a 0.4 µm.  The defaults of ``[simulation] pad_roughness_um`` / ``pad_material``.
DEFAULT_PAD_ROUGHNESS_UM = paper.PAD_ROUGHNESS_UM
DEFAULT_PAD_MATERIAL = paper.PAD_MATERIAL


@dataclass(frozen=True)
class Sample:
    """A physical sample (or the roughness class a simulated trial stands for).

    Attributes
    ----------
    id : int
        Number used in responses and logs (``roughness_id``; 1..4 for 1#-4#).
    label : str
        What the experimenter and participant see, e.g. ``"2#"``.
    roughness_um : float, µm
        Ra of the surface.
    """

    id: int
    label: str
    roughness_um: float

    @property
    def roughness_m(self) -> float:
        """Ra in metres."""
        return self.roughness_um * 1e-6


@dataclass(frozen=True)
class Environment:
    """Room and skin conditions (°C)."""

    room_temperature_C: float
    skin_temperature_min_C: float
    skin_temperature_max_C: float
    measure_skin_temperature: bool = True


@dataclass(frozen=True)
class SampleMaterial:
    """The samples' material (a name in ``stimuli.MATERIALS``) and thickness (mm)."""

    name: str
    thickness_mm: float | None = None

    @property
    def thickness_m(self) -> float | None:
        """Thickness in metres (None: a half-space)."""
        return None if self.thickness_mm is None else self.thickness_mm * 1e-3


@dataclass(frozen=True)
class DisplaySettings:
    """The Peltier display's safe range, rate limit and neutral setpoint.

    Field names match ``experiments.display.SafetyLimits``: :meth:`safety_limits` builds them.
    ``min_C``, ``max_C`` and ``neutral_C`` must lie in the skin-safe
    [:data:`~experiments.protocol.limits.SKIN_SAFE_MIN_C`, :data:`~experiments.protocol.limits.SKIN_SAFE_MAX_C`]
    = [5, 45] °C.
    """

    min_C: float
    max_C: float
    max_rate_C_per_s: float
    neutral_C: float

    def safety_limits(self):
        """These settings as the display driver's :class:`~experiments.display.safety.SafetyLimits`."""
        # lazy: the hardware package is the driver's layer, not needed to read a protocol
        from experiments.display.safety import SafetyLimits
        return SafetyLimits(**dataclasses.asdict(self))


@dataclass(frozen=True)
class ContactSettings:
    """How a touch is detected and how long it lasts.

    Attributes
    ----------
    force_threshold_N : float, N
        Contact starts when the force reaches this.
    max_contact_s : float, s
        Longest contact per trial.
    record_s : float, s
        Length of the recorded contact trace (≤ ``max_contact_s``).
    trial_timeout_s : float, s
        No contact within this time: the attempt is aborted.
    rewarm_s : float, s
        Rewarming interval between trials (hand on the hot-water bag).
    max_attempts : int
        A trial is attempted at most this many times in one run of the session (default 3):
        once it has failed that often the session stops, resumable, with one line.
    """

    force_threshold_N: float
    max_contact_s: float
    record_s: float
    trial_timeout_s: float
    rewarm_s: float
    max_attempts: int = 3


@dataclass(frozen=True)
class Presentation:
    """What the participant's screen does (optional ``[presentation]`` table).

    Attributes
    ----------
    instructions_key : bool
        Block instructions stay on screen until the participant presses a key (space), accepted
        once they have been shown ``instructions_min_s``; false: shown for ``instructions_min_s``.
    instructions_min_s : float, s
        Shortest time block instructions are on screen.
    text_min_s : float, s
        Shortest time any other text (please wait, label, cue, question, feedback) is on
        screen before the next one replaces it.
    answer_during_contact : bool
        The question is asked from the moment of contact, while the participant still touches
        (the paper: "when making contact with a sample they were instructed to judge it");
        false: after the contact trace has been recorded.
    feedback_s : float, s
        How long the feedback text of a block with ``feedback = true`` and ``response = true``
        stays on screen.
    answer_mode : {"keyed", "spoken"}
        ``"keyed"``: the participant reads the screen and presses 1-4 (``rt_s``);
        ``"spoken"`` (the paper's procedure): the participant's screen stays blank, sound cues
        mark the touch and the question, the participant says the answer and the experimenter
        keys it (with a confirm/undo step), timed from the question's cue to the key
        (``answer_keyed_after_cue_s``, not a response time).
    """

    instructions_key: bool = True
    instructions_min_s: float = 2.0
    text_min_s: float = 1.0
    answer_during_contact: bool = False
    feedback_s: float = 1.5
    answer_mode: str = "keyed"


@dataclass(frozen=True)
class Simulation:
    """How the target profiles of simulated trials are computed.

    Attributes
    ----------
    skin_thickness : {"group", "participant"}
        ``"group"``: the group's mean thickness (the paper: 650 µm A, 1000 µm B);
        ``"participant"``: the participant's own ``skin_thickness.total_um``.
    group_skin_thickness_um : dict of str to float, µm
    dermis_fraction : float
        d / L, depth of the thermoreceptors as a fraction of the skin thickness.
    skin_temperature_C, material_temperature_C : float, °C
    duration_s : float, s
    rate_Hz : float, Hz
    resolution_C : float, °C
    method : str
        ``stimuli`` method name.
    target_side : {"material", "skin", "compensated"}
        Which temperature the display replays (``stimuli.target_profile(side=...)``):
        ``"material"`` the material side of the interface, the paper's Eq. 7 (default);
        ``"skin"`` the skin side; ``"compensated"`` the pad temperature that, through the
        finger–pad contact resistance, reproduces the real contact at the skin.
    pad_roughness_um : float, µm
        R_a of the display's contact face (its contact sensor surface); with ``pad_material``
        and the profile's skin it gives the finger–pad resistance by Eq. 5.
    pad_material : str
        What the finger touches on the pad (a ``stimuli.MATERIALS`` name).
    rate_limit : {"refuse", "slew"}
        A profile faster than ``[display] max_rate_C_per_s``: ``"refuse"`` (default) leaves it to
        the display's check, which refuses it (the trial faults); ``"slew"`` slows it to the limit
        (:func:`experiments.profile_rate.limit_rate`) and logs the largest change.
    max_tracking_error_C : float, °C
        Largest |contact − target| of a delivered playback (default 1): a trial the display
        tracked worse is a flagged attempt, run again (the participant did not feel the
        profile asked for).
    contact_model : {"press", "resting"}
        ``"press"`` (default): the finger presses on a pad held at the profile's first sample
        (the paper's display; contact by force). ``"resting"``: the probe already rests on the
        skin at ``[display] neutral_C`` (which must equal ``skin_temperature_C``); the profile
        starts at the skin temperature and reaches the target as fast as ``[display]
        max_rate_C_per_s`` allows (:func:`experiments.contact_model.resting_profile`).
    replayed_material : {"sample", "half-space"}
        The material the profile is computed for: ``"sample"`` (default) the protocol's
        ``[material]`` with its thickness; ``"half-space"`` the same material without a back
        face (what the paper's closed forms, Eq. 7 among them, assume). Real trials always
        touch the protocol's sample.
    """

    skin_thickness: str
    group_skin_thickness_um: Mapping[str, float]
    dermis_fraction: float
    skin_temperature_C: float
    material_temperature_C: float
    duration_s: float
    rate_Hz: float
    resolution_C: float
    method: str
    target_side: str = "material"
    pad_roughness_um: float = DEFAULT_PAD_ROUGHNESS_UM
    pad_material: str = DEFAULT_PAD_MATERIAL
    rate_limit: str = "refuse"
    max_tracking_error_C: float = 1.0
    contact_model: str = "press"
    replayed_material: str = "sample"

    @property
    def pad_roughness_m(self) -> float:
        """R_a of the pad's contact face, m."""
        return self.pad_roughness_um * 1e-6

    def pad_resistance(self, skin=None) -> float:
        """Finger–pad contact resistance, m² K/W: Eq. 5 (``stimuli.contact_resistance``) of the pad.

        Parameters
        ----------
        skin : stimuli.Skin, optional
            Supplies the skin conductivity (default: ``stimuli.Skin`` defaults).
        """
        from stimuli import Skin, contact_resistance, material  # lazy: numpy/scipy
        return float(contact_resistance(self.pad_roughness_m, skin=Skin(1e-3) if skin is None else skin,
                                        material=material(self.pad_material)))

    def skin_thickness_for(self, group: str, participant_thickness_um: float | None = None) -> float:
        """The skin thickness (µm) to simulate for a participant of ``group``."""
        if self.skin_thickness == "participant":
            if participant_thickness_um is None:
                raise ValueError("simulation.skin_thickness is 'participant' but no thickness was given")
            return float(participant_thickness_um)
        try:
            return float(self.group_skin_thickness_um[group])
        except KeyError:
            raise ValueError(f"simulation.group_skin_thickness_um: expected a value for group "
                             f"{group!r}, got none") from None


@dataclass(frozen=True)
class Block:
    """A block of trials.

    Attributes
    ----------
    name : str
        Unique; the ``block`` column of the trials table (``"familiarise"`` is excluded
        from the analysis).
    mode : {"real", "simulated"}
    repetitions : int
        Presentations of each sample.
    order : {"random", "by_repetition", "fixed"}
        ``random``: all presentations shuffled together; ``by_repetition``: each repetition
        is a shuffled pass over the samples; ``fixed``: samples in listed order, repeated.
    samples : tuple of int
        Sample ids used (default all, in the protocol's order).
    scored : bool
        Counted in the analysis (default: same as ``response``).
    feedback : bool
        The participant is told the sample's label: before the touch when ``response`` is
        false (familiarisation, the label stays up for the whole touch), after the answer when
        it is true (correct or not, and which sample it was).
    response : bool
        A response (1..n) is asked for.
    no_immediate_repeats : bool
        With a shuffled order, the same sample never comes twice in a row.
    instructions : str
    """

    name: str
    mode: str
    repetitions: int
    order: str
    samples: tuple[int, ...]
    scored: bool = True
    feedback: bool = False
    response: bool = True
    no_immediate_repeats: bool = False
    instructions: str = ""

    @property
    def n_trials(self) -> int:
        """Trials in the block."""
        return len(self.samples) * self.repetitions


#: Default of ``[analysis] equivalence_margin_pp``: +-10 percentage points of proportion
#: correct (real - simulated, averaged over the samples). ``analysis.fidelity`` holds the same
#: number (it may not import the experiment runtime); a test checks they agree.
DEFAULT_EQUIVALENCE_MARGIN_PP = 10.0


@dataclass(frozen=True)
class AnalysisSettings:
    """What the analysis needs from the protocol (``[analysis]``, optional).

    Attributes
    ----------
    equivalence_margin_pp : float, percentage points
        Margin of the real-vs-simulated equivalence test: simulated samples count as
        recognised as well as real ones when the real - simulated difference of mean
        proportions correct is shown to lie within +-this (two one-sided tests). In (0, 50).
    """

    equivalence_margin_pp: float = DEFAULT_EQUIVALENCE_MARGIN_PP


@dataclass(frozen=True)
class Protocol:
    """A validated protocol.

    Attributes
    ----------
    name, title, description : str
    experiment : int
        The paper's experiment number (informative).
    version : int
    samples : tuple of Sample
    environment : Environment
    material : SampleMaterial
    contact : ContactSettings
    display : DisplaySettings
    grouping : participants_schema.GroupRule or None
    simulation : Simulation or None
        Required when a block is simulated.
    block_order : {"fixed", "counterbalanced", "random"}
        How scored blocks are ordered per participant (unscored blocks keep their place).
    blocks : tuple of Block
    presentation : Presentation
        The participant's screen: minimum text durations, instructions, answer timing.
    analysis : AnalysisSettings
        The analysis's protocol-stated parameters (the equivalence margin).
    authors : tuple of str
        ``[protocol] authors``: the study's authors (the BIDS dataset's ``Authors``); may be empty.
    hash : str
        SHA-256 hex of the canonical JSON of :attr:`data`.
    path : Path or None
        The file it was read from.
    data : dict
        The parsed content (JSON-ready); store it in session.json and rebuild with
        :func:`parse_protocol`.  Treat as read-only.
    """

    name: str
    title: str
    description: str
    experiment: int
    version: int
    samples: tuple[Sample, ...]
    environment: Environment
    material: SampleMaterial
    contact: ContactSettings
    display: DisplaySettings
    grouping: GroupRule | None
    simulation: Simulation | None
    block_order: str
    blocks: tuple[Block, ...]
    hash: str
    path: Path | None
    data: dict
    presentation: Presentation = Presentation()
    analysis: AnalysisSettings = AnalysisSettings()
    authors: tuple[str, ...] = ()

    def sample(self, sample_id: int) -> Sample:
        """The sample with this id (KeyError if none)."""
        for s in self.samples:
            if s.id == sample_id:
                return s
        raise KeyError(sample_id)

    def block(self, name: str) -> Block:
        """The block with this name (KeyError if none)."""
        for b in self.blocks:
            if b.name == name:
                return b
        raise KeyError(name)

    @property
    def n_trials(self) -> int:
        """Trials in a whole session."""
        return sum(b.n_trials for b in self.blocks)

