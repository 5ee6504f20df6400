"""The participant record's ``calibration`` field: write a fit into it, read it back for profiles.

Shape written (accepted by ``participants_schema/participant.schema.json``; SI in the key
names)::

    "calibration": {
      "method": "thermocue calibrate 0.1.0: least squares on the exact Laplace model ...",
      "date": "2026-11-22",                       # UTC date of the fit
      "skin_thickness_um": 801.3,
      "contact_resistance_m2K_W": {"1.6": 6.49e-4, "12.5": 7.47e-4, ...},   # key: R_a in µm (%g)
      "intervals": {"level": 0.95, "method": "profile",
                    "skin_thickness_um": [799.8, 802.7],
                    "contact_resistance_m2K_W": {"1.6": [6.47e-4, 6.51e-4], ...}},
      "samples": [{"key": "1.6", "roughness_id": 1, "roughness_um": 1.6, "n_traces": 3}, ...],
      "sensor_side": "skin", "sample_thickness_um": 3000.0, "material": "stainless_steel",
      "skin_temperature_C": 35.2,                 # only if one shared T_S0 was fitted
      "trace_skin_temperatures_C": [35.8, ...],   # only if fitted per trace
      "residual_sd_C": 0.021, "session": "DATA/P07/S01"
    }

:func:`calibrated_profile_parameters` is what a session calls, per simulated trial, to use
the fitted values instead of the group mean.
"""
from __future__ import annotations

import copy
import datetime as _dt
import json
import math
from importlib import metadata
from pathlib import Path
from typing import Mapping

from experiments.calibration.errors import CalibrationError
from experiments.calibration.fit import CalibrationFit

__all__ = ["calibration_record", "write_participant_calibration", "calibrated_profile_parameters",
           "calibration_key", "check_calibration_samples"]


def _key(roughness_um) -> str:
    return f"{float(roughness_um):g}"


#: The one key convention of ``calibration.contact_resistance_m2K_W`` (writer, schema, reader):
#: the sample's roughness Ra in µm, formatted with ``%g`` ("1.6", "12.5", "50", "100").
calibration_key = _key


def _calibration_of(record):
    """The ``calibration`` object of a :class:`participants_schema.Participant` or of a JSON
    record, or None."""
    if record is None or isinstance(record, Mapping):
        return (record or {}).get("calibration")
    return record.calibration


def check_calibration_samples(record, roughness_um, source: str = "participant record") -> None:
    """Refuse a calibration none of whose resistances belongs to a sample of the protocol.

    Parameters
    ----------
    record : participants_schema.Participant or dict
        A validated participant (or its JSON record).
    roughness_um : iterable of float, µm
        The roughness of each sample of the protocol.
    source : str
        The record's file, for the message.

    Raises
    ------
    CalibrationError
        The record has fitted resistances and no key is the Ra of a sample of the protocol
        (they would all be ignored, and every profile silently fall back to Eq. 5).
    """
    cal = _calibration_of(record)
    table = cal.get("contact_resistance_m2K_W") if isinstance(cal, dict) else None
    if not table:
        return
    wanted = [_key(r) for r in roughness_um]
    if wanted and not set(table) & set(wanted):
        raise CalibrationError(
            f"{source}: calibration.contact_resistance_m2K_W: expected keys naming the protocol's "
            f"samples by Ra in µm ({', '.join(repr(w) for w in wanted)}), got "
            f"{', '.join(repr(k) for k in table)}: no fitted resistance would be used")


def calibration_record(fit: CalibrationFit, *, session: str | None = None, date: str | None = None) -> dict:
    """The ``calibration`` object for a participant record (see the module docstring)."""
    try:
        version = metadata.version("thermocue")
    except metadata.PackageNotFoundError:   # pragma: no cover
        version = "unknown"
    prob = fit.problem
    setup = prob.setup
    L = fit.skin_thickness
    d = setup.sample_thickness
    method = (f"thermocue calibrate {version}: least squares (scipy trf) on the exact Laplace model, "
              f"parameters log R per sample and log L{' and T_S0 (' + prob.skin_temperature_mode + ')' if prob.fit_skin_temperature else ''}; "
              f"{setup.describe()}; {fit.level:.0%} "
              f"{'profile-likelihood' if fit.interval_method == 'profile' else 'parametric-bootstrap'} intervals")
    resist, r_int, samples = {}, {}, []
    for p in fit.resistances():
        key = _key(p.roughness_um) if p.roughness_um is not None else p.sample
        resist[key] = p.value
        r_int[key] = [p.low, p.high]
        samples.append({"key": key, "roughness_id": p.roughness_id, "roughness_um": p.roughness_um,
                        "n_traces": sum(tr.sample == p.sample for tr in prob.traces)})
    rec = {
        "method": method,
        "date": date or _dt.datetime.now(_dt.timezone.utc).date().isoformat(),
        "skin_thickness_um": L.value * 1e6,
        "contact_resistance_m2K_W": resist,
        "intervals": {"level": fit.level, "method": fit.interval_method,
                      "skin_thickness_um": [L.low * 1e6, L.high * 1e6],
                      "contact_resistance_m2K_W": r_int},
        "samples": samples,
        "sensor_side": setup.sensor.side,
        "sample_thickness_um": None if d is None else d * 1e6,
        "material": getattr(setup.material, "name", "") or None,
        "residual_sd_C": fit.sigma_C,
        "skin_thickness_meaning": "effective depth of the isothermal core of the model (where the "
                                  "skin is held at T_S0), not an anatomical thickness",
        "correlation": {"parameters": list(fit.diagnostics.get("correlation_parameters", [])),
                        "coordinates": "log R, log L, T_S0 (°C)",
                        "matrix": fit.diagnostics.get("correlation", [])},
        "misspecification": [{"name": c["name"], "size": c["size"], "shift": c["shift"],
                              "beyond_interval": c["beyond"]}
                             for c in fit.diagnostics.get("misspecification", [])],
        "warnings": list(fit.warnings),
        "plan": fit.diagnostics.get("plan"),
        "forward_model": fit.diagnostics.get("forward_model"),
    }
    if setup.sensor.side == "lumped":
        rec["sensor"] = setup.sensor.to_dict()
    if prob.skin_temperature_mode == "shared":
        T = fit.parameter("T_S0")
        rec["skin_temperature_C"] = T.value
        rec["intervals"]["skin_temperature_C"] = [T.low, T.high]
    elif prob.skin_temperature_mode == "per-trace":     # kept for the record; not used by profiles
        rec["trace_skin_temperatures_C"] = [
            fit.parameter(f"T_S0[{i + 1}]").value for i in range(len(prob.traces))]
    if session:
        rec["session"] = str(session)
    return rec


def write_participant_calibration(path, calibration: dict) -> dict:
    """Put ``calibration`` into the participant record at ``path``, validated, atomically.

    The record is read, its ``calibration`` field replaced, the whole record validated with
    :func:`participants_schema.validate_participant` (schema + semantic checks) and only then
    written: a temporary file in the same folder, fsynced, renamed over the old one, the
    folder fsynced.  A record that would not validate is left untouched.

    Parameters
    ----------
    path : path-like
        The participant JSON file.
    calibration : dict
        From :func:`calibration_record`.

    Returns
    -------
    dict
        The new record.

    Raises
    ------
    participants_schema.ParticipantError
        The file is missing or invalid, or the new record does not validate.
    """
    from sessionfiles.logbook import atomic_write_text
    from participants_schema import load_participant, validate_participant

    path = Path(path)
    record = load_participant(path)
    new = copy.deepcopy(record)
    new["calibration"] = json.loads(json.dumps(calibration, allow_nan=False))
    validate_participant(new, source=str(path))
    atomic_write_text(path, json.dumps(new, indent=2, ensure_ascii=False) + "\n")
    return new


def calibrated_profile_parameters(record, roughness_id: int | None, roughness_um: float | None = None):
    """The fitted R and L to simulate a sample for this participant, or None.

    Parameters
    ----------
    record : participants_schema.Participant or dict
        A validated participant (or its JSON record).
    roughness_id : int or None
        The protocol's sample id (matched against the ids stored with the calibration).
    roughness_um : float, µm, optional
        The sample's R_a; when given it alone decides (ids may differ between protocols,
        roughness values do not).

    Returns
    -------
    dict or None
        None when the record has no calibration: the caller keeps the group mean and Eq. 5.
        Else ``{"resistance": m² K/W or None, "skin_thickness": m, "source": str, "date": str,
        "sensor_side": str}`` (plus ``"skin_temperature"``, °C, when one shared T_S0 was
        fitted).  ``resistance`` is None when this sample was not calibrated: use Eq. 5 for it
        (``target_profile(..., resistance=None)``) but still the calibrated skin thickness.

    Examples
    --------
    >>> rec = {"calibration": {"method": "m", "date": "2026-11-22", "skin_thickness_um": 800.0,
    ...        "contact_resistance_m2K_W": {"12.5": 7.5e-4},
    ...        "samples": [{"key": "12.5", "roughness_id": 2, "roughness_um": 12.5}]}}
    >>> calibrated_profile_parameters(rec, 2)["resistance"]
    0.00075
    >>> round(calibrated_profile_parameters(rec, None, roughness_um=12.5)["skin_thickness"] * 1e6, 6)
    800.0
    >>> calibrated_profile_parameters(rec, 3)["resistance"] is None     # not calibrated: Eq. 5
    True
    >>> calibrated_profile_parameters({"id": "P01"}, 2) is None
    True
    """
    cal = _calibration_of(record)
    if not isinstance(cal, dict):
        return None
    table = cal.get("contact_resistance_m2K_W") or {}
    key = None
    if roughness_um is not None:
        k = _key(roughness_um)
        key = k if k in table else None
    elif roughness_id is not None:          # the roughness, when given, decides alone
        for s in cal.get("samples") or []:
            if s.get("roughness_id") is not None and int(s["roughness_id"]) == int(roughness_id):
                key = s.get("key")
                break
    if cal.get("skin_thickness_um") is None:
        return None
    R = float(table[key]) if key in table else None
    L = float(cal["skin_thickness_um"]) * 1e-6
    if not ((R is None or (math.isfinite(R) and R >= 0)) and math.isfinite(L) and L > 0):
        raise CalibrationError(f"participant record: calibration.contact_resistance_m2K_W.{key}: "
                               f"expected a finite R ≥ 0 and a skin thickness > 0, got {R!r}, {L!r}")
    out = {"resistance": R, "skin_thickness": L,
           "source": f"calibration {cal.get('date', '')}".strip(), "date": cal.get("date"),
           "sensor_side": cal.get("sensor_side")}
    if cal.get("skin_temperature_C") is not None:
        out["skin_temperature"] = float(cal["skin_temperature_C"])
    return out
