"""``thermocue bench model`` end to end (quick mode) and its output files."""
from __future__ import annotations

import json

import pytest

from experiments.cli import main


@pytest.mark.slow
def test_bench_model_quick_writes_table_json_png(tmp_path, capsys):
    out = tmp_path / "bench"
    assert main(["bench", "model", "--quick", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "cost_per_point_us" in printed and "machine:" in printed
    data = json.loads((out / "bench.json").read_text(encoding="utf-8"))
    assert (out / "bench.png").stat().st_size > 10_000
    assert (out / "bench.csv").read_text(encoding="utf-8").startswith("problem,method,setting,cost_per_point_us")
    for key in ("platform", "cpu_model", "numpy", "scipy"):
        assert data["machine"][key]
    methods = {(r["problem"], r["method"]) for r in data["rows"]}
    for m in ("exact", "paper", "paper-as-printed", "numerical"):
        assert ("interface", m) in methods and ("receptor", m) in methods
    for r in data["rows"]:
        assert r["cost_per_point_us"] > 0 and r["max_error_K"] >= 0
    by = {(r["problem"], r["method"], r["setting"]): r for r in data["rows"]}
    # the exact display-driven response really is within 1e-6 K of the mpmath reference
    assert by[("receptor", "exact", "Duhamel + FFT")]["max_error_K"] < 1e-6
    assert by[("interface", "exact", "default")]["max_error_theta"] < 1e-12
    # and so is the one through the finger-pad resistance (Robin case, own mpmath eigen reference)
    assert by[("pad", "exact", "R_pad, Duhamel + Bromwich")]["max_error_K"] < 1e-6
    assert data["ratios"]["skin_response_pad_exact_over_eq7_cost_ratio"] > 0
    # the printed Eq. 8 prefactor is grossly wrong for a display: the bench must show it
    assert by[("receptor", "paper-as-printed", "Eq. 8 prefactor")]["max_error_K"] > 1.0
    assert data["ratios"]["skin_response_exact_over_eq7_cost_ratio"] > 0
    assert data["profile"]["points"] == 20001 and data["profile"]["rate_Hz"] == 1000.0
    # layered and perfused skin exact, against mpmath transfer matrices, and the planner
    assert by[("layered", "exact", "epidermis + dermis")]["max_error_K"] < 1e-9
    assert by[("layered", "exact", "epidermis + dermis, Pennes 1.25e-3 /s")]["max_error_K"] < 1e-9
    planner = [r for r in data["rows"] if r["problem"] == "layered" and r["method"] == "planner"]
    assert len(planner) == 1 and planner[0]["max_error_K"] <= data["ratios"]["planner_tolerance_K"]
    for key in ("layered_exact_over_eq7_cost_ratio", "perfusion_exact_over_eq7_cost_ratio",
                "planner_cold_over_exact_cost_ratio", "planner_profile_scene_cold_over_exact_cost_ratio",
                "planner_evaluated_scene_cold_over_exact_cost_ratio",
                "planner_near_tolerance_scene_cold_over_exact_cost_ratio",
                "display_planner_decay_over_exact_cost_ratio", "display_planner_step_over_exact_cost_ratio"):
        assert data["ratios"][key] > 0


def test_bench_out_must_be_a_folder(tmp_path, capsys):
    f = tmp_path / "file.txt"
    f.write_text("x", encoding="utf-8")
    assert main(["bench", "model", "--out", str(f)]) == 2
    assert "--out: expected a folder" in capsys.readouterr().err


def test_bench_rejects_unknown_target(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["bench", "disk"])
    assert exc.value.code == 2
