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
                   "above_chance_real", "above_chance_simulated", "no_dominant_answer_simulated",
                   "a_above_b_real", "smaller_diff_simulated", "table2_rises"]
    assert all(c.statistic and c.descriptive and c.inferential and c.quote for c in CLAIMS)
    # the criteria that are the project's reading, not the paper's words, say so
    own = {c.id for c in CLAIMS if c.own}
    assert "no_dominant_answer_simulated" in own and "confused_1_real" in own
    assert "a_above_b_real" not in own and "rise_real" not in own


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


# --------------------------------------------------------------- recognition itself
def test_above_chance_is_a_one_sample_t_test_against_a_quarter():
    # correct out of 3 per sample; per-participant proportions over the 12 trials, by hand:
    # real 6/12 3/12 6/12 9/12 -> mean 0.5, deviations 0 -1/4 0 +1/4, s^2 = 0.125/3,
    #   t = 0.25 / (sqrt(0.125/3)/2) = sqrt(6) = 2.449 > t(0.95, 3) = 2.353 (table): shown
    # simulated 6/12 3/12 3/12 9/12 -> mean 0.4375, s^2 = 0.171875/3 = 0.0572917,
    #   t = 0.1875 / (0.239357/2) = 1.567 < 2.353: not shown
    c = np.zeros((4, 2, 4))
    c[:, 0] = [[1, 1, 2, 2], [0, 1, 1, 1], [2, 1, 1, 2], [1, 2, 3, 3]]
    c[:, 1] = [[1, 1, 2, 2], [0, 1, 1, 1], [0, 1, 1, 1], [1, 2, 3, 3]]
    v = evaluate_claims(c, np.array(["A", "A", "B", "B"]), 3)
    assert v["above_chance_real"][0][0] == pytest.approx(0.5)
    assert v["above_chance_real"][1][0]
    assert v["above_chance_simulated"][0][0] == pytest.approx(0.4375)
    assert not v["above_chance_simulated"][1][0]
    # the same decisions as scipy's one-sided one-sample t-test (an independent implementation)
    ref = stats.ttest_1samp(c[:, 1].sum(axis=1) / 12, 0.25, alternative="greater")
    assert ref.statistic == pytest.approx(1.5667, abs=1e-4) and ref.pvalue > 0.05
    assert "no_dominant_answer_simulated" not in v          # no answer counts given


def _all_fourth(n=30):
    """A study whose real block is recognised and whose simulated answers are all '4#'."""
    correct = np.zeros((n, 2, 4))
    correct[:, 0] = [2, 2, 3, 3]
    correct[:, 1] = [0, 0, 0, 3]
    answered = np.zeros((n, 2, 4))
    answered[:, 0] = [3, 3, 3, 3]
    answered[:, 1] = [0, 0, 0, 12]
    return correct, answered


def test_a_study_answering_4_to_every_simulated_sample_fails_the_recognition_claims():
    correct, answered = _all_fourth()
    v = evaluate_claims(correct, GROUPS, 3, answered=answered)
    # the old claims are fooled: a rise from 0 to 1 with roughness
    assert v["rise_simulated"][1][0]
    # proportion correct exactly 1/4 for everyone (sd 0): not above chance
    assert v["above_chance_simulated"][0][0] == pytest.approx(0.25)
    assert not v["above_chance_simulated"][1][0]
    # 360 of 360 simulated answers are 4#
    assert v["no_dominant_answer_simulated"][0][0] == pytest.approx(1.0)
    assert not v["no_dominant_answer_simulated"][1][0]
    # the real block (10/12 each, 3 of each answer) shows both
    assert v["above_chance_real"][0][0] == pytest.approx(10 / 12) and v["above_chance_real"][1][0]
    table = claim_probabilities(v).set_index("claim")
    assert table.loc["all", "probability"] == 0.0


def test_a_mostly_4_study_above_chance_still_fails_the_bias_claim():
    # half the participants answer 2# once (correct) and 4# otherwise, half answer 4# always:
    # proportions 4/12 and 3/12, mean 0.2917, s = 0.042379, t = 0.041667 / (s/sqrt(30)) = 5.39
    # > t(0.95, 29) = 1.699: above chance; answers: 15*11 + 15*12 = 345 of 360 are 4# = 0.9583
    correct, answered = _all_fourth()
    correct[:15, 1] = [0, 1, 0, 3]
    answered[:15, 1] = [0, 1, 0, 11]
    v = evaluate_claims(correct, GROUPS, 3, answered=answered)
    assert v["above_chance_simulated"][0][0] == pytest.approx(3.5 / 12)
    assert v["above_chance_simulated"][1][0]
    assert v["no_dominant_answer_simulated"][0][0] == pytest.approx(345 / 360)
    assert not v["no_dominant_answer_simulated"][1][0]


def test_dominant_answer_threshold_is_strict_half():
    correct = np.ones((2, 2, 4))
    ok = np.zeros((2, 2, 4))
    ok[:, 1] = [[3, 2, 1, 0], [2, 1, 1, 2]]       # pooled 5 3 2 2: 5/12 < 1/2
    half = ok.copy()
    half[:, 1] = [[3, 1, 1, 1], [3, 1, 1, 1]]     # pooled 6 2 2 2: 6/12, not < 1/2
    both = evaluate_claims(np.stack([correct, correct]), np.array(["A", "B"]), 3,
                           answered=np.stack([ok, half]), reading="descriptive")
    stat, holds = both["no_dominant_answer_simulated"]
    np.testing.assert_allclose(stat, [5 / 12, 0.5])
    assert list(holds) == [True, False]


def test_answers_from_trials_counts_each_participants_answers():
    import pandas as pd

    from analysis.claims import answers_from_trials, counts_from_trials
    rows = [("P02", "B", "simulated", 1, 4), ("P02", "B", "simulated", 2, 4),
            ("P02", "B", "simulated", 3, 4), ("P02", "B", "real", 1, 1),
            ("P01", "A", "simulated", 4, 2), ("P01", "A", "simulated", 4, None),
            ("P01", "A", "real", 2, 2), ("P01", "A", "real", 3, 2)]
    trials = pd.DataFrame(rows, columns=["participant", "group", "mode", "roughness_id",
                                         "response_id"])
    trials["correct"] = (trials.response_id == trials.roughness_id).astype(float)
    got = answers_from_trials(trials)
    _, groups = counts_from_trials(trials)
    assert list(groups) == ["A", "B"]
    np.testing.assert_array_equal(got[0], [[0, 2, 0, 0], [0, 1, 0, 0]])
    np.testing.assert_array_equal(got[1], [[1, 0, 0, 0], [0, 0, 0, 3]])


# ------------------------------------------------- two readings: descriptive and inferential
def test_descriptive_reading_is_the_direction_of_the_point_estimates():
    # A 0.60 vs B 0.55 on average with a wide spread: A - B > 0 (descriptive) without Welch's
    # test at 5 % (inferential); scipy's Welch test is the independent reference
    rng = np.random.default_rng(5)
    one = np.zeros((30, 2, 4))
    per = np.r_[rng.uniform(0.2, 1.0, 15), rng.uniform(0.15, 0.95, 15)]
    per[:15] += 0.6 - per[:15].mean()
    per[15:] += 0.55 - per[15:].mean()
    one[:, 0] = (per * 3)[:, None]
    from analysis.claims import evaluate_readings
    both = evaluate_readings(one, GROUPS, 3)
    ref = stats.ttest_ind(per[:15], per[15:], equal_var=False, alternative="greater")
    assert ref.pvalue > 0.05
    assert both["descriptive"]["a_above_b_real"][1][0]
    assert not both["inferential"]["a_above_b_real"][1][0]
    assert both["descriptive"]["a_above_b_real"][0][0] == pytest.approx(0.05)


def test_inferential_readings_match_scipys_tests():
    from analysis.claims import evaluate_readings
    rng = np.random.default_rng(8)
    seen = set()
    for k in range(40):
        probs = rng.uniform(0.1, 0.9, (30, 2, 4))
        probs[:, :, 0] -= 0.25 * (k % 3 == 0)               # 1# harder in a third of the studies
        probs[:15, 0] += 0.3 * (k % 4 == 0)                 # A better on real samples in a quarter
        c = rng.binomial(3, np.clip(probs, 0, 1))
        ans = rng.multinomial(12, [0.2, 0.2, 0.2, 0.4] if k % 2 else [0.1, 0.1, 0.1, 0.7],
                              size=(30, 2))
        inf = evaluate_readings(c, GROUPS, 3, answered=ans)["inferential"]
        p = c / 3
        for m, mode in enumerate(("real", "simulated")):
            d = p[:, m, 0] - p[:, m, 1:].mean(axis=1)
            ref = stats.ttest_1samp(d, 0.0, alternative="less")
            assert bool(inf[f"confused_1_{mode}"][1][0]) == bool(ref.pvalue < 0.05)
            seen.add(("confused", bool(ref.pvalue < 0.05)))
        e = p.mean(axis=2)
        ref = stats.ttest_ind(e[:15, 0] - e[:15, 1], e[15:, 0] - e[15:, 1], equal_var=False,
                              alternative="greater")
        assert bool(inf["smaller_diff_simulated"][1][0]) == bool(ref.pvalue < 0.05)
        seen.add(("smaller", bool(ref.pvalue < 0.05)))
        pooled = ans[:, 1].sum(axis=0)
        ref = stats.binomtest(int(pooled.max()), int(pooled.sum()), 0.5, alternative="less")
        assert bool(inf["no_dominant_answer_simulated"][1][0]) == bool(ref.pvalue < 0.05)
        seen.add(("dominant", bool(ref.pvalue < 0.05)))
    # both outcomes of every test occurred: the comparisons above are not vacuous
    assert len(seen) == 6, seen


def test_unknown_reading_is_refused():
    with pytest.raises(ValueError, match="reading"):
        evaluate_claims(np.zeros((2, 2, 4)), np.array(["A", "B"]), 3, reading="loose")


def test_the_critical_t_is_scipy_stats_t_ppf_including_invalid_df():
    from scipy.stats import t

    from analysis.claims import ALPHA, _t_crit
    df = np.array([-1.0, 0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 14.0, 28.7, 1e3, 1e9, np.inf, np.nan])
    np.testing.assert_array_equal(_t_crit(df), t.ppf(1 - ALPHA, df))
    assert _t_crit(14) == t.ppf(1 - ALPHA, 14)
