"""Power simulation: size under no effect, power under a large one, the CLI."""
from __future__ import annotations

import json
import sys
import types

import numpy as np
import pandas as pd
import pytest

from analysis import LogError, power_curve
from analysis.power import cells_frame, read_cells
from experiments.cli import main


def _cells(delta):
    """A above B by ``delta`` (probability) in real mode; equal in simulated mode."""
    base = {1: 0.35, 2: 0.45, 3: 0.55, 4: 0.6}
    out = {}
    for r, p in base.items():
        out[("A", "real", r)] = p + delta
        out[("B", "real", r)] = p
        out[("A", "simulated", r)] = out[("B", "simulated", r)] = p
    return out


@pytest.mark.slow     # 8000 cohorts, ~12 s: the default suite keeps its margin to 10 min
def test_no_group_difference_rejects_at_about_alpha():
    res = power_curve(_cells(0.0), (10, 30), simulations=4000, participant_sd=0.6, seed=3,
                      test="cluster-t")
    # 4000 cohorts: the rejection rate's SE is sqrt(0.05*0.95/4000) = 0.0034; Welch's t on
    # per-participant proportions is close to exact here (measured 0.044-0.049); band +-4.5 SE
    assert ((res.table["power"] > 0.035) & (res.table["power"] < 0.065)).all(), res.table
    assert (res.table["expected_difference_A_minus_B"] == 0).all()
    assert (res.table["mean_difference_A_minus_B"].abs() < 0.005).all()


def test_power_grows_with_cohort_size_and_matches_the_expected_difference():
    res = power_curve(_cells(0.25), (5, 10, 30), simulations=2000, participant_sd=0.0, seed=4,
                      test="cluster-t")
    t = res.table
    assert t["power"].is_monotonic_increasing and t["power"].iloc[-1] > 0.99
    assert t["power"].iloc[0] < 0.9
    # sd 0: the expected difference is the mean of the cell differences exactly
    assert t["expected_difference_A_minus_B"].iloc[0] == pytest.approx(0.25, abs=1e-6)
    # simulated mean difference: SE ~ sqrt(2 * 0.25 / (12 n)) / sqrt(2000) < 0.003 at n = 5
    assert np.allclose(t["mean_difference_A_minus_B"], 0.25, atol=0.012)
    assert (t["power_low"] <= t["power"]).all() and (t["power"] <= t["power_high"]).all()


def test_gee_test_agrees_with_the_cluster_t_on_a_clear_effect():
    res = power_curve(_cells(0.3), (12,), simulations=15, participant_sd=0.3, test="gee", seed=5)
    assert res.table["power"].iloc[0] > 0.8 and res.settings["test"] == "gee"


def test_cells_validation_names_file_and_column(tmp_path):
    bad = tmp_path / "cells.csv"
    pd.DataFrame({"group": ["A"], "mode": ["real"], "roughness_id": [1]}).to_csv(bad, index=False)
    with pytest.raises(LogError, match=rf"^{bad}: p_correct: expected a column"):
        read_cells(bad)
    pd.DataFrame({"group": ["A"], "mode": ["real"], "roughness_id": [1],
                  "p_correct": [1.7]}).to_csv(bad, index=False)
    with pytest.raises(LogError, match=rf"^{bad}: p_correct: expected a probability"):
        read_cells(bad)
    with pytest.raises(LogError, match="groups A and B"):
        power_curve({("A", "real", 1): 0.5}, (5,), simulations=10)


def _write_cells(path, cells):
    pd.DataFrame([(g, m, r, p) for (g, m, r), p in cells.items()],
                 columns=["group", "mode", "roughness_id", "p_correct"]).to_csv(path, index=False)


def test_cli_power_with_cells_file(tmp_path, capsys):
    cells = tmp_path / "cells.csv"
    _write_cells(cells, _cells(0.2))
    out = tmp_path / "power"
    status = main(["power", "--cells", str(cells), "--n-per-group", "5,15",
                   "--simulations", "15", "--out", str(out)])
    assert status == 0
    table = pd.read_csv(out / "power.csv")
    assert list(table["n_per_group"]) == [5, 15] and (table["simulations"] == 15).all()
    # the test, SD, alpha, missing rate and scale travel with the numbers
    assert (table["test"] == "gee").all() and (table["participant_sd"] == 0.5).all()
    assert (table["alpha"] == 0.05).all() and (table["cells_scale"] == "marginal").all()
    summary = json.loads((out / "power_summary.json").read_text())
    assert {"n_for_80", "n_for_90", "test_description", "cells_source"} <= set(summary)
    from analysis.exports import check_codebook
    book = json.loads((out / "codebook.json").read_text())
    assert set(book) == {"power.csv", "cells.csv"} and check_codebook(book) == []
    assert (out / "power.png").stat().st_size > 10_000
    err = capsys.readouterr().err
    assert "n = 5 per group" in err and "n = 15 per group" in err


def test_cli_power_uses_the_participant_model_when_no_cells(tmp_path, monkeypatch, capsys):
    fake = types.ModuleType("experiments.participant_model.prediction")
    fake.predicted_cell_probabilities = lambda: pd.DataFrame(
        [(g, m, r, p) for (g, m, r), p in _cells(0.1).items()],
        columns=["group", "mode", "roughness_id", "p_correct"])
    monkeypatch.setitem(sys.modules, "experiments.participant_model.prediction", fake)
    status = main(["power", "--n-per-group", "6", "--simulations", "20", "--test", "cluster-t",
                   "--out", str(tmp_path)])
    assert status == 0
    assert "simulated-participant model" in capsys.readouterr().err
    cells = pd.read_csv(tmp_path / "cells.csv")
    assert len(cells) == 16


def test_cli_power_bad_input_exits_2(tmp_path, monkeypatch, capsys):
    assert main(["power", "--n-per-group", "5,x", "--cells", "c.csv", "--out", str(tmp_path)]) == 2
    assert "--n-per-group: expected comma-separated integers" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "experiments.participant_model.prediction", None)   # import fails
    assert main(["power", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("thermocue power: --cells: expected a CSV") and "\n" not in err


def test_power_runs_the_reports_primary_test():
    # the averaged contrast power computes per cohort is the report's primary row exactly
    from analysis import fit_gee, group_contrasts
    from analysis.inference import averaged_contrast
    from analysis.power import _as_trials, _simulate
    rng = np.random.default_rng(6)
    keys = [(g, m, r) for g in "AB" for m in ("real", "simulated") for r in (1, 2, 3, 4)]
    q = np.array([_cells(0.15)[k] for k in keys])
    trials = _as_trials(_simulate(q, keys, 13, 17, 3, 0.5, 0.1, rng))
    assert trials["participant"].nunique() == 30
    assert trials.groupby("participant").size().max() <= 24 and len(trials) < 30 * 24
    fit = fit_gee(trials)
    row = group_contrasts(fit, trials).set_index(["mode", "roughness_id"]).loc[("real", 0)]
    mine = averaged_contrast(fit, "real")
    assert mine["p_value"] == pytest.approx(row["p_value"], rel=1e-12)
    assert mine["log_odds_ratio"] == pytest.approx(row["log_odds_ratio_A_vs_B"], rel=1e-12)


def test_unequal_groups_missing_trials_and_n_for_80_and_90():
    res = power_curve(_cells(0.25), [(4, 6), (10, 14), (26, 34)], simulations=300,
                      participant_sd=0.3, test="cluster-t", missing_rate=0.2, seed=7)
    t = res.table
    assert list(zip(t["n_group_A"], t["n_group_B"])) == [(4, 6), (10, 14), (26, 34)]
    assert list(t["n_per_group"]) == [5, 12, 30] and (t["missing_rate"] == 0.2).all()
    assert t["power"].iloc[-1] > 0.9
    n80 = res.settings["n_for_80"]
    assert n80 is not None and 5 <= n80 <= 30
    assert res.settings["n_for_90"] >= n80


def test_marginal_cells_are_converted_to_a_typical_participant():
    from scipy import integrate, special
    from analysis.power import to_conditional
    p = np.array([0.1, 0.4, 0.8])
    q = to_conditional(p, 1.2)
    for pi, qi in zip(p, q):
        avg = integrate.quad(lambda u: special.expit(special.logit(qi) + u)
                             * np.exp(-u * u / (2 * 1.44)) / np.sqrt(2 * np.pi * 1.44), -12, 12)[0]
        assert avg == pytest.approx(pi, abs=1e-7)
    # counting the spread twice would understate the difference the model implies
    res_m = power_curve(_cells(0.2), (10,), simulations=10, participant_sd=1.2,
                        cells_scale="marginal", test="cluster-t")
    assert res_m.table["expected_difference_A_minus_B"].iloc[0] == pytest.approx(0.2, abs=1e-6)


def test_cells_from_the_analysis_mixed_model(study, tmp_path):
    from analysis import analyze
    from analysis.power import glmm_cells
    data, _ = study(n_per_group=6, sigma=0.5, seed=8)
    analyze(data, tmp_path / "out", n_boot=20)
    cells, sd = glmm_cells(tmp_path / "out")
    glmm = pd.read_csv(tmp_path / "out" / "glmm.csv").set_index("term")
    assert sd == glmm.loc["participant_sd", "log_odds"] and len(cells) == 16
    c = pd.read_csv(tmp_path / "out" / "contrasts.csv")
    row = c[(c["model"] == "glmm") & (c["mode"] == "real") & (c["roughness_id"] == 2)].iloc[0]
    cell = cells.set_index(["group", "mode", "roughness_id"])["p_correct"]
    assert cell[("A", "real", 2)] == pytest.approx(row["p_correct_A"], rel=1e-10)
    assert cell[("B", "real", 2)] == pytest.approx(row["p_correct_B"], rel=1e-10)


def test_cli_power_bad_analysis_folder_and_sizes_exit_2(tmp_path, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["power", "--from-analysis", str(empty), "--effect-pp", "10",
                 "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"thermocue power: {empty / 'glmm.csv'}: term: expected") and "\n" not in err
    assert main(["power", "--n-per-group", "13:17:4", "--out", str(tmp_path / "o")]) == 2
    assert "A:B pairs" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_power_tests_are_one_table_and_the_error_names_them():
    from analysis.power import TESTS
    assert list(TESTS) == ["gee", "cluster-t"]
    with pytest.raises(ValueError, match="test: expected 'gee' or 'cluster-t', got 'anova'"):
        power_curve(_cells(0.2), (4,), simulations=2, test="anova")


def test_from_analysis_refuses_without_a_stated_effect_and_says_why(tmp_path, capsys):
    """Observed (post-hoc) power is never computed: the effect is the user's."""
    folder = tmp_path / "results"
    folder.mkdir()
    assert main(["power", "--from-analysis", str(folder), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("thermocue power: --effect-pp: expected the smallest") and "\n" not in err
    assert "observed (post-hoc) power" in err and "p-value" in err
    assert not (tmp_path / "o").exists()


def _marginal_mpmath(p_typical, sd):
    """E[expit(logit(p) + u)], u ~ N(0, sd^2), by mpmath quadrature (independent of the code)."""
    import mpmath
    c = mpmath.log(p_typical / (1 - p_typical))
    f = lambda u: mpmath.exp(-u * u / (2 * sd * sd)) / (sd * mpmath.sqrt(2 * mpmath.pi)) \
        / (1 + mpmath.exp(-(c + u)))
    return float(mpmath.quad(f, [-mpmath.inf, 0, mpmath.inf]))


@pytest.mark.parametrize("effect", [0.0, 7.5, -12.0])
def test_stated_effect_is_the_population_averaged_difference(effect):
    from analysis.power_design import cells_with_effect
    cells = _cells(0.0)
    out = cells_with_effect(cells, effect, participant_sd=0.9).set_index(
        ["group", "mode", "roughness_id"])["p_correct"]
    a = np.mean([_marginal_mpmath(out[("A", "real", r)], 0.9) for r in range(1, 5)])
    b = np.mean([_marginal_mpmath(out[("B", "real", r)], 0.9) for r in range(1, 5)])
    assert 100 * (a - b) == pytest.approx(effect, abs=1e-6)
    # group B and the other mode untouched
    before = cells_frame(cells).set_index(["group", "mode", "roughness_id"])["p_correct"]
    for key in before.index:
        if not (key[0] == "A" and key[1] == "real"):
            assert out[key] == before[key]


@pytest.mark.slow
def test_power_from_analysis_takes_the_design_and_curves_over_effects(study, tmp_path, capsys):
    from analysis import analyze
    data, _ = study(n_per_group=5, sigma=0.5, seed=9)
    analyze(data, tmp_path / "res", n_boot=20)
    assert main(["power", "--from-analysis", str(tmp_path / "res"), "--effect-pp", "0,25",
                 "--n-per-group", "6", "--simulations", "15", "--workers", "1",
                 "--out", str(tmp_path / "p")]) == 0
    out = capsys.readouterr().out
    assert "Observed (post-hoc) power is not shown" in out
    all_sd = pd.read_csv(tmp_path / "p" / "power.csv")
    t = all_sd[all_sd["sd_basis"] == "point estimate of the analysis"].reset_index(drop=True)
    assert list(t["effect_pp"]) == [0.0, 25.0]
    assert list(t["expected_difference_A_minus_B"]) == pytest.approx([0.0, 0.25], abs=1e-9)
    glmm = pd.read_csv(tmp_path / "res" / "glmm.csv").set_index("term")
    sd = glmm.loc["participant_sd"]
    assert (t["participant_sd"] == sd["log_odds"]).all()
    assert t.loc[0, "power"] <= 0.2 and t.loc[1, "power"] > t.loc[0, "power"]
    # the pilot's SD is uncertain: power at both ends of its profile interval too, each named
    ends = {basis: float(v) for basis, v in all_sd.groupby("sd_basis")["participant_sd"].first().items()}
    assert ends == pytest.approx({"point estimate of the analysis": sd["log_odds"],
                                  "lower end of its 95 % profile interval": max(sd["ci_low"], 0),
                                  "upper end of its 95 % profile interval": sd["ci_high"]})
    for value in ends.values():
        assert f"Conditional on participant SD = {value:.3f}" in out
        assert f"n per group for 80 % power at A - B +25 points, conditional on SD = {value:.3f}" in out
    summary = json.loads((tmp_path / "p" / "power_summary.json").read_text())
    assert summary["repetitions"] == 3 and summary["effects_pp"] == [0.0, 25.0]
    assert len(summary["by_participant_sd"]) == 3


@pytest.mark.slow   # starts two LocalClusters (8.9 s of the default suite, 555 s of 600 in CI here)
def test_power_is_the_same_here_and_on_one_or_two_dask_workers(caplog):
    # the cohorts are fixed, self-seeded tasks: who runs them, and how many workers, cannot
    # change the table (60 cohorts per size: tasks of 25, 25 and 10)
    import logging

    from experiments.simulation.sweep import Sweep
    kw = dict(simulations=60, participant_sd=0.4, seed=11, test="cluster-t", missing_rate=0.1)
    here = power_curve(_cells(0.15), (5, (6, 8)), **kw)
    tables = []
    for workers in (1, 2):
        with caplog.at_level(logging.INFO, logger="thermocue"), \
                Sweep(workers=workers, label="power") as sweep:
            tables.append(power_curve(_cells(0.15), (5, (6, 8)), map_tasks=sweep.map, **kw).table)
            assert sweep.n_workers == workers       # six tasks: the cluster did run them
    pd.testing.assert_frame_equal(tables[0], tables[1])
    pd.testing.assert_frame_equal(here.table, tables[1])
    # progress with the time remaining, from the sweep
    assert any("of 120 cohorts" in r.getMessage() and "remaining" in r.getMessage()
               for r in caplog.records)
    # a size's cohorts do not depend on the other sizes of the grid
    alone = power_curve(_cells(0.15), ((6, 8),), **kw).table
    pd.testing.assert_frame_equal(alone.reset_index(drop=True),
                                  here.table.iloc[[1]].reset_index(drop=True))


def test_cli_power_runs_on_a_local_cluster_with_progress(tmp_path, capsys):
    cells = tmp_path / "cells.csv"
    _write_cells(cells, _cells(0.2))
    out = tmp_path / "w2"
    assert main(["power", "--cells", str(cells), "--n-per-group", "5", "--simulations", "30",
                 "--test", "cluster-t", "--workers", "2", "--seed", "12", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "power: 30 of 30 cohorts" in err and "remaining" in err
    # the same table as the same computation here
    here = power_curve(read_cells(cells), (5,), simulations=30, test="cluster-t", seed=12,
                       participant_sd=0.5, cells_scale="marginal").table
    written = pd.read_csv(out / "power.csv")
    assert set(written.pop("sd_basis")) == {"default"}       # the one SD used, named
    pd.testing.assert_frame_equal(written, here, check_dtype=False)
    assert main(["power", "--cells", str(cells), "--workers", "0", "--out", str(tmp_path / "x")]) == 2
    assert "--workers: expected an integer >= 1" in capsys.readouterr().err


def test_cli_power_sends_the_cohorts_to_a_running_scheduler(tmp_path, capsys):
    # --scheduler ADDRESS: no local cluster of its own; the cluster's workers run the tasks
    import logging

    from distributed import Client, LocalCluster
    cells = tmp_path / "cells.csv"
    _write_cells(cells, _cells(0.2))
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        assert main(["power", "--cells", str(cells), "--n-per-group", "6", "--simulations", "30",
                     "--test", "cluster-t", "--seed", "13", "--scheduler",
                     cluster.scheduler_address, "--out", str(tmp_path / "p")]) == 0
        # that scheduler ran the cohort tasks (30 cohorts: tasks of 25 and 5)
        prefixes = client.run_on_scheduler(lambda dask_scheduler: {
            name: dict(p.state_counts) for name, p in dask_scheduler.task_prefixes.items()})
    assert "power: 30 of 30 cohorts" in capsys.readouterr().err
    here = power_curve(read_cells(cells), (6,), simulations=30, test="cluster-t", seed=13,
                       participant_sd=0.5, cells_scale="marginal").table
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "p" / "power.csv").drop(
                                      columns="sd_basis"), here,
                                  check_dtype=False)
    assert prefixes["cohort_task"]["memory"] == 2, prefixes     # each computed once, there


def test_a_single_task_runs_in_this_process_with_the_same_result():
    """A cluster for one task is pure overhead (and a forked process with another cluster's
    threads can hang starting one): a map of one task runs here, with the worker's result."""
    from experiments.simulation.sweep import Sweep
    kw = dict(simulations=20, participant_sd=0.4, seed=11, test="cluster-t", missing_rate=0.1)
    here = power_curve(_cells(0.15), (5,), **kw)
    with Sweep(workers=2, label="power") as sweep:
        table = power_curve(_cells(0.15), (5,), map_tasks=sweep.map, **kw).table
        assert sweep.client is None and sweep.cluster is None     # no cluster was started
    pd.testing.assert_frame_equal(here.table, table)


def test_cli_power_names_the_grid_it_searched(tmp_path, capsys):
    """With unequal groups 13:17 it printed 'not reached up to 17 per group'."""
    from experiments.cli.power import not_reached
    cells = tmp_path / "cells.csv"
    _write_cells(cells, _cells(0.0))
    assert main(["power", "--cells", str(cells), "--n-per-group", "13:17", "--simulations", "4",
                 "--out", str(tmp_path / "power")]) == 0
    out = capsys.readouterr().out
    assert "up to 17 per group" not in out
    assert ("n per group for 80 % power, conditional on SD = 0.500: not reached on the grid "
            "searched (13 + 17 participants, group A + group B)") in out
    assert "Conditional on participant SD = 0.500 (default):" in out
    # the grid is printed whether or not the target was reached
    assert "Grid searched: 13 + 17 (4 simulated cohorts per size)" in out
    from experiments.cli.power import grid_text
    assert grid_text([10, (20, 20), (13, 17)]) == "10 per group, 20 per group, 13 + 17"
    assert not_reached([15, 30, 60]) == "not reached up to 60 per group (grid searched: 15, 30, 60)"
    assert not_reached([(20, 20), 10]) == ("not reached up to 20 per group (grid searched: "
                                          "20 + 20, 10)")
