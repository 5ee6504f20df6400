"""The paper's claims as statistics (analysis.claims)."""
import numpy as np
import pytest
from scipy import stats

from analysis.claims import CLAIMS, claim_probabilities, evaluate_claims, wilson_interval

GROUPS = np.array(["A"] * 15 + ["B"] * 15)


def _study(real_by_sample, sim_by_sample, rng, a_bonus=0.0):
    """Correct counts out of 3 drawn from per-sample probabilities (group A + a_bonus, real)."""
    p = np.zeros((30, 2, 4))
    p[:, 0] = real_by_sample
    p[:, 1] = sim_by_sample
    p[:15, 0] = np.clip(p[:15, 0] + a_bonus, 0, 1)
    return rng.binomial(3, p)


def test_claims_have_statistics_and_criteria():
    ids = [c.id for c in CLAIMS]
    assert ids == ["rise_real", "rise_simulated", "confused_1_real", "confused_1_simulated",
                   "a_above_b_real", "smaller_diff_simulated", "table2_rises"]
    assert all(c.statistic and c.criterion and c.quote for c in CLAIMS)


def test_rise_and_confusion_follow_the_data():
    rng = np.random.default_rng(4)
    rising = np.stack([_study([0.3, 0.5, 0.7, 0.9], [0.9, 0.7, 0.5, 0.3], rng) for _ in range(50)])
    v = evaluate_claims(rising, GROUPS, 3)
    assert v["rise_real"][1].mean() > 0.95 and v["rise_simulated"][1].mean() == 0
    assert v["confused_1_real"][1].mean() > 0.9 and v["confused_1_simulated"][1].mean() < 0.05
    assert "table2_rises" not in v


def test_a_above_b_is_welchs_t_test():
    rng = np.random.default_rng(11)
    one = _study([0.5] * 4, [0.5] * 4, rng, a_bonus=0.15)
    stat, holds = evaluate_claims(one, GROUPS, 3)["a_above_b_real"]
    per = one[:, 0].mean(axis=1) / 3
    ref = stats.ttest_ind(per[:15], per[15:], equal_var=False, alternative="greater")
    assert stat[0] == pytest.approx(per[:15].mean() - per[15:].mean())
    assert bool(holds[0]) == bool(ref.pvalue < 0.05)


def test_table2_ordering_and_probability_table():
    rng = np.random.default_rng(2)
    many = np.stack([_study([0.4] * 4, [0.4] * 4, rng) for _ in range(200)])
    v = evaluate_claims(many, GROUPS, 3, replay_temperatures=[25.7, 25.73, 26.3, 27.3, 28.8])
    table = claim_probabilities(v).set_index("claim")
    assert table.loc["table2_rises", "probability"] == 1.0
    falling = evaluate_claims(many[:1], GROUPS, 3, replay_temperatures=[29.8, 29.8, 29.7, 28.7])
    assert not falling["table2_rises"][1][0]
    # no real difference between groups: the one-sided 5 % test holds about 5 % of the time
    assert table.loc["a_above_b_real", "probability"] < 0.15
    lo, hi = wilson_interval(table.loc["rise_real", "probability"] * 200, 200)
    assert table.loc["rise_real", "mc_low"] == pytest.approx(lo)
    joint = np.logical_and.reduce([h for _, h in v.values()])
    assert table.loc["all", "probability"] == pytest.approx(joint.mean())


def test_counts_from_trials_gives_per_participant_proportions():
    import pandas as pd

    from analysis.claims import counts_from_trials
    rows = []
    for pid, group, hits in (("P01", "A", 1.0), ("P02", "B", 0.0)):
        for mode in ("real", "simulated"):
            for rid in (1, 2, 3, 4):
                for rep in range(3):
                    rows.append({"participant": pid, "group": group, "mode": mode,
                                 "roughness_id": rid, "correct": hits if rid > 1 or rep else 1 - hits})
    props, groups = counts_from_trials(pd.DataFrame(rows))
    assert list(groups) == ["A", "B"]
    np.testing.assert_allclose(props[0, 0], [2 / 3, 1, 1, 1])
    np.testing.assert_allclose(props[1, 1], [1 / 3, 0, 0, 0])


def test_one_participant_per_group_shows_no_group_difference():
    # Welch's test is undefined with one participant per group: the claim is not shown
    one = np.zeros((2, 2, 4))
    one[0, 0] = 3
    stat, holds = evaluate_claims(one, np.array(["A", "B"]), 3)["a_above_b_real"]
    assert stat[0] == 1.0 and not holds[0]
