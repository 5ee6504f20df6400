"""`thermocue calibrate SESSION_DIR --out DIR`: fit contact resistances and skin thickness.

Reads the real-trial contact traces of a session (Exp. 1: the sensor glued to the fingertip,
stainless-steel samples of known roughness), fits one effective contact resistance per
sample and one skin thickness with the exact model, and writes ``residuals.png``,
``resistances.csv``, ``skin.csv``, ``parameters.md`` and ``fit.json`` into ``--out``.  With
``--write-participant FILE`` the fitted values go into that record's ``calibration`` field.

A fit that does not converge or is not identifiable is refused: ``refusal.json`` (the
reasons and what the checks measured) is written into ``--out`` and the command exits 2
with the reasons in one line, as it does for unusable traces.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

HELP_SENSOR = ("where the contact sensor sits: 'material' (massless, on the sample surface: the "
               "display's contact sensor, Eq. 7; the default), 'skin' (massless, glued to the "
               "fingertip as in the paper's Exp. 1), 'lumped' (a sensor with its own heat capacity "
               "between skin and sample)")


#: Files ``write_report`` puts into ``--out``.
REPORT_FILES = ("residuals.png", "resistances.csv", "skin.csv", "parameters.md", "fit.json")


def register(sub) -> None:
    p = sub.add_parser(
        "calibrate", help="fit contact resistance per sample and skin thickness to a session's traces",
        description=__doc__.split("\n\n")[1].strip())
    p.add_argument("session_dir", metavar="SESSION_DIR", help="DATA/<participant>/<session>/")
    p.add_argument("--out", required=True, metavar="DIR", help="folder for the report files")
    p.add_argument("--sensor-side", choices=("material", "skin", "lumped"), default="material", help=HELP_SENSOR)
    p.add_argument("--sensor-heat-capacity-J-m2K", type=float, default=None, metavar="C",
                   help="lumped sensor: heat capacity per area (default: 155, a 100 µm polyimide film)")
    p.add_argument("--sensor-skin-resistance-m2K-W", type=float, default=None, metavar="R1",
                   help="lumped sensor: skin-to-sensor resistance (default: 5.2e-4, glue + film)")
    p.add_argument("--sample-thickness-um", default=None, metavar="UM",
                   help="sample thickness in µm (a slab with an insulated back), or 'inf' for a "
                        "half-space (default: the protocol's, the paper's 3000 µm)")
    p.add_argument("--material", default=None, help="sample material (default: the protocol's)")
    p.add_argument("--skin-temperature-C", type=float, default=None,
                   help="initial skin temperature for every trace (default: finger_C before contact, "
                        "then the participant record, then the protocol)")
    p.add_argument("--material-temperature-C", type=float, default=None,
                   help="initial sample temperature (default: ambient_C before contact, then the protocol)")
    p.add_argument("--fit-skin-temperature", default="per-trace", choices=("per-trace", "shared", "none"),
                   help="fit the initial skin temperature too: one per trace (default: the finger is "
                        "rewarmed between touches, and a radiation thermometer sees the surface, a "
                        "little cooler than the tissue), one shared by all traces, or none (use the "
                        "measured values as they are)")
    p.add_argument("--skin-temperature-sd-C", type=float, default=None,
                   help="with --fit-skin-temperature none: the thermometer's uncertainty (SD, K), "
                        "propagated into the intervals (default: not propagated; a 0.3 K error that "
                        "would move an estimate beyond its interval is warned about)")
    p.add_argument("--contact-threshold-N", type=float, default=None,
                   help="summed force that marks the first touch, t = 0 (default 0.1 N)")
    p.add_argument("--interval", choices=("profile", "bootstrap"), default="profile",
                   help="profile likelihood (default) or parametric bootstrap intervals")
    p.add_argument("--level", type=float, default=0.95, help="interval coverage (default 0.95)")
    p.add_argument("--bootstrap-samples", type=int, default=200)
    p.add_argument("--seed", type=int, default=0, help="seed of the bootstrap")
    p.add_argument("--write-participant", metavar="FILE", default=None,
                   help="write the fitted values into this participant record's calibration field")
    p.set_defaults(func=run)


def _sample_thickness(value, default_m):
    from experiments.calibration import CalibrationError
    if value is None:
        return default_m
    text = str(value).strip().lower()
    if text in ("inf", "infinity", "half-space", "halfspace"):
        return None
    try:
        um = float(text)
    except ValueError:
        um = float("nan")
    if not (math.isfinite(um) and um > 0):
        raise CalibrationError(f"--sample-thickness-um: expected a thickness > 0 µm or 'inf', got {value!r}")
    return um * 1e-6


def run(ns) -> int:
    from stimuli import material as get_material

    from experiments.calibration import (CalibrationRefused, ContactSetup, Sensor, calibration_record,
                                         fit_traces, load_session_traces, write_participant_calibration,
                                         write_report)
    from experiments.calibration.model import (DEFAULT_SENSOR_HEAT_CAPACITY,
                                               DEFAULT_SENSOR_SKIN_RESISTANCE)
    from experiments.calibration.errors import CalibrationError
    from sessionfiles.atomicfile import OutputFolder, output_file
    from experiments.cli.paths import check_writable_dir

    check_writable_dir(ns.out, "--out")      # before the fit (minutes), nothing written
    if ns.sensor_side != "lumped" and (ns.sensor_heat_capacity_J_m2K is not None
                                       or ns.sensor_skin_resistance_m2K_W is not None):
        raise CalibrationError("--sensor-heat-capacity-J-m2K: expected only with --sensor-side lumped, "
                               f"got --sensor-side {ns.sensor_side}")
    if ns.sensor_side == "lumped":
        sensor = Sensor.lumped(
            DEFAULT_SENSOR_HEAT_CAPACITY if ns.sensor_heat_capacity_J_m2K is None else ns.sensor_heat_capacity_J_m2K,
            DEFAULT_SENSOR_SKIN_RESISTANCE if ns.sensor_skin_resistance_m2K_W is None
            else ns.sensor_skin_resistance_m2K_W)
    else:
        sensor = Sensor(ns.sensor_side)
    st = load_session_traces(ns.session_dir, sensor_side=ns.sensor_side,
                             skin_temperature_C=ns.skin_temperature_C,
                             material_temperature_C=ns.material_temperature_C,
                             contact_threshold_N=ns.contact_threshold_N)
    thickness = _sample_thickness(ns.sample_thickness_um, st.sample_thickness_m)
    mat = get_material(ns.material or st.material_name, thickness=thickness)
    setup = ContactSetup(mat, sensor)
    guess = st.measured_skin_m
    if ns.bootstrap_samples < 20:
        raise CalibrationError(f"--bootstrap-samples: expected an integer ≥ 20, got {ns.bootstrap_samples!r}")
    if ns.write_participant:       # check before fitting: the record must be this session's participant
        from participants_schema import load_participant
        rec = load_participant(ns.write_participant)
        if st.participant_id is not None and rec.get("id") != st.participant_id:
            raise CalibrationError(f"{ns.write_participant}: id: expected the session's participant "
                                   f"{st.participant_id!r}, got {rec.get('id')!r}")
    out = Path(ns.out)
    folder = OutputFolder(out, "thermocue calibrate")
    try:
        fit = fit_traces(st.traces, setup, fit_skin_temperature=ns.fit_skin_temperature,
                         skin_thickness_guess=guess, interval=ns.interval, level=ns.level,
                         bootstrap_samples=ns.bootstrap_samples, seed=ns.seed,
                         skin_temperature_sd_C=ns.skin_temperature_sd_C)
    except CalibrationRefused as exc:
        folder.begin()
        for name in REPORT_FILES:          # no stale report from an earlier run next to a refusal
            (out / name).unlink(missing_ok=True)
        with output_file(out / "refusal.json") as fh:
            json.dump({"session": str(ns.session_dir), "setup": setup.describe(),
                       "reasons": list(exc.reasons), "diagnostics": exc.diagnostics}, fh, indent=2,
                      default=str)
            fh.write("\n")
        raise CalibrationRefused(f"{ns.session_dir}: {exc}", exc.reasons, exc.diagnostics) from None
    folder.begin()                   # COMPLETE only once every file of this run is written
    (out / "refusal.json").unlink(missing_ok=True)
    write_report(fit, out, extra={"session": str(ns.session_dir), "participant": st.participant_id,
                                  "skipped_trials": st.skipped})
    folder.finish()
    L = fit.skin_thickness
    print(f"calibrate: {len(st.traces)} traces, {len(fit.resistances())} samples; "
          f"L = {L.value * 1e6:.0f} µm [{L.low * 1e6:.0f}, {L.high * 1e6:.0f}] ({fit.level:.0%}), "
          f"residual SD {fit.sigma_C * 1e3:.1f} mK -> {out}")
    for p in fit.resistances():
        ra = f"{p.roughness_um:g} µm" if p.roughness_um is not None else p.sample
        print(f"  R[{ra}] = {p.value:.4g} m² K/W [{p.low:.4g}, {p.high:.4g}]")
    for w in fit.warnings:
        print(f"  warning: {w}")
    if ns.write_participant:
        cal = calibration_record(fit, session=str(ns.session_dir))
        write_participant_calibration(ns.write_participant, cal)
        print(f"  wrote calibration into {ns.write_participant}")
    return 0
