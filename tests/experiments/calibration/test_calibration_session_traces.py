"""Reading a session's traces: contact onset, initial temperatures, which trials are used."""
import pytest

from _calibration_helpers import make_session
from experiments.calibration import CalibrationError, load_session_traces


def test_onset_and_initial_temperatures_for_a_sensor_on_the_sample(tmp_path):
    extra = [{"trial_index": 9, "block": "simulated", "mode": "simulated", "roughness_id": 1, "status": "ok"},
             {"trial_index": 10, "block": "real", "mode": "real", "roughness_id": 2, "status": "fault"}]
    sdir = make_session(tmp_path, samples=(1, 4), duration_s=3.0, sample_C=23.0, finger_C=35.4,
                        ambient_C=20.0, extra_rows=extra)
    st = load_session_traces(sdir)
    assert [t.sample for t in st.traces] == ["1.6", "100"]
    assert [t.roughness_id for t in st.traces] == [1, 4]
    tr = st.traces[0]
    assert tr.meta["onset_s"] == pytest.approx(1.0)          # the touch, from the forces
    assert tr.time_s[0] == pytest.approx(0.05)               # samples after the touch only
    # sensor on the sample: its reading before the touch is T_M0 (not the 20 °C room air)
    assert tr.material_temperature_C == pytest.approx(23.0, abs=0.01)
    assert tr.skin_temperature_C == pytest.approx(35.4)      # finger_C before the touch
    assert len(st.skipped) == 2 and "simulated" in st.skipped[0] and "fault" in st.skipped[1]
    assert st.sample_thickness_m == pytest.approx(3e-3) and st.material_name == "stainless_steel"
    assert st.participant_id == "P01"


def test_skin_side_sensor_and_explicit_temperatures(tmp_path):
    sdir = make_session(tmp_path, samples=(2,), duration_s=3.0, finger_C=35.4, ambient_C=21.0,
                        pre_C=35.1)
    st = load_session_traces(sdir, sensor_side="skin")
    # a sensor on the finger reads the finger before the touch (35.1 °C, not finger_C)
    assert st.traces[0].skin_temperature_C == pytest.approx(35.1, abs=0.01)
    assert st.traces[0].material_temperature_C == pytest.approx(21.0)   # ambient_C
    st = load_session_traces(sdir, skin_temperature_C=35.9, material_temperature_C=22.5)
    assert (st.traces[0].skin_temperature_C, st.traces[0].material_temperature_C) == (35.9, 22.5)


def test_without_force_columns_the_first_sample_is_the_onset(tmp_path):
    sdir = make_session(tmp_path, samples=(3,), duration_s=3.0)
    path = sdir / "traces" / "trial-001.csv"
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    keep = [i for i, h in enumerate(header) if not h.startswith("force")]
    path.write_text("\n".join(",".join(l.split(",")[i] for i in keep) for l in lines) + "\n")
    st = load_session_traces(sdir)
    assert st.traces[0].meta["onset_s"] == 0.0


def test_no_usable_trial_and_no_touch_are_errors(tmp_path):
    sdir = make_session(tmp_path / "a", samples=(1,), duration_s=3.0)
    rows = (sdir / "trials.csv").read_text().replace(",ok,", ",aborted,")
    (sdir / "trials.csv").write_text(rows)
    with pytest.raises(CalibrationError, match=r"trials\.csv: mode: expected at least one real trial"):
        load_session_traces(sdir)
    sdir = make_session(tmp_path / "b", samples=(1,), duration_s=3.0)
    path = sdir / "traces" / "trial-001.csv"
    path.write_text(path.read_text().replace(",0.625,0.625,0.625,0.625,", ",0.0,0.0,0.0,0.0,"))
    with pytest.raises(CalibrationError, match=r"trial-001\.csv: force1_N\.\.force4_N: .*no contact"):
        load_session_traces(sdir)


def test_a_binary_or_nul_damaged_trace_is_named_with_its_byte_offset(tmp_path):
    # a garbage (non-UTF-8) trace given to calibrate was a UnicodeDecodeError traceback
    sdir = make_session(tmp_path, samples=(1, 4), duration_s=3.0)
    trace = sorted((sdir / "traces").glob("trial-*.csv"))[0]
    good = trace.read_bytes()
    trace.write_bytes(good[:40] + b"\xe2\x28\xa1" + good[43:])
    with pytest.raises(CalibrationError, match=rf"{trace.name}: expected a UTF-8 CSV trace, got "
                                               r"byte 0xe2 at offset 40$"):
        load_session_traces(sdir)
    trace.write_bytes(good[:50] + b"\x00" + good[51:])
    with pytest.raises(CalibrationError, match=r"got a NUL byte at offset 50$"):
        load_session_traces(sdir)


def test_a_written_nan_in_a_trace_is_refused_with_its_line(tmp_path):
    sdir = make_session(tmp_path, samples=(1, 4), duration_s=3.0)
    trace = sorted((sdir / "traces").glob("trial-*.csv"))[0]
    lines = trace.read_text(encoding="utf-8").splitlines()
    header = lines[0].split(",")
    cells = lines[5].split(",")
    cells[header.index("contact_C")] = "nan"
    lines[5] = ",".join(cells)
    trace.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(CalibrationError, match=r"contact_C: expected finite numbers, got 'nan' "
                                               r"on line 6$"):
        load_session_traces(sdir)
