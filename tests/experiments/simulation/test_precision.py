"""Monte Carlo precision before verdicts: statuses, sequential rounds, the per-study tables."""
import numpy as np
import pandas as pd
import pytest
from scipy.stats import beta, norm

from experiments.simulation.figure9.precision import (MAX_STUDIES, MC_LEVEL, claim_status,
                                                      needs_more, round_sizes, runs_from_table,
                                                      scenario_status, study_table)


def _wilson(k, n, level):
    # the textbook formula, written out here (not the code under test)
    z = norm.ppf(1 - (1 - level) / 2)
    p = k / n
    mid = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return mid - half, mid + half


def test_a_claim_is_undecided_while_its_interval_contains_one_half():
    # the review's case: 0.475 of 200 studies straddles 0.5; at 3200 studies it does not
    assert claim_status(*_wilson(95, 200, MC_LEVEL)) == "undecided"
    assert claim_status(*_wilson(1520, 3200, MC_LEVEL)) == "not shown"
    assert claim_status(*_wilson(140, 200, MC_LEVEL)) == "shown"
    assert claim_status(*_wilson(100, 200, MC_LEVEL)) == "undecided"    # 0.5 is not a majority


def test_scenario_status_needs_every_claim_shown_and_one_not_shown_decides():
    assert scenario_status(["shown", "shown"]) == "reproduced"
    assert scenario_status(["shown", "undecided"]) == "undecided"
    assert scenario_status(["undecided", "not shown"]) == "not reproduced"


def test_the_cap_keeps_the_standard_error_of_one_half_within_0_01():
    assert 0.5 / np.sqrt(MAX_STUDIES) <= 0.01
    assert sum(round_sizes(200, MAX_STUDIES)) == MAX_STUDIES
    assert len(round_sizes(200, MAX_STUDIES)) <= 5        # the looks the 0.99 level covers
    assert round_sizes(100, 350) == [100, 100, 150]


def _readings(outcomes):
    """reading -> claim -> (statistic, holds) from {claim: holds}."""
    return {r: {cid: (h.astype(float), h) for cid, h in outcomes.items()}
            for r in ("descriptive", "inferential")}


def test_a_scenario_needs_more_studies_only_while_a_status_is_undecided():
    n = 200
    ones = np.ones(n, bool)
    half = np.arange(n) < 96                                         # 0.48: undecided
    low = np.arange(n) < 20                                          # 0.10: not shown
    assert needs_more(_readings({"rise_real": ones, "a_above_b_real": half}))
    assert not needs_more(_readings({"rise_real": ones, "a_above_b_real": ones}))
    # one claim not shown decides "not reproduced", but the paper's claims alone are then
    # undecided when the failing claim is the project's own (*) and another is undecided
    assert not needs_more(_readings({"a_above_b_real": low, "smaller_diff_simulated": half}))
    assert needs_more(_readings({"no_dominant_answer_simulated": low,
                                 "smaller_diff_simulated": half}))


def test_the_per_study_table_reads_back_to_the_same_runs(tmp_path):
    rng = np.random.default_rng(1)
    S = 7
    stats = {"rise_real": rng.normal(size=S), "a_above_b_real": rng.normal(size=S)}
    # the statistic is the same in both readings; the outcome differs
    readings = {r: {cid: (x, rng.random(S) < 0.5) for cid, x in stats.items()}
                for r in ("descriptive", "inferential")}
    res = {"readings": readings, "proportions": rng.random((S, 2, 2, 4)),
           "answer_share": rng.dirichlet(np.ones(4), S)}
    path = tmp_path / "studies.csv"
    study_table([({"hypothesis": "skin", "observer": "absolute"}, res)]).to_csv(path, index=False)
    table = pd.read_csv(path)
    assert len(table) == S and set(table["study"]) == set(range(S))
    ((keys, back),) = runs_from_table(table, ("hypothesis", "observer"))
    assert keys == {"hypothesis": "skin", "observer": "absolute"}
    for r in readings:
        for cid, (stat, holds) in readings[r].items():
            np.testing.assert_allclose(back["readings"][r][cid][0], stat)
            np.testing.assert_array_equal(back["readings"][r][cid][1], holds)
    np.testing.assert_allclose(back["proportions"], res["proportions"])
    np.testing.assert_allclose(back["answer_share"], res["answer_share"])
    with pytest.raises(ValueError, match="studies.csv: a_above_b_real_inferential"):
        runs_from_table(table.drop(columns=["a_above_b_real_inferential"]),
                        ("hypothesis", "observer"))


def test_claim_probabilities_carry_a_wilson_interval_at_the_stated_level():
    from analysis.claims import claim_probabilities
    holds = np.arange(400) < 190
    table = claim_probabilities({"rise_real": (holds.astype(float), holds)}, MC_LEVEL)
    row = table.set_index("claim").loc["rise_real"]
    lo, hi = _wilson(190, 400, MC_LEVEL)
    assert row["probability"] == 0.475
    assert row["mc_low"] == pytest.approx(lo) and row["mc_high"] == pytest.approx(hi)
    # wider than Clopper-Pearson's would be at 95 %, narrower than nothing
    cp = beta.ppf(0.025, 190, 211), beta.ppf(0.975, 191, 210)
    assert row["mc_low"] < cp[0] and row["mc_high"] > cp[1]


def test_frames_made_from_a_sensitivity_table_share_its_runs_not_copies():
    # pandas deep-copies a frame's attrs into every frame made from it; the per-study runs
    # (here 3,000 studies) are shared instead: the report filters the table many times
    import copy

    from analysis.claims import CLAIMS
    from experiments.simulation.figure9.fitted_depth import with_depth_row
    from experiments.simulation.figure9.scenarios import (SENSITIVITY_CHOICES, result_from_runs,
                                                          sensitivity)
    choice, default = next((c, s) for c, settings in SENSITIVITY_CHOICES.items()
                           for s, change in settings.items() if not change)
    n = 3000
    readings = {r: {c.id: (np.zeros(n), np.arange(n) < n // 2) for c in CLAIMS}
                for r in ("descriptive", "inferential")}
    res = {"readings": readings, "proportions": np.full((n, 2, 2, 4), 0.5),
           "answer_share": np.tile((0.25,) * 4, (n, 1))}
    run = result_from_runs([({"hypothesis": "skin", "observer": "absolute"}, res)],
                           (1.6, 12.5, 50.0, 100.0)).runs[0][1]
    # settings that change nothing are the default run itself: nothing is simulated
    table = sensitivity(None, "skin", "absolute", default_run=run,
                        choices={choice: {default: {}, "again": {}}})
    runs = table.attrs["runs"]
    assert [keys for keys, _ in runs] == [{"choice": choice, "setting": default},
                                          {"choice": choice, "setting": "again"}]
    assert all(r is run for _, r in runs)
    assert table[table["choice"] == choice].attrs["runs"] is runs
    assert table["setting"].to_frame().attrs["runs"] is runs
    assert copy.deepcopy(table).attrs["runs"] is runs
    row = sensitivity(None, "skin", "absolute", default_run=run,
                      choices={"receptor depth (fitted)": {"fitted": {}}})
    both = with_depth_row(table, {"row": row})
    assert len(both) == 3 and [k["setting"] for k, _ in both.attrs["runs"]] == \
        [default, "again", "fitted"]
    assert both[both["setting"] == "again"].attrs["runs"] is both.attrs["runs"]
