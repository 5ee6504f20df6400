"""Read the contact traces of a recorded session (Exp. 1) into :class:`ContactTrace` objects.

``DATA/<participant>/<session>/``: ``session.json`` (protocol, participant record),
``trials.csv`` (one row per trial; ``mode``, ``status``, ``roughness_id``, ``roughness_um``,
``trace_file``) and ``traces/trial-NNN.csv`` (``time_s``, ``target_C``, ``contact_C``,
``ambient_C``, ``finger_C``, ``force1_N`` .. ``force4_N``, ``state``:
:data:`sessionfiles.logformat.TRACE_COLUMNS`).  Every real trial with status ``ok`` and a trace
is used.

Per trace (each rule documented because each is a choice):

* **contact onset** (t = 0): the first sample whose summed force reaches
  ``contact_threshold_N`` (default 0.1 N, ten times the summed force noise of the emulator: the thermal contact starts at the first touch,
  before the force reaches the protocol's trial threshold); without force columns, the first
  sample (the display records "from contact").
* **the sensor's own body**: the median pre-contact ``contact_C`` is the initial temperature
  of the body the sensor is attached to: T_M0 for a ``"material"`` sensor, T_S0 for a
  ``"skin"`` or ``"lumped"`` one (a sensor glued to the finger reads the finger before contact).
* **T_M0** (sample) otherwise: ``material_temperature_C`` if given, else the median
  ``ambient_C`` before contact (the samples rest at room temperature), else the protocol's
  ``environment.room_temperature_C``.
* **T_S0** (skin) otherwise: ``skin_temperature_C`` if given, else the median ``finger_C``
  (radiation thermometer) before contact, else the record's ``initial_skin_temperature_C``,
  else the middle of the protocol's skin-temperature range.

An explicit ``skin_temperature_C`` / ``material_temperature_C`` always wins.
"""
from __future__ import annotations

import csv
import io
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from experiments.calibration.errors import CalibrationError
from experiments.calibration.trace import ContactTrace
from sessionfiles.logformat import FORCE_COLUMNS

__all__ = ["SessionTraces", "load_session_traces", "read_trace_csv", "TOUCH_THRESHOLD_N"]

_REQUIRED_TRACE_COLUMNS = ("time_s", "contact_C")
#: Summed force (N) taken as the first touch.
TOUCH_THRESHOLD_N = 0.1


@dataclass
class SessionTraces:
    """The traces of a session and what the calibration needs to know about it."""

    session_dir: Path
    traces: list
    participant: dict | None
    protocol: object | None
    material_name: str
    sample_thickness_m: float | None
    skipped: list = field(default_factory=list)

    @property
    def participant_id(self) -> str | None:
        return (self.participant or {}).get("id")

    @property
    def measured_skin_m(self) -> float | None:
        """The stored record's measured skin thickness (``skin_thickness.total_um``), m: the
        fit's first guess of L; None when the record has none."""
        st = (self.participant or {}).get("skin_thickness")
        total = st.get("total_um") if isinstance(st, dict) else None
        return float(total) * 1e-6 if total else None


def _float(value):
    if value is None or value == "":
        return float("nan")
    try:
        return float(value)
    except ValueError:
        return float("nan")


def read_trace_csv(path) -> dict:
    """Columns of a trace file as float arrays (``state`` kept as strings).

    Raises
    ------
    CalibrationError
        Missing file, missing column, unreadable number.
    """
    from sessionfiles.session_reader import MAX_BYTES, SessionFileError, read_regular_bytes
    path = Path(path)
    if not os.path.lexists(path):
        raise CalibrationError(f"{path}: expected a trace file, got none")
    try:                    # regular files only, bounded, never a blocking open
        raw = read_regular_bytes(path, MAX_BYTES["trace"])
    except SessionFileError as exc:
        raise CalibrationError(str(exc)) from None
    except FileNotFoundError:
        raise CalibrationError(f"{path}: expected a trace file, got none") from None
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise CalibrationError(f"{path}: expected a UTF-8 CSV trace, got byte 0x{raw[exc.start]:02x} "
                               f"at offset {exc.start}") from None
    if "\x00" in text:
        raise CalibrationError(f"{path}: expected a text CSV trace, got a NUL byte at offset "
                               f"{text.index(chr(0))}")
    rows = list(csv.reader(io.StringIO(text, newline="")))
    if not rows:
        raise CalibrationError(f"{path}: header: expected {', '.join(_REQUIRED_TRACE_COLUMNS)}, got an empty file")
    header = [h.strip() for h in rows[0]]
    for col in _REQUIRED_TRACE_COLUMNS:
        if col not in header:
            raise CalibrationError(f"{path}: {col}: expected a column {col!r}, got columns {header}")
    out = {}
    body = [r for r in rows[1:] if r]
    if body and len(body[-1]) < len(header):      # a torn last line of a killed session
        body = body[:-1]
    for j, name in enumerate(header):
        vals = [r[j] if j < len(r) else "" for r in body]
        if name == "state":
            out[name] = vals
            continue
        try:
            out[name] = np.array([float(v) if v != "" else np.nan for v in vals], dtype=float)
        except ValueError:
            bad = next(v for v in vals if v != "" and not _isfloat(v))
            raise CalibrationError(f"{path}: {name}: expected numbers, got {bad!r}") from None
        if name in _REQUIRED_TRACE_COLUMNS:
            # a blank cell is a sample the device did not report; a written NaN or infinity is
            # damage (or an edit), never a measurement
            written = np.array([v.strip() != "" for v in vals], dtype=bool)
            bad_rows = np.flatnonzero(written & ~np.isfinite(out[name]))
            if bad_rows.size:
                i = int(bad_rows[0])
                raise CalibrationError(f"{path}: {name}: expected finite numbers, got "
                                       f"{vals[i]!r} on line {i + 2}")
    return out


def _isfloat(v) -> bool:
    try:
        float(v)
        return True
    except ValueError:
        return False


def _median_finite(x):
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    return float(np.median(x)) if x.size else float("nan")


def _session_protocol(session: dict, path: Path):
    data = session.get("protocol")
    if not isinstance(data, dict):
        return None
    from experiments.protocol import parse_protocol
    # session.json may hold the protocol as {"data": ..., "hash": ...} or the data itself
    data = data.get("data", data) if "data" in data and isinstance(data.get("data"), dict) else data
    return parse_protocol(data, source=f"{path}: protocol")


def _session_participant(session: dict):
    for key in ("participant", "participant_record"):
        rec = session.get(key)
        if isinstance(rec, dict):
            return rec.get("record", rec) if isinstance(rec.get("record"), dict) else rec
    return None


def _session_rows(session_dir: Path):
    """``(session.json's object, the trial rows)``, read by the one reader of session folders
    (regular UTF-8 files, session.json against the log, every trial row in the trial table's
    domain; the log's rows when trials.csv is older); CalibrationError names the file."""
    if not session_dir.is_dir():
        raise CalibrationError(f"{session_dir}: expected a session directory, got none")
    spath = session_dir / "session.json"
    tpath = session_dir / "trials.csv"
    from sessionfiles.session_reader import SessionFileError, read_session_folder
    try:
        read = read_session_folder(session_dir)
        if not os.path.lexists(spath):
            raise CalibrationError(f"{spath}: expected a session.json, got none")
        if read.meta is None:
            raise CalibrationError(f"{spath}: expected a JSON object, got "
                                   + (read.notes[0].split(": ", 1)[-1] if read.notes else "none"))
        if read.trials_csv is None:
            raise CalibrationError(f"{tpath}: expected the trials table, got none")
        rows, source, lines = read.trial_rows()      # the log's when trials.csv is older
        read.check_rows(rows, source, lines)
    except SessionFileError as exc:
        raise CalibrationError(str(exc)) from None
    return read.meta, rows


def _skin_default(participant, protocol) -> float:
    """The initial skin temperature when a trace has none, °C: the participant record's, else
    the middle of the protocol's range (NaN: neither)."""
    if participant and participant.get("initial_skin_temperature_C") is not None:
        return float(participant["initial_skin_temperature_C"])
    if protocol:
        env = protocol.environment
        return 0.5 * (env.skin_temperature_min_C + env.skin_temperature_max_C)
    return float("nan")


def _onset(path, cols, t, contact_threshold_N) -> float:
    """The first touch, s: the first sample whose summed force reaches the threshold (the
    trace's start when it has no force columns, or only empty ones)."""
    forces = [cols[c] for c in FORCE_COLUMNS if c in cols]
    if forces:
        total = np.nansum(np.vstack(forces), axis=0)
        hit = np.flatnonzero(total >= contact_threshold_N)
        if hit.size:
            return float(t[hit[0]])
        if np.any(np.isfinite(np.vstack(forces))):
            raise CalibrationError(
                f"{path}: force1_N..force4_N: expected the summed force to reach the contact "
                f"threshold {contact_threshold_N:g} N, got at most {np.nanmax(total):.3g} N "
                f"(no contact)")
    return float(t[0]) if t.size else 0.0


def _initial_temperatures(path, cols, t, onset, sensor_side, given, defaults):
    """``(skin, material)`` initial temperatures of a trace, °C: those ``given`` (not None),
    else the contact sensor's before the touch on its ``sensor_side``, the ambient or finger
    sensor, then the ``defaults`` (room, skin); CalibrationError when one is still unknown."""
    skin_temperature_C, material_temperature_C = given
    room, skin_default = defaults
    pre = t < onset
    early = pre if np.any(pre) else (t <= onset + 1.0)
    own = _median_finite(cols["contact_C"][pre]) if np.any(pre) else float("nan")
    tm0 = material_temperature_C
    if tm0 is None:
        tm0 = own if sensor_side == "material" else float("nan")
        if not math.isfinite(tm0) and "ambient_C" in cols:
            tm0 = _median_finite(cols["ambient_C"][early])
        if not math.isfinite(tm0):
            tm0 = room
    ts0 = skin_temperature_C
    if ts0 is None:
        ts0 = own if sensor_side != "material" else float("nan")
        if not math.isfinite(ts0) and "finger_C" in cols:
            fpre = cols["finger_C"][pre] if np.any(pre) else cols["finger_C"][:1]
            ts0 = _median_finite(fpre)
        if not math.isfinite(ts0):
            ts0 = skin_default
    if not math.isfinite(tm0):
        raise CalibrationError(f"{path}: ambient_C: expected the sample temperature (ambient_C, "
                               f"the protocol or --material-temperature-C), got none")
    if not math.isfinite(ts0):
        raise CalibrationError(f"{path}: finger_C: expected the initial skin temperature (finger_C, "
                               f"the participant record or --skin-temperature-C), got none")
    return ts0, tm0


def _roughness(row, protocol):
    """``(roughness µm or NaN, roughness id or None)`` of a trial row (the protocol's sample
    when the row has no roughness_um)."""
    rid = row.get("roughness_id")
    rid = int(float(rid)) if rid not in (None, "") else None
    ra = _float(row.get("roughness_um"))
    if not math.isfinite(ra) and protocol and rid is not None:
        try:
            ra = protocol.sample(rid).roughness_um
        except Exception:          # noqa: BLE001 - unknown id: roughness stays unknown
            ra = float("nan")
    return ra, rid


def _trace(session_dir, row, protocol, contact_threshold_N, sensor_side, given, defaults):
    """The contact trace of one real, ok trial row, its time from the first touch."""
    idx = row.get("trial_index")
    name = row.get("trace_file") or f"traces/trial-{int(idx):03d}.csv"
    path = session_dir / name
    if not path.is_file() and (session_dir / "traces" / name).is_file():
        path = session_dir / "traces" / name
    cols = read_trace_csv(path)
    t = cols["time_s"]
    onset = _onset(path, cols, t, contact_threshold_N)
    ts0, tm0 = _initial_temperatures(path, cols, t, onset, sensor_side, given, defaults)
    ra, rid = _roughness(row, protocol)
    key = f"{ra:g}" if math.isfinite(ra) else f"id{rid}"
    return ContactTrace(
        t - onset, cols["contact_C"], ts0, tm0, sample=key,
        roughness_um=ra if math.isfinite(ra) else None, source=str(path), roughness_id=rid,
        meta={"trial_index": int(float(idx)), "onset_s": onset})


def load_session_traces(session_dir, *, sensor_side: str = "material", skin_temperature_C: float | None = None,
                        material_temperature_C: float | None = None,
                        contact_threshold_N: float | None = None) -> SessionTraces:
    """Read every usable real-trial trace of a session.

    Parameters
    ----------
    session_dir : path-like
        ``DATA/<participant>/<session>/``.
    sensor_side : {"material", "skin", "lumped"}
        Decides which initial temperature the pre-contact sensor reading gives.
    skin_temperature_C, material_temperature_C : float, °C, optional
        Override the per-trace initial temperatures (see the module docstring).
    contact_threshold_N : float, N, optional
        Summed force that marks the first touch (default :data:`TOUCH_THRESHOLD_N`).

    Returns
    -------
    SessionTraces

    Raises
    ------
    CalibrationError
        A missing or malformed file, no usable trial, a bad trace (naming file and field).
    """
    session_dir = Path(session_dir)
    session, rows = _session_rows(session_dir)
    spath, tpath = session_dir / "session.json", session_dir / "trials.csv"
    protocol = _session_protocol(session, spath)
    participant = _session_participant(session)
    for col in ("mode", "status", "roughness_id", "trial_index"):
        if rows and col not in rows[0]:
            raise CalibrationError(f"{tpath}: {col}: expected a column {col!r}, got columns {list(rows[0])}")
    if contact_threshold_N is None:
        contact_threshold_N = TOUCH_THRESHOLD_N
    defaults = (protocol.environment.room_temperature_C if protocol else float("nan"),
                _skin_default(participant, protocol))
    traces, skipped = [], []
    for row in rows:
        if row.get("mode") != "real" or row.get("status") != "ok":
            skipped.append(f"trial {row.get('trial_index')}: mode {row.get('mode')!r}, "
                           f"status {row.get('status')!r}")
            continue
        traces.append(_trace(session_dir, row, protocol, contact_threshold_N, sensor_side,
                             (skin_temperature_C, material_temperature_C), defaults))
    if not traces:
        raise CalibrationError(f"{tpath}: mode: expected at least one real trial with status 'ok' and "
                               f"a trace, got none ({len(rows)} rows)")
    mat_name = protocol.material.name if protocol else "stainless_steel"
    thick = protocol.material.thickness_m if protocol else None
    return SessionTraces(session_dir, traces, participant, protocol, mat_name, thick, skipped)
