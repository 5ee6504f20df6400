"""Experiment protocols: TOML files validated into typed, frozen objects.

A protocol says everything a session needs that is not about the participant: the samples,
the room and skin temperatures, the display's safe range, the contact settings, the group
rule, how simulated profiles are computed and the blocks of trials.  The paper's two
experiments ship in ``experiments/protocols/`` (``interface_temperature``,
``roughness_recognition``); ``load_protocol("roughness_recognition")`` finds them by name.

Validation is strict: a wrong type, an out-of-range value, a missing key or an unknown key
raises :class:`experiments.errors.ProtocolError` with one line naming the file and the
field, e.g. ``"roughness_recognition.toml: blocks[1].repetitions: expected an integer ≥ 1,
got 'three'"``.  Block indices are 0-based, as in the TOML array.

The protocol's :attr:`Protocol.hash` is the SHA-256 of the parsed content in canonical JSON
(sorted keys, no whitespace), so comments and layout do not change it, and
``parse_protocol(protocol.data)`` (e.g. from ``session.json``) gives the same hash.

One concept, the protocol (its typed objects and how a file becomes them); the generic table
reader it is read with is :mod:`experiments.records` (shared with ``session.json`` and
:class:`~experiments.schedule.TrialSpec`).
"""
from __future__ import annotations

import copy
import hashlib
import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

from experiments.errors import ProtocolError
from experiments.records import TableReader
from experiments.records import TableReader as _Table
from experiments.records import Verbatim as _Note
from experiments.records import number_text as _fmt
from participants_schema import GroupRule
from stimuli import paper

__all__ = [
    "PROTOCOLS_DIR",
    "Protocol",
    "Sample",
    "Environment",
    "SampleMaterial",
    "DisplaySettings",
    "ContactSettings",
    "Simulation",
    "Block",
    "Presentation",
    "load_protocol",
    "parse_protocol",
    "protocol_names",
    "canonical_hash",
    "TableReader",
    "SKIN_SAFE_MIN_C",
    "SKIN_SAFE_MAX_C",
]

#: Folder of the packaged protocols.
PROTOCOLS_DIR = Path(__file__).with_name("protocols")

MODES = paper.MODES
ORDERS = ("random", "by_repetition", "fixed")
BLOCK_ORDERS = ("fixed", "counterbalanced", "random")
SIM_THICKNESS = ("group", "participant")
SIM_METHODS = ("exact", "paper", "paper-as-printed", "numerical")
SIM_TARGET_SIDES = paper.TARGET_SIDES
SIM_RATE_LIMITS = paper.RATE_LIMITS
#: The emulated display's pad face (``experiments.hardware.pad_physics.finger_pad_resistance``):
#: polished copper, R_a 0.4 µm.  The defaults of ``[simulation] pad_roughness_um`` / ``pad_material``.
DEFAULT_PAD_ROUGHNESS_UM = paper.PAD_ROUGHNESS_UM
DEFAULT_PAD_MATERIAL = paper.PAD_MATERIAL
#: Skin-safe bounds of ``[display]`` min_C, max_C and neutral_C (°C).  The pad touches a
#: fingertip for up to ``max_contact_s``: 45 °C is where heat pain begins for most people (the
#: heat-pain threshold region, ~43-47 °C, and the usual ceiling of thermal testers held against
#: skin), and below ~5 °C contact cooling turns painful and risks cold injury.  The paper's range
#: (15-42 °C, the packaged protocols) lies well inside; the device's own hard range may be wider.
SKIN_SAFE_MIN_C = 5.0
SKIN_SAFE_MAX_C = 45.0


# --------------------------------------------------------------------------- typed parts
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

    Field names match ``experiments.hardware.SafetyLimits``: :meth:`safety_limits` builds them.
    ``min_C``, ``max_C`` and ``neutral_C`` must lie in the skin-safe
    [:data:`SKIN_SAFE_MIN_C`, :data:`SKIN_SAFE_MAX_C`] = [5, 45] °C.
    """

    min_C: float
    max_C: float
    max_rate_C_per_s: float
    neutral_C: float

    def safety_limits(self):
        """These settings as the display driver's :class:`~experiments.hardware.safety.SafetyLimits`."""
        import dataclasses

        from experiments.hardware.safety import SafetyLimits
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
    """

    force_threshold_N: float
    max_contact_s: float
    record_s: float
    trial_timeout_s: float
    rewarm_s: float


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
    """

    instructions_key: bool = True
    instructions_min_s: float = 2.0
    text_min_s: float = 1.0
    answer_during_contact: bool = False
    feedback_s: float = 1.5


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
        from stimuli import Skin, contact_resistance, material
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


# --------------------------------------------------------------------------- validation
#: Upper bounds, so that no value can hang or overflow a session (issue 16): ids and versions,
MAX_ID = 1_000_000
#: presentations of one sample in a block, trials in a whole session,
MAX_REPETITIONS = 1000
MAX_TRIALS = 5000
#: and any wait (contact time-out, rewarming), s.
MAX_WAIT_S = 3600.0
_WAIT_WHY = "at most an hour: longer is a typo, and a real clock cannot wait it"
_SKIN_WHY = "µm of fingertip skin: at most 1 cm"


def _pad_material(s: _Table) -> str:
    """``[simulation] pad_material``: a ``stimuli.MATERIALS`` name (aliases allowed)."""
    from stimuli import MATERIALS, ModelInputError, material
    name = s.string("pad_material", DEFAULT_PAD_MATERIAL)
    try:
        material(name)
    except ModelInputError:
        s.fail("pad_material", "one of " + ", ".join(repr(k) for k in sorted(MATERIALS)), name)
    return name


def _read_samples(top: _Table) -> tuple[Sample, ...]:
    out, ids, labels = [], set(), set()
    for t in top.tables("samples"):
        sid = t.integer("id", ge=0, le=MAX_ID)
        label = t.string("label", str(sid))
        r = t.number("roughness_um", gt=0, le=10_000, why="Ra beyond 1 cm is no surface finish")
        t.done()
        if sid in ids:
            t.fail("id", "an id not used by another sample", sid)
        if label in labels:
            t.fail("label", "a label not used by another sample", label)
        ids.add(sid)
        labels.add(label)
        out.append(Sample(sid, label, r))
    return tuple(out)


def _read_blocks(top: _Table, samples: tuple[Sample, ...]) -> tuple[Block, ...]:
    ids = [s.id for s in samples]
    out, names = [], set()
    for t in top.tables("blocks"):
        name = t.string("name")
        if name in names:
            t.fail("name", "a name not used by another block", name)
        names.add(name)
        mode = t.string("mode", choices=MODES)
        reps = t.integer("repetitions", ge=1, le=MAX_REPETITIONS,
                         why="a session is at most a few hundred trials")
        order = t.string("order", "random", choices=ORDERS)
        chosen = t._get("samples", list(ids), "a list of sample ids")
        if not isinstance(chosen, list) or not chosen or any(
                isinstance(c, bool) or not isinstance(c, int) for c in chosen):
            t.fail("samples", "a non-empty list of sample ids", chosen)
        for c in chosen:
            if c not in ids:
                t.fail("samples", f"ids of listed samples ({', '.join(map(str, ids))})", c)
        if len(set(chosen)) != len(chosen):
            t.fail("samples", "each sample id once", chosen)
        response = t.boolean("response", True)
        scored = t.boolean("scored", response)
        if scored and not response:
            t.fail("scored", "false when response = false", scored)
        feedback = t.boolean("feedback", False)
        nir = t.boolean("no_immediate_repeats", False)
        if nir and len(chosen) < 2 and reps > 1:
            t.fail("no_immediate_repeats", "false with a single sample", nir)
        instructions = t.string("instructions", "", nonempty=False)
        t.done()
        out.append(Block(name, mode, reps, order, tuple(chosen), scored, feedback, response,
                         nir, instructions))
    return tuple(out)


def _build(source: str, data: Any, path: Path | None) -> Protocol:
    top = _Table(source, data, "")
    p = top.table("protocol")
    name = p.string("name")
    title = p.string("title", name)
    description = p.string("description", "", nonempty=False).strip()
    experiment = p.integer("experiment", 0, ge=0, le=MAX_ID)
    version = p.integer("version", 1, ge=1, le=MAX_ID)
    p.done()

    e = top.table("environment")
    env = Environment(
        room_temperature_C=e.number("room_temperature_C", ge=-10, le=50),
        skin_temperature_min_C=e.number("skin_temperature_min_C", ge=20, le=42),
        skin_temperature_max_C=e.number("skin_temperature_max_C", ge=20, le=42),
        measure_skin_temperature=e.boolean("measure_skin_temperature", True),
    )
    if env.skin_temperature_max_C < env.skin_temperature_min_C:
        e.fail("skin_temperature_max_C",
               f"a number ≥ skin_temperature_min_C ({_fmt(env.skin_temperature_min_C)})",
               env.skin_temperature_max_C)
    e.done()

    m = top.table("material")
    mat = SampleMaterial(m.string("name"), m.number("thickness_mm", None, gt=0, le=1000,
                                                    why="a sample a finger can touch"))
    m.done()

    samples = _read_samples(top)

    c = top.table("contact")
    contact = ContactSettings(
        force_threshold_N=c.number("force_threshold_N", gt=0, le=50),
        max_contact_s=c.number("max_contact_s", gt=0, le=600),
        record_s=c.number("record_s", gt=0, le=600),
        trial_timeout_s=c.number("trial_timeout_s", gt=0, le=MAX_WAIT_S, why=_WAIT_WHY),
        rewarm_s=c.number("rewarm_s", ge=0, le=MAX_WAIT_S, why=_WAIT_WHY),
    )
    if contact.record_s > contact.max_contact_s:
        c.fail("record_s", f"a number ≤ max_contact_s ({_fmt(contact.max_contact_s)})", contact.record_s)
    c.done()

    d = top.table("display")
    display = DisplaySettings(
        min_C=d.number("min_C", ge=SKIN_SAFE_MIN_C, le=SKIN_SAFE_MAX_C),
        max_C=d.number("max_C", ge=SKIN_SAFE_MIN_C, le=SKIN_SAFE_MAX_C),
        max_rate_C_per_s=d.number("max_rate_C_per_s", gt=0, le=100),
        neutral_C=d.number("neutral_C", ge=SKIN_SAFE_MIN_C, le=SKIN_SAFE_MAX_C),
    )
    if not display.max_C > display.min_C:
        d.fail("max_C", f"a number > min_C ({_fmt(display.min_C)})", display.max_C)
    if not display.min_C <= display.neutral_C <= display.max_C:
        d.fail("neutral_C", f"a number from min_C to max_C ({_fmt(display.min_C)}-{_fmt(display.max_C)})",
               display.neutral_C)
    d.done()

    grouping = None
    g = top.table("grouping", required=False)
    if g is not None:
        below = g.string("below", "A")
        above = g.string("above", "B")
        if above == below:
            g.fail("above", "a group name different from below", above)
        grouping = GroupRule(threshold_um=g.number("threshold_um", gt=0, le=10_000, why=_SKIN_WHY),
                             margin_um=g.number("margin_um", 50.0, ge=0, le=10_000, why=_SKIN_WHY),
                             below=below, above=above)
        g.done()

    simulation = None
    s = top.table("simulation", required=False)
    if s is not None:
        how = s.string("skin_thickness", "group", choices=SIM_THICKNESS)
        gst = s.table("group_skin_thickness_um", required=(how == "group"))
        per_group = {}
        if gst is not None:
            for key in list(gst.data):
                per_group[key] = gst.number(key, gt=0, le=10_000, why=_SKIN_WHY)
            gst.done()
        if how == "group":
            if grouping is None:
                s.fail("skin_thickness", "'participant' when the protocol has no [grouping]", how)
            for grp in (grouping.below, grouping.above):
                if grp not in per_group:
                    gst.fail(grp, "the group's skin thickness in µm, a number > 0")
        simulation = Simulation(
            skin_thickness=how,
            group_skin_thickness_um=per_group,
            dermis_fraction=s.number("dermis_fraction", 0.6, gt=0, lt=1),
            skin_temperature_C=s.number("skin_temperature_C", ge=20, le=42),
            material_temperature_C=s.number("material_temperature_C", ge=-10, le=60),
            duration_s=s.number("duration_s", gt=0, le=600),
            rate_Hz=s.number("rate_Hz", 100.0, gt=0, le=10000),
            resolution_C=s.number("resolution_C", 0.01, gt=0, le=1),
            method=s.string("method", "exact", choices=SIM_METHODS),
            target_side=s.string("target_side", "material", choices=SIM_TARGET_SIDES),
            pad_roughness_um=s.number("pad_roughness_um", DEFAULT_PAD_ROUGHNESS_UM, ge=0, le=1000),
            pad_material=_pad_material(s),
            rate_limit=s.string("rate_limit", "refuse", choices=SIM_RATE_LIMITS),
            max_tracking_error_C=s.number("max_tracking_error_C", 1.0, gt=0, le=10),
        )
        s.done()

    sch = top.table("schedule", required=False)
    block_order = "fixed"
    if sch is not None:
        block_order = sch.string("block_order", "fixed", choices=BLOCK_ORDERS)
        sch.done()

    presentation = Presentation()
    pr = top.table("presentation", required=False)
    if pr is not None:
        presentation = Presentation(
            instructions_key=pr.boolean("instructions_key", True),
            instructions_min_s=pr.number("instructions_min_s", 2.0, ge=0, le=600),
            text_min_s=pr.number("text_min_s", 1.0, ge=0, le=60),
            answer_during_contact=pr.boolean("answer_during_contact", False),
            feedback_s=pr.number("feedback_s", 1.5, ge=0, le=60),
        )
        pr.done()

    blocks = _read_blocks(top, samples)
    n_trials = sum(b.n_trials for b in blocks)
    if n_trials > MAX_TRIALS:
        top.fail("blocks", f"at most {MAX_TRIALS} trials in all (samples × repetitions; a session "
                           f"is hours, not days)", _Note(f"{n_trials} trials"))
    if simulation is None:
        for i, b in enumerate(blocks):
            if b.mode == "simulated":
                raise ProtocolError(f"{source}: simulation: expected a [simulation] table because "
                                    f"blocks[{i}] is simulated, got nothing")
    top.done()

    canonical = _canonical(data)
    return Protocol(name=name, title=title, description=description, experiment=experiment,
                    version=version, samples=samples, environment=env, material=mat,
                    contact=contact, display=display, grouping=grouping, simulation=simulation,
                    block_order=block_order, blocks=blocks, presentation=presentation,
                    hash=hashlib.sha256(canonical).hexdigest(), path=path,
                    data=copy.deepcopy(dict(data)))


def _canonical(data: Any) -> bytes:
    return json.dumps(data, sort_keys=True, separators=(",", ":"), ensure_ascii=False,
                      allow_nan=False).encode("utf-8")


def canonical_hash(data: Mapping[str, Any]) -> str:
    """SHA-256 hex of ``data`` in canonical JSON (sorted keys, no whitespace, UTF-8)."""
    return hashlib.sha256(_canonical(data)).hexdigest()


# --------------------------------------------------------------------------- entry points
def protocol_names() -> list[str]:
    """Names of the packaged protocols (``experiments/protocols/*.toml``)."""
    return sorted(p.stem for p in PROTOCOLS_DIR.glob("*.toml"))


def _resolve(path_or_name: str | Path) -> tuple[Path, str]:
    p = Path(path_or_name)
    if p.is_file():
        return p, str(path_or_name)
    text = str(path_or_name)
    if isinstance(path_or_name, str) and "/" not in text and "\\" not in text and not text.endswith(".toml"):
        packaged = PROTOCOLS_DIR / f"{text}.toml"
        if packaged.is_file():
            return packaged, packaged.name
    raise ProtocolError(f"{text}: expected a protocol file or one of the packaged protocols "
                        f"({', '.join(protocol_names())}), got no such file")


def load_protocol(path_or_name: str | Path) -> Protocol:
    """Read and validate a protocol.

    Parameters
    ----------
    path_or_name : str or Path
        A TOML file, or the bare name of a packaged protocol
        (``"roughness_recognition"``, ``"interface_temperature"``).

    Returns
    -------
    Protocol

    Raises
    ------
    ProtocolError
        One line naming the file and the field, for a missing file, a TOML syntax error,
        a missing, unknown, mistyped or out-of-range key.

    Examples
    --------
    >>> p = load_protocol("roughness_recognition")
    >>> [s.label for s in p.samples], [b.name for b in p.blocks]
    (['1#', '2#', '3#', '4#'], ['familiarise', 'real', 'simulated'])
    >>> p.simulation.skin_thickness_for("A"), p.grouping.threshold_um
    (650.0, 800.0)
    """
    path, source = _resolve(path_or_name)
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
        text = raw.decode("utf-8")
        data = tomllib.loads(text)
    except UnicodeDecodeError as exc:
        raise ProtocolError(f"{source}: expected UTF-8 text, got byte 0x{raw[exc.start]:02x} at "
                            f"offset {exc.start}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ProtocolError(f"{source}: expected valid TOML, got {exc}") from None
    except OSError as exc:
        raise ProtocolError(f"{source}: expected a readable file, got {exc.strerror}") from None
    return _build(source, data, path)


def parse_protocol(data: Mapping[str, Any], source: str = "<protocol>", path: Path | None = None) -> Protocol:
    """Validate an already-parsed protocol (e.g. ``session.json``'s copy).

    Parameters
    ----------
    data : dict
        The content of a protocol file, as :attr:`Protocol.data`.
    source : str
        Name used in error messages.
    path : Path, optional
        Recorded as :attr:`Protocol.path`.

    Returns
    -------
    Protocol
        With the same :attr:`~Protocol.hash` as the file ``data`` came from.
    """
    return _build(source, data, path)
