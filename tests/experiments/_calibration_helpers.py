"""Session directories for the calibration tests, built like the session engine writes them.

The traces are the exact model + the stated noise (0.02 °C white, 1 mK quantisation) at
20 Hz, with 1 s before the touch (forces 0, the sensor on the sample reads the sample).
"""
import csv
import json
from pathlib import Path

import numpy as np

from experiments.calibration import ContactSetup, Sensor, sensor_temperature
from sessionfiles.logformat import TRACE_COLUMNS
from experiments.protocol import load_protocol
from stimuli import contact_resistance, material

EXAMPLE = Path(__file__).resolve().parents[2] / "participants" / "examples" / "P01.json"
T_S0, T_M0, L_TRUE = 35.0, 24.0, 700e-6
# docs/design.md's session-directory columns: traces/trial-NNN.csv (TRACE_COLUMNS, the writer's) and
# the trials table's columns analysis requires (a subset of logformat.TRIAL_COLUMNS)
TRIAL_COLUMNS = ["participant", "group", "session", "block", "trial_index", "mode", "roughness_id",
                 "roughness_um", "repetition", "response_id", "correct", "rt_s", "status",
                 "tracking_rms_C"]


def make_session(root: Path, *, duration_s=25.0, samples=(1, 2, 3, 4), rate=20.0, flat=False,
                 drop_column=None, half_space=False, skin_thickness=L_TRUE, seed=0,
                 sample_C=T_M0, finger_C=T_S0, ambient_C=24.0, extra_rows=(), pre_C=None):
    """A session folder ``root/P01/S1`` with one real trial per sample id of Exp. 1's protocol.

    The sensor is on the sample (material side) and reads ``sample_C`` before the touch at
    t = 1 s (or ``pre_C`` if given); ``finger_C`` and ``ambient_C`` are constant columns;
    ``extra_rows`` are appended to trials.csv as they are.  Returns the folder."""
    protocol = load_protocol("interface_temperature")
    record = json.loads(EXAMPLE.read_text())
    sdir = root / "P01" / "S1"
    (sdir / "traces").mkdir(parents=True)
    (sdir / "session.json").write_text(json.dumps({
        "format": "thermocue-session/1", "participant_id": "P01", "participant": record,
        "protocol_name": protocol.name, "protocol_hash": protocol.hash, "protocol": protocol.data}))
    rng = np.random.default_rng(seed)
    steel = material("stainless_steel", thickness=None if half_space else 3e-3)
    setup = ContactSetup(steel, Sensor("material"))
    rows = []
    for i, sid in enumerate(samples, start=1):
        ra = protocol.sample(sid).roughness_um
        R = float(contact_resistance(ra * 1e-6))
        t = np.arange(0, int(round((duration_s + 1.0) * rate))) / rate
        touching = t >= 1.0
        y = sensor_temperature(t - 1.0, R, skin_thickness, T_S0, sample_C, setup)
        if flat:
            y = np.full_like(t, sample_C)
        if pre_C is not None:
            y[~touching] = pre_C
        y = np.round((y + 0.02 * rng.standard_normal(t.size)) * 1000) / 1000
        name = f"trial-{i:03d}.csv"
        with open(sdir / "traces" / name, "w", newline="") as fh:
            w = csv.writer(fh)
            cols = [c for c in TRACE_COLUMNS if c != drop_column]
            w.writerow(cols)
            for k in range(t.size):
                f = 0.625 if touching[k] else 0.0
                vals = {"time_s": t[k], "target_C": "", "contact_C": y[k], "ambient_C": ambient_C,
                        "finger_C": finger_C, "force1_N": f, "force2_N": f, "force3_N": f, "force4_N": f,
                        "state": "record" if touching[k] else "armed"}
                w.writerow([vals[c] for c in cols])
        rows.append({"participant": "P01", "session": "S1", "block": "contact", "trial_index": i,
                     "mode": "real", "roughness_id": sid, "roughness_um": ra, "repetition": 1,
                     "status": "ok"})   # the trace is found as traces/trial-NNN.csv
    with open(sdir / "trials.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, TRIAL_COLUMNS)
        w.writeheader()
        for r in [*rows, *extra_rows]:
            w.writerow(r)
    return sdir
