"""Wilson intervals, the participant-cluster bootstrap, per-participant summaries."""
from __future__ import annotations

import mpmath
import numpy as np
import pandas as pd
import pytest

from analysis import cell_proportions, cluster_bootstrap, participant_summary, wilson_interval


def _wilson_mp(k, n, level=0.95):
    """Wilson bounds as the roots of n (k/n - p)^2 = z^2 p (1 - p), solved in 40 digits."""
    mpmath.mp.dps = 40
    z = mpmath.sqrt(2) * mpmath.erfinv(mpmath.mpf(level))
    ph = mpmath.mpf(k) / n
    roots = mpmath.polyroots([n * ph * ph, -(2 * n * ph + z * z), n + z * z], asc=True)
    roots = sorted(mpmath.re(r) for r in roots)
    return float(roots[0]), float(roots[1])


@pytest.mark.parametrize("k, n", [(0, 10), (1, 10), (20, 45), (44, 45), (45, 45), (3, 7), (250, 1000)])
@pytest.mark.parametrize("level", [0.95, 0.8])
def test_wilson_matches_the_score_equation_roots(k, n, level):
    low, high = wilson_interval(k, n, level)
    ref_low, ref_high = _wilson_mp(k, n, level)
    assert float(low) == pytest.approx(max(ref_low, 0.0), abs=1e-12)
    assert float(high) == pytest.approx(min(ref_high, 1.0), abs=1e-12)



@pytest.mark.parametrize("n", [1, 3, 24, 45, 400])
@pytest.mark.parametrize("level", [0.95, 0.8])
def test_wilson_is_statsmodels_proportion_confint_on_a_grid(n, level):
    # one Wilson interval in the package: statsmodels' own, bit for bit, on every k = 0..n;
    # only k = 0 and k = n are set to exactly 0 and 1 (statsmodels leaves rounding there)
    from statsmodels.stats.proportion import proportion_confint
    import analysis.claims
    k = np.arange(n + 1)
    low, high = wilson_interval(k, n, level)
    ref_low, ref_high = proportion_confint(k, n, alpha=1 - level, method="wilson")
    np.testing.assert_array_equal(low[1:], ref_low[1:])
    np.testing.assert_array_equal(high[:-1], ref_high[:-1])
    assert low[0] == 0.0 and high[-1] == 1.0
    assert abs(ref_low[0]) < 1e-15 and abs(ref_high[-1] - 1.0) < 1e-15
    assert analysis.claims.wilson_interval is wilson_interval     # no second copy in claims


def _table(per_participant):
    """per_participant: {pid: (group, mode, roughness_id, [correct...])} lists -> trials."""
    rows = []
    for pid, cells in per_participant.items():
        for group, mode, r, answers in cells:
            for c in answers:
                rows.append({"participant": pid, "group": group, "mode": mode, "roughness_id": r,
                             "correct": c, "response_id": r if c else (r % 4) + 1,
                             "rt_s": 2.0 + c, "skin_thickness_um": 650.0 if group == "A" else 1000.0})
    return pd.DataFrame(rows)


def test_bootstrap_resamples_participants_not_trials():
    # 20 group-A people: half answer all 6 right, half all wrong -> strongly clustered
    people = {f"A{i}": [("A", "real", 1, [1] * 6 if i % 2 else [0] * 6)] for i in range(20)}
    trials = _table(people)
    boot = cluster_bootstrap(trials, n_boot=4000, seed=1, method="percentile")
    k = np.array([sum(c[0][3]) for c in people.values()], float)
    n = np.full(20, 6.0)
    p = k.sum() / n.sum()
    m = len(k)
    # the bootstrap variance of a ratio over m resampled clusters: (1/m^2) sum (k_i - p n_i)^2 / nbar^2
    expected_se = np.sqrt(((k - p * n) ** 2).sum() / m ** 2 / n.mean() ** 2)
    binomial_se = np.sqrt(p * (1 - p) / n.sum())
    assert boot["boot_se"].iloc[0] == pytest.approx(expected_se, rel=0.05)
    assert expected_se > 2 * binomial_se      # so resampling trials instead would fail the line above


def test_bootstrap_is_seeded_and_brackets_the_estimate(study):
    from analysis import load_trials
    data, _ = study(n_per_group=6, sigma=0.5, seed=21)
    trials = load_trials(data).analysable
    a = cell_proportions(trials, n_boot=500, seed=4)
    b = cell_proportions(trials, n_boot=500, seed=4)
    c = cell_proportions(trials, n_boot=500, seed=5)
    pd.testing.assert_frame_equal(a, b)
    assert not np.allclose(a["boot_low"], c["boot_low"])
    assert ((a["boot_low"] <= a["proportion_correct"]) & (a["proportion_correct"] <= a["boot_high"])).all()
    assert ((a["wilson_low"] <= a["proportion_correct"]) & (a["proportion_correct"] <= a["wilson_high"])).all()
    assert (a["n_trials"] == 6 * 3).all() and (a["n_participants"] == 6).all()
    assert list(a["roughness_um"].iloc[:4]) == [1.6, 12.5, 50.0, 100.0]


def test_cell_with_every_answer_right_gets_the_wilson_interval():
    people = {f"A{i}": [("A", "real", 1, [1, 1, 1]), ("A", "real", 2, [1, 0, i % 2])] for i in range(8)}
    table = cell_proportions(_table(people), n_boot=300, seed=2)
    row = table[table["roughness_id"] == 1].iloc[0]
    assert row["proportion_correct"] == 1.0
    assert row["boot_high"] == 1.0
    assert row["boot_low"] == pytest.approx(_wilson_mp(24, 24)[0], abs=1e-12)


def test_participant_summary_by_hand():
    people = {"A1": [("A", "real", 1, [1, 0, 1]), ("A", "real", 2, [0, 0, 0]),
                     ("A", "simulated", 1, [1, 1, 1])],
              "B1": [("B", "real", 1, [0, 0, 1])]}
    s = participant_summary(_table(people)).set_index(["participant", "mode"])
    assert s.loc[("A1", "real"), "n_trials"] == 6
    assert s.loc[("A1", "real"), "proportion_correct"] == pytest.approx(2 / 6)
    assert s.loc[("A1", "real"), "proportion_correct_r1"] == pytest.approx(2 / 3)
    assert s.loc[("A1", "real"), "proportion_correct_r2"] == 0.0
    assert s.loc[("A1", "simulated"), "proportion_correct"] == 1.0
    assert s.loc[("B1", "real"), "median_rt_s"] == 2.0
    assert s.loc[("B1", "real"), "skin_thickness_um"] == 1000.0


def test_bootstrap_methods_are_one_table_and_the_error_names_them():
    from analysis.proportions import BOOTSTRAP_METHODS
    assert list(BOOTSTRAP_METHODS) == ["wilson-deff", "studentized", "percentile"]
    trials = _table({"P1": [("A", "real", 1, [1, 0, 1])], "P2": [("A", "real", 1, [0, 0, 1])]})
    with pytest.raises(ValueError, match="method: expected 'wilson-deff', 'studentized' or "
                                         "'percentile', got 'bca'"):
        cluster_bootstrap(trials, method="bca")
    for name in BOOTSTRAP_METHODS:                     # every entry runs through the public call
        out = cluster_bootstrap(trials, n_boot=50, method=name)
        assert ((out["boot_low"] >= 0) & (out["boot_low"] <= out["boot_high"])
                & (out["boot_high"] <= 1)).all()
