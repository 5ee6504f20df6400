"""The columns of ``trials.csv``: one declarative table (standard library only).

Every column the session writes to ``trials.csv`` is one :class:`Column` of :data:`TRIALS`, in
the file's order: its name, its group (identity, design, stimulus, response, timing, quality,
force), its type, its unit, the decimals it is written with, its domain (what a reader accepts),
its meaning, and whether analysis reads it. Everything else is derived from this table:

* the writer's column list and cell format (:data:`sessionfiles.logformat.TRIAL_COLUMNS`,
  ``COLUMN_DECIMALS``, ``PSYCHOPY_COLUMNS``, ``STATUSES``);
* the reader's checks (:data:`sessionfiles.session_reader.DOMAIN`);
* analysis' typing of the rows (``REQUIRED_COLUMNS``, ``OPTIONAL_COLUMNS``, :data:`QUIET_COLUMNS`
  used by :func:`analysis.trial_rows.validate_rows`) and its codebook's entries
  (:data:`CODEBOOK`, in :data:`analysis.exports.COLUMNS`);
* the BIDS sidecar's descriptions and units (:data:`DESCRIPTIONS`, ``experiments.bids``);
* the table in docs/session.md ("The trial table"), :func:`markdown_table` (a test compares).

A new column is one entry here (plus the code that fills it).
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Column", "TRIALS", "STATUSES", "MODES", "CATEGORY", "column", "names",
           "ANALYSIS_ORDER", "QUIET_COLUMNS", "CODEBOOK", "DESCRIPTIONS", "markdown_table"]

#: Values of the ``status`` column.
STATUSES = ("ok", "fault", "aborted")
#: Values of the ``mode`` column.
MODES = ("real", "simulated", "familiarise")
#: The codebook's unit of a column of names or codes.
CATEGORY = "category"

GROUPS = ("identity", "design", "stimulus", "response", "timing", "quality", "force")
KINDS = ("str", "int", "float", "flag")
ANALYSIS_ROLES = (None, "required", "optional", "quiet")


@dataclass(frozen=True)
class Column:
    """One column of ``trials.csv``.

    Parameters
    ----------
    name : str
        Its header (SI-unit suffix ``_C``, ``_um``, ``_s``, ``_N`` where it has a unit).
    group : str
        One of :data:`GROUPS` (docs/session.md lists the columns by group).
    kind : str
        ``"str"``, ``"int"``, ``"float"`` or ``"flag"`` (1/0).
    unit : str or None
        Its unit as BIDS writes it (SI symbols); None for names, codes, counts and flags.
    meaning : str
        What it holds (the BIDS sidecar's description, the docs' table).
    decimals : int, "sig4" or None
        How a float is written (:func:`sessionfiles.logformat.format_cell`); None: shortest
        round-trip form.
    domain : (lower, upper, what) or None
        The values a reader accepts (``lower <= value <= upper``, None: unbounded; floats must be
        finite; a flag is 0 or 1), ``what`` in words; empty cells always pass (a "nan" or
        "n/a" text does not: the writer writes a missing number as an empty cell).
    choices : tuple of str or None
        The values a text column may hold.
    psychopy : bool
        Named and meant as in PsychoPy's own data files.
    analysis : None, "required", "optional" or "quiet"
        Whether analysis reads the column: a required one must be there; an optional one is
        filled blank when missing, with a warning ("quiet": without one, a column newer than
        older logs).
    codebook : (unit, meaning) or None
        Its entry in the analysis codebook (``codebook.json``) where analysis exports it.
    blank : bool
        Whether a reader accepts a blank cell (False: the session writes a value in every row,
        and a row without one is refused).
    """

    name: str
    group: str
    kind: str
    unit: str | None = None
    meaning: str = ""
    decimals: int | str | None = None
    domain: tuple | None = None
    choices: tuple | None = None
    psychopy: bool = False
    analysis: str | None = None
    codebook: tuple[str, str] | None = None
    blank: bool = True

    def __post_init__(self):
        if self.group not in GROUPS or self.kind not in KINDS \
                or self.analysis not in ANALYSIS_ROLES or not self.meaning:
            raise ValueError(f"Column {self.name!r}: expected a group of {GROUPS}, a kind of "
                             f"{KINDS}, an analysis role of {ANALYSIS_ROLES} and a meaning")


#: The columns of ``trials.csv``, in the file's order, all of them from the first row on. A key a
#: row has beyond these (none written by this version) follows, sorted. ``trial_index`` and
#: ``repetition`` count from 1, PsychoPy's loop counters ``thisN`` and ``thisRepN`` from 0.
TRIALS = (
    # identity
    Column("participant", "identity", "str", analysis="required",
           meaning="Participant id (the participant record's id)",
           codebook=(CATEGORY, "participant id")),
    Column("session", "identity", "str", analysis="required",
           meaning="Session name (its folder)",
           codebook=(CATEGORY, "session name")),
    Column("group", "identity", "str", analysis="required",
           meaning="Skin-thickness group (A below the protocol's threshold, B above)",
           codebook=(CATEGORY, "skin-thickness group: A thin (600-750 um), B thick (900-1200 um)")),
    Column("sex", "identity", "str", analysis="optional",
           meaning="Sex from the participant record",
           codebook=(CATEGORY, "participant's sex as recorded")),
    Column("skin_thickness_um", "identity", "float", unit="um", decimals=1, analysis="optional",
           domain=(1e-06, 10000.0, "a skin thickness in (0, 10000] um"),
           meaning="Fingertip skin thickness from the participant record",
           codebook=("um", "skin thickness of the participant")),
    Column("date", "identity", "str", psychopy=True,
           meaning="PsychoPy's column: date and local time the session first started "
                   "(data.getDateStr format)"),
    Column("expName", "identity", "str", psychopy=True,
           meaning="PsychoPy's column: the experiment's name (the protocol's name)"),
    Column("expStart", "identity", "str", psychopy=True,
           meaning="PsychoPy's column: local time the session first started, with its UTC "
                   "offset (%Y-%m-%d %Hh%M.%S.%f %z)"),
    Column("protocol_version", "identity", "str",
           meaning="Protocol version"),
    Column("protocol_hash", "identity", "str",
           meaning="SHA-256 of the protocol's canonical JSON"),
    Column("thermocue_version", "identity", "str",
           meaning="thermocue version that ran the session"),
    Column("psychopyVersion", "identity", "str", psychopy=True,
           meaning="PsychoPy's column: PsychoPy version of the participant's window (n/a: no "
                   "PsychoPy window ran)"),
    Column("frameRate", "identity", "float", unit="Hz", psychopy=True,
           meaning="PsychoPy's column: the window's frame rate as PsychoPy measured it "
                   "(win.getActualFrameRate; n/a: no window; empty: not measurable)"),
    # design
    Column("block", "design", "str", analysis="required", blank=False,
           meaning="Block name from the protocol",
           codebook=(CATEGORY, "protocol block name")),
    Column("trial_index", "design", "int", analysis="required",
           domain=(1, None, "an integer >= 1"),
           meaning="Trial number in the session's schedule, from 1",
           codebook=("index", "trial number within the session (1-based)")),
    Column("thisN", "design", "int", psychopy=True,
           meaning="PsychoPy's column: the trial's 0-based position in the session (trial_index "
                   "- 1)"),
    Column("attempt", "design", "int", analysis="optional",
           domain=(0, None, "an integer >= 0"),
           meaning="Attempt number of this trial (a faulted or aborted attempt is run again)",
           codebook=("index", "attempt number of the trial (re-runs after faults are 2, 3, ...)")),
    Column("repetition", "design", "int", analysis="optional",
           domain=(1, None, "an integer >= 1"),
           meaning="Repetition of the sample within its block, from 1",
           codebook=("index", "repetition of the sample within the block")),
    Column("thisRepN", "design", "int", psychopy=True,
           meaning="PsychoPy's column: the 0-based repetition of the sample within its block "
                   "(repetition - 1)"),
    Column("mode", "design", "str", choices=MODES, analysis="required",
           meaning="real: a physical sample; simulated: the Peltier display replaying its "
                   "profile",
           codebook=(CATEGORY, "real = steel sample touched; simulated = thermal display replay")),
    Column("roughness_id", "design", "int", analysis="required",
           meaning="The sample presented (1..4 for 1#..4#)",
           codebook=(CATEGORY, "sample number 1-4 (1# smoothest); 0 = averaged over the samples")),
    Column("roughness_um", "design", "float", unit="um", decimals=3, analysis="optional",
           domain=(1e-06, 10000.0, "a roughness Ra in (0, 10000] um"),
           meaning="Roughness Ra of the sample presented",
           codebook=("um", "sample roughness Ra")),
    # stimulus
    Column("target_side", "stimulus", "str",
           meaning="Which interface temperature the simulated profile replays"),
    Column("profile_skin_thickness_um", "stimulus", "float", unit="um", decimals=1,
           domain=(1e-06, 10000.0, "a skin thickness in (0, 10000] um"),
           meaning="Skin thickness the simulated profile was computed for"),
    Column("profile_resistance_m2K_W", "stimulus", "float", unit="m^2*K/W", decimals="sig4",
           domain=(0.0, 1.0, "a contact resistance in [0, 1] m2K/W"),
           meaning="Finger-sample contact resistance of the simulated profile"),
    Column("profile_resistance_source", "stimulus", "str",
           meaning="Where that resistance came from: calibration or eq5"),
    Column("pad_resistance_m2K_W", "stimulus", "float", unit="m^2*K/W", decimals="sig4",
           domain=(0.0, 1.0, "a contact resistance in [0, 1] m2K/W"),
           meaning="Finger-pad contact resistance of the display"),
    Column("rate_limited_max_change_C", "stimulus", "float", unit="degC", decimals=3,
           domain=(0.0, 100.0, "a temperature change in [0, 100] degC"),
           meaning="Largest change made to keep the profile within the display's rate limit"),
    Column("cue_played", "stimulus", "flag",
           domain=(0, 1, "an integer, 0 or 1"),
           meaning="1 if the sound cue was played, 0 if no audio was available"),
    # response
    Column("response_id", "response", "int", analysis="required",
           meaning="The sample the participant named (1..4); n/a where no answer was asked",
           codebook=(CATEGORY, "sample named by the participant (1-4)")),
    Column("correct", "response", "flag", analysis="required",
           domain=(0, 1, "an integer, 0 or 1"),
           meaning="1 if response_id equals roughness_id, else 0",
           codebook=("0/1", "1 if response_id equals roughness_id")),
    Column("rt_s", "response", "float", unit="s", decimals=4, analysis="optional",
           domain=(0.0, 86400.0, "a finite time >= 0 s (at most a day)"),
           meaning="Response time from the first frame showing the question to the key press; "
                   "n/a for spoken answers",
           codebook=("s", "response time (from the answer prompt); empty for spoken answers")),
    Column("response_source", "response", "str",
           meaning="What produced the answer (keyboard backend, console, simulated model)"),
    Column("answer_mode", "response", "str", analysis="quiet",
           meaning="keyed: the participant pressed the answer; spoken: the participant said it "
                   "and the experimenter keyed it",
           codebook=(CATEGORY, "keyed = the participant pressed the answer; spoken = the "
                             "participant said it and the experimenter keyed it")),
    Column("answer_keyed_after_cue_s", "response", "float", unit="s", decimals=4, analysis="quiet",
           meaning="Spoken answers: time from the question's sound cue to the experimenter's "
                   "key (not a response time)",
           codebook=("s", "spoken answers: time from the question's sound cue to the "
                        "experimenter's key (not a response time)")),
    # timing
    Column("started_at_utc", "timing", "str", analysis="optional",
           meaning="UTC time the trial started (ISO 8601)",
           codebook=("ISO 8601 UTC", "time the attempt started")),
    Column("finished_at_utc", "timing", "str",
           meaning="UTC time the trial was written (ISO 8601)"),
    Column("contact_onset_s", "timing", "float", unit="s", decimals=3,
           domain=(0.0, None, "a finite device time >= 0 s"),
           meaning="Display clock at the moment of contact (a time stamp, not a duration)"),
    Column("contact_duration_s", "timing", "float", unit="s", decimals=3,
           domain=(0.0, 86400.0, "a finite duration >= 0 s"),
           meaning="Time from contact to the end of the recording"),
    # quality
    Column("status", "quality", "str", choices=STATUSES, analysis="required",
           meaning="ok, fault (display fault; run again) or aborted (no contact or interrupted; "
                   "run again)",
           codebook=(CATEGORY, "attempt outcome: ok, fault, aborted")),
    Column("fault_code", "quality", "str", analysis="optional",
           meaning="Display or host fault code of a faulted attempt",
           codebook=(CATEGORY, "display fault code of the attempt, if any")),
    Column("abort_reason", "quality", "str", analysis="quiet",
           meaning="Why an aborted attempt stopped",
           codebook=(CATEGORY, "why the attempt was aborted (no_contact, interrupted, killed, "
                             "error)")),
    Column("skin_temperature_C", "quality", "float", unit="degC", decimals=2, analysis="quiet",
           domain=(-50.0, 100.0, "a temperature in [-50, 100] degC"),
           meaning="Fingertip temperature just before touching (radiation thermometer)",
           codebook=("degC", "fingertip temperature measured just before the touch")),
    Column("skin_temperature_in_range", "quality", "flag", analysis="quiet",
           domain=(0, 1, "an integer, 0 or 1"),
           meaning="1 if skin_temperature_C was within the protocol's range, else 0",
           codebook=("0/1", "1 if skin_temperature_C was within the protocol's range")),
    Column("tracking_rms_C", "quality", "float", unit="degC", decimals=3, analysis="optional",
           domain=(0.0, 100.0, "a finite tracking error >= 0 degC"),
           meaning="RMS of display contact temperature minus target during playback",
           codebook=("degC", "RMS tracking error of the display")),
    Column("tracking_max_C", "quality", "float", unit="degC", decimals=3,
           domain=(0.0, 100.0, "a finite tracking error >= 0 degC"),
           meaning="Largest absolute tracking error during playback"),
    Column("frames", "quality", "int",
           domain=(0, None, "an integer >= 0"),
           meaning="Telemetry frames received during the trial"),
    Column("frames_lost", "quality", "int",
           domain=(0, None, "an integer >= 0"),
           meaning="Telemetry frames missing from the device's numbering"),
    Column("trace_file", "quality", "str",
           meaning="The trial's telemetry trace, relative to the session folder"),
    # force
    Column("contact_force_N", "force", "float", unit="N", decimals=2, analysis="quiet",
           domain=(0.0, 1000.0, "a force in [0, 1000] N"),
           meaning="Mean summed force of the display's four sensors over the contact",
           codebook=("N", "mean summed force the display measured over the contact")),
)

_BY_NAME = {c.name: c for c in TRIALS}


def column(name: str) -> Column:
    """The column called ``name`` (KeyError if ``trials.csv`` has none)."""
    return _BY_NAME[name]


def names(**where) -> tuple[str, ...]:
    """The names of the columns whose fields equal ``where`` (all columns: none given), in the
    file's order; e.g. ``names(psychopy=True)``."""
    return tuple(c.name for c in TRIALS if all(getattr(c, k) == v for k, v in where.items()))


#: The order of the columns analysis reads in its tidy table (``all_trials.csv``), kept from
#: before this table existed so that the exports stay byte-identical; a column analysis reads
#: that is not listed follows, in the file's order (a new column needs no entry here).
_ANALYSIS_LEGACY_ORDER = (
    "participant", "group", "session", "block", "trial_index", "attempt", "mode", "roughness_id",
    "roughness_um", "repetition", "response_id", "correct", "rt_s", "answer_mode",
    "answer_keyed_after_cue_s", "status", "tracking_rms_C", "skin_thickness_um", "sex",
    "started_at_utc", "fault_code", "skin_temperature_C", "skin_temperature_in_range",
    "contact_force_N", "abort_reason")


def _analysis_order() -> tuple[str, ...]:
    read = [c.name for c in TRIALS if c.analysis]
    listed = [n for n in _ANALYSIS_LEGACY_ORDER if n in read]
    return tuple(listed + [n for n in read if n not in listed])


#: The columns analysis reads, in its tidy table's order (``all_trials.csv``).
ANALYSIS_ORDER = _analysis_order()
#: Columns analysis reads that older logs lack: filled blank without a warning.
QUIET_COLUMNS = names(analysis="quiet")
#: Column -> (unit, meaning) of the analysis codebook.
CODEBOOK = {c.name: c.codebook for c in TRIALS if c.codebook}
#: Column -> (description, unit or None) of the BIDS sidecar.
DESCRIPTIONS = {c.name: (c.meaning, c.unit) for c in TRIALS}


def markdown_table() -> str:
    """The table of docs/session.md's "The trial table": one row per column, in the file's order.

    >>> print(markdown_table().splitlines()[2])
    | `participant` | identity | text |  | Participant id (the participant record's id) |
    """
    kinds = {"str": "text", "int": "integer", "float": "number", "flag": "1/0"}
    lines = ["| column | group | type | unit | meaning |", "|---|---|---|---|---|"]
    for c in TRIALS:
        meaning = c.meaning.replace("|", "\\|")
        lines.append(f"| `{c.name}` | {c.group} | {kinds[c.kind]} | {c.unit or ''} | {meaning} |")
    return "\n".join(lines)
