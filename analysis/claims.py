"""The paper's claims about Figure 9 and Table 2, as data, each with the statistic that tests it.

§3.2 of the paper says of Figure 9: the proportion correct "goes up slowly" with roughness, for
real and simulated samples; 1# "is often confused with other samples, both for the real and
simulated samples"; with real samples group A is "higher than that of the group B to a certain
extent", and "for simulated material ... this difference becomes less".  Its Table 2
"simulation" column rises with roughness (25.70 -> 28.82 °C).  Of recognition itself it says
that "the different surface roughness can be recognized by the thermal tactile perception to a
certain extent" although "the correct proportions ... are still not quite high", for real and
simulated samples alike: above chance (1/4), and -- since the simulated block is read as
recognition, not as one answer given to everything -- without one answer dominating the
simulated block (see :data:`DOMINANT_SHARE`).  :data:`CLAIMS` states each with
a statistic and the criterion under which one study "shows" it; :func:`evaluate_claims` applies
them to the correct-answer counts of one study or of thousands at once (no experiment runtime is
imported: counts come from logs via :func:`counts_from_trials`, or from simulated studies).

Two readings of every claim (:data:`READINGS`).  *Descriptive*: the direction or ordering the
paper states, in the study's point estimates (the paper reports proportions, no tests: "A is
higher than B to a certain extent" reads as A - B > 0).  *Inferential*: the same direction
backed by a one-sided test at :data:`ALPHA` (a study that shows it would let its authors claim
it against chance).  A claim whose criterion is the project's own reading rather than the
paper's words says so (:attr:`Claim.own`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .proportions import wilson_interval

__all__ = ["Claim", "CLAIMS", "evaluate_claims", "evaluate_readings", "counts_from_trials",
           "answers_from_trials", "claim_probabilities", "wilson_interval", "ALPHA",
           "DOMINANT_SHARE", "READINGS"]

#: The two readings of a claim: its direction in the point estimates, and that direction
#: backed by a one-sided test.
READINGS = ("descriptive", "inferential")

#: One-sided level of the claims that are tests.
ALPHA = 0.05

#: ``no_dominant_answer_simulated``: the most frequent answer of the simulated block (all
#: participants of a study pooled) must take less than this share of the answers.  In the
#: paper's balanced design (each sample 3 times in 12 trials) every answer is right in exactly
#: 1/4 of the trials, whatever the participant's accuracy: a perfect recogniser and an unbiased
#: guesser both give each answer 1/4 of the time.  An answer given in at least half of the
#: trials is therefore wrong in at least half of its uses -- it is given because of a response
#: bias (one label for whatever is felt), not because the sample was recognised.  The criterion
#: reads the confusion matrix's answer margins directly, so it needs no threshold on the
#: per-sample proportions correct (a bias towards 4# shows there as 4# near 1 and the others
#: near 0, but so could an observer who recognises 4# well and confuses the rest).
DOMINANT_SHARE = 0.5


@dataclass(frozen=True)
class Claim:
    """One claim of the paper.

    Parameters
    ----------
    id : str
        Column name in claims tables.
    short : str
        Column header (a few characters).
    text : str
        The claim in one line.
    quote : str
        Where the paper makes it.
    statistic : str
        The statistic computed from one study.
    descriptive : str
        When a study shows the claim read descriptively (its point estimates).
    inferential : str
        When a study shows it read inferentially (the test).
    own : str
        Empty when the criterion is the paper's statement itself; else what the project
        chose (the criterion is then the project's own, and tables mark it).
    """

    id: str
    short: str
    text: str
    quote: str
    statistic: str
    descriptive: str
    inferential: str
    own: str = ""

    @property
    def criterion(self) -> str:
        """The inferential criterion (the one reading tables used before there were two)."""
        return self.inferential


_T = f"one-sided test at {ALPHA:g}"

CLAIMS = (
    Claim("rise_real", "rise R", "proportion correct rises with roughness (real)",
          "§3.2 'the correct proportion ... goes up slowly'",
          "mean over participants of each one's least-squares slope of proportion correct on "
          "sample number 1-4 (per step)",
          "> 0", f"its one-sample t > t(0.95, P-1): {_T}"),
    Claim("rise_simulated", "rise S", "proportion correct rises with roughness (simulated)",
          "§3.2, as above, 'for both real and simulated'",
          "as rise_real, simulated trials", "> 0", "as rise_real"),
    Claim("confused_1_real", "1# low R", "1# is often confused (real)",
          "§3.2 '1# ... is often confused with other samples, both for the real and simulated'",
          "proportion correct of 1# minus the mean of 2#-4# (mean over participants)",
          "< 0: 1# recognised less often than the others on average",
          f"paired t of the per-participant differences < -t(0.95, P-1): {_T}",
          own="'often confused' read as 'below the mean of the other samples'"),
    Claim("confused_1_simulated", "1# low S", "1# is often confused (simulated)",
          "§3.2, as above", "as confused_1_real, simulated trials", "as confused_1_real",
          "as confused_1_real", own="as confused_1_real"),
    Claim("above_chance_real", ">1/4 R", "samples recognised above chance (real)",
          "§3.2 'the different surface roughness can be recognized ... to a certain extent'; "
          "'the correct proportions ... are still not quite high'",
          "mean over participants of each one's proportion correct over the four samples",
          "> 1/4", f"its one-sample t against 1/4 > t(0.95, P-1): {_T}",
          own="'recognized to a certain extent' read as 'above chance (1/4)'"),
    Claim("above_chance_simulated", ">1/4 S", "samples recognised above chance (simulated)",
          "§3.2, as above, 'for both real and simulated samples'",
          "as above_chance_real, simulated trials", "> 1/4", "as above_chance_real",
          own="as above_chance_real"),
    Claim("no_dominant_answer_simulated", "no bias S",
          "no single answer dominates the simulated block",
          "§3.2 reads the simulated block as recognition 'to a certain extent', like the real one",
          "share of the simulated block's answers (all participants pooled) taken by its most "
          "frequent answer; 1/4 in the balanced design without a response bias",
          f"< {DOMINANT_SHARE:g}: otherwise that answer is wrong in at least half of its uses",
          f"binomial test of that answer's count against a share of {DOMINANT_SHARE:g} "
          f"(answers pooled as independent): {_T}",
          own="the paper states no such claim: a response bias is not recognition"),
    Claim("a_above_b_real", "A>B R", "group A above group B with real samples",
          "§3.2 'the proportion of the group A is higher than that of the group B to a certain "
          "extent'",
          "difference of the groups' mean per-participant proportion correct (real), A - B",
          "> 0", f"Welch's t > t(0.95, Welch df): {_T}"),
    Claim("smaller_diff_simulated", "A-B S<R", "smaller A - B difference with simulated samples",
          "§3.2 'For simulated material, however, this difference becomes less'",
          "(A - B) real minus |A - B| simulated (mean per-participant proportions)",
          "> 0: a positive real difference larger than the simulated one's size",
          f"Welch's t of the per-participant real - simulated proportions, A against B, "
          f"> t(0.95, Welch df): {_T}"),
    Claim("table2_rises", "T2 rise", "Table 2's simulated interface temperature rises with roughness",
          "Table 2, 'simulation' column 25.70 -> 28.82 °C",
          "Spearman correlation of the replayed temperature at 20 s (35 °C skin, 24 °C steel, "
          "650 µm) with roughness 0.4-100 µm",
          "= +1: strictly increasing (a property of the replay, not of a study)",
          "as descriptive: a deterministic property of the replay, no test",
          own="the paper's Table 2 was read by a sensor on the skin side; that the display's "
              "replayed temperature must rise likewise is the project's reading"),
)


def _t_crit(df):
    """t's one-sided critical value at ``ALPHA`` for ``df`` (nan where ``df`` <= 0 or nan):
    the special function ``scipy.stats.t.ppf`` evaluates, without its argument handling
    (~80-250 µs a call; ``reproduce figure9`` makes ~2,000 calls in its main process)."""
    from scipy.special import stdtrit
    return stdtrit(df, 1 - ALPHA)


def _one_sample_t(x):
    """t of the mean of ``x`` (S, P) against 0 along axis 1; +-inf for a constant nonzero mean."""
    P = x.shape[1]
    mean = x.mean(axis=1)
    sd = x.std(axis=1, ddof=1) if P > 1 else np.full(x.shape[0], np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(sd > 0, mean / (sd / math.sqrt(P)),
                     np.where(mean > 0, np.inf, np.where(mean < 0, -np.inf, 0.0)))
    return mean, np.nan_to_num(t, nan=0.0)


def _welch_greater(a, b):
    """Welch's one-sided test that a's mean exceeds b's, per study: (difference, shown)."""
    na, nb = a.shape[1], b.shape[1]
    diff = a.mean(axis=1) - b.mean(axis=1)

    def _var_of_mean(x, n):   # sample variance / n; undefined (nan) for one participant
        if n < 2:
            return np.full(x.shape[0], np.nan)
        return np.sum((x - x.mean(axis=1, keepdims=True)) ** 2, axis=1) / (n - 1) / n
    va, vb = _var_of_mean(a, na), _var_of_mean(b, nb)
    se = np.sqrt(va + vb)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(np.isnan(se), np.nan, np.where(se > 0, diff / se, np.sign(diff) * np.inf))
        df = np.where(se > 0, (va + vb) ** 2 / (va ** 2 / max(na - 1, 1) + vb ** 2 / max(nb - 1, 1)),
                      na + nb - 2)
    return diff, np.nan_to_num(t, nan=-np.inf) > _t_crit(np.nan_to_num(df, nan=1.0))


def evaluate_readings(correct, groups, repetitions: int, replay_temperatures=None,
                      answered=None) -> dict:
    """Both readings of each claim for each study (see :func:`evaluate_claims`).

    Returns
    -------
    dict
        reading (:data:`READINGS`) -> claim id -> (statistic, holds), arrays of shape (S,).
        The statistic is the same in both readings.
    """
    c = np.asarray(correct, dtype=float)
    if c.ndim == 3:
        c = c[None]
    groups = np.asarray(groups)
    prop = c / float(repetitions)                                  # (S, P, 2, C)
    S, P, _, C = prop.shape
    desc, inf = {}, {}
    x = np.arange(1, C + 1, dtype=float)
    xc = x - x.mean()
    for m, mode in enumerate(("real", "simulated")):
        slope = np.sum(prop[:, :, m, :] * xc, axis=-1) / np.sum(xc ** 2)   # (S, P)
        mean, t = _one_sample_t(slope)
        desc[f"rise_{mode}"] = (mean, mean > 0)
        inf[f"rise_{mode}"] = (mean, t > _t_crit(P - 1))
        gap_each = prop[:, :, m, 0] - prop[:, :, m, 1:].mean(axis=-1)    # (S, P)
        gap, t = _one_sample_t(gap_each)
        desc[f"confused_1_{mode}"] = (gap, gap < 0)
        inf[f"confused_1_{mode}"] = (gap, t < -_t_crit(P - 1))
        each = prop[:, :, m, :].mean(axis=-1)                      # (S, P) over the samples
        excess, t = _one_sample_t(each - 1.0 / C)
        desc[f"above_chance_{mode}"] = (excess + 1.0 / C, excess > 0)
        inf[f"above_chance_{mode}"] = (excess + 1.0 / C, t > _t_crit(P - 1))
    if answered is not None:
        from scipy.stats import binom
        n = np.asarray(answered, dtype=float)
        if n.ndim == 3:
            n = n[None]
        totals = n[:, :, 1, :].sum(axis=1)                          # (S, C) pooled answers
        top, total = totals.max(axis=1), totals.sum(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            share = top / total
        desc["no_dominant_answer_simulated"] = (share, share < DOMINANT_SHARE)
        p_low = binom.cdf(top, total, DOMINANT_SHARE)
        inf["no_dominant_answer_simulated"] = (share, (total > 0) & (p_low < ALPHA))
    per = prop.mean(axis=3)                                         # (S, P, 2)
    a, b = per[:, groups == "A"], per[:, groups == "B"]
    diff, shown = _welch_greater(a[:, :, 0], b[:, :, 0])
    desc["a_above_b_real"] = (diff, diff > 0)
    inf["a_above_b_real"] = (diff, shown)
    diff_sim = a[:, :, 1].mean(axis=1) - b[:, :, 1].mean(axis=1)
    gap = diff - np.abs(diff_sim)
    desc["smaller_diff_simulated"] = (gap, gap > 0)
    _, shown = _welch_greater(a[:, :, 0] - a[:, :, 1], b[:, :, 0] - b[:, :, 1])
    inf["smaller_diff_simulated"] = (gap, shown)
    if replay_temperatures is not None:
        from scipy.stats import spearmanr
        temps = np.asarray(replay_temperatures, dtype=float)
        rho = float(spearmanr(np.arange(temps.size), temps).statistic)
        strictly = bool(np.all(np.diff(temps) > 0))
        desc["table2_rises"] = inf["table2_rises"] = (np.full(S, rho), np.full(S, strictly))
    order = [cl.id for cl in CLAIMS]
    return {"descriptive": {k: desc[k] for k in order if k in desc},
            "inferential": {k: inf[k] for k in order if k in inf}}


def evaluate_claims(correct, groups, repetitions: int, replay_temperatures=None,
                    answered=None, reading: str = "inferential") -> dict:
    """Statistic and verdict of each claim for each study, in one reading.

    Parameters
    ----------
    correct : array_like of int, shape (S, P, 2, C) or (P, 2, C)
        Correct answers per study, participant, mode (0 real, 1 simulated) and sample
        (1# first), out of ``repetitions`` trials.
    groups : array_like of str, shape (P,)
        "A" or "B" per participant.
    repetitions : int
    replay_temperatures : array_like, °C, optional
        The replayed interface temperature at Table 2's conditions, one per roughness in
        increasing order; without it ``table2_rises`` is left out.
    answered : array_like, shape (S, P, 2, C) or (P, 2, C), optional
        How often each participant gave each answer (1# first) per mode: the column sums of
        their confusion matrices (:func:`answers_from_trials`); without it
        ``no_dominant_answer_simulated`` is left out.
    reading : {"inferential", "descriptive"}
        Which criterion of each claim (:data:`READINGS`).

    Returns
    -------
    dict
        claim id -> (statistic, holds), arrays of shape (S,) (one study: shape (1,)).
    """
    if reading not in READINGS:
        raise ValueError(f"evaluate_claims: reading: expected one of {', '.join(READINGS)}, "
                         f"got {reading!r}")
    return evaluate_readings(correct, groups, repetitions, replay_temperatures, answered)[reading]


def counts_from_trials(trials: pd.DataFrame, roughness_ids=(1, 2, 3, 4)):
    """Correct counts of one study from its analysable trials.

    Parameters
    ----------
    trials : pandas.DataFrame
        Columns participant, group, mode, roughness_id, correct (one row per scored trial,
        e.g. :attr:`analysis.TrialLog.analysable`).

    Returns
    -------
    correct : ndarray, shape (P, 2, C)
        Proportion correct (not counts) per participant, mode, sample; ``repetitions`` is then 1.
    groups : ndarray of str, shape (P,)
    """
    people = trials.drop_duplicates("participant").sort_values("participant")
    out = np.full((len(people), 2, len(roughness_ids)), np.nan)
    table = trials.groupby(["participant", "mode", "roughness_id"])["correct"].mean()
    for i, pid in enumerate(people["participant"]):
        for m, mode in enumerate(("real", "simulated")):
            for j, rid in enumerate(roughness_ids):
                out[i, m, j] = table.get((pid, mode, rid), np.nan)
    return out, people["group"].to_numpy()


def answers_from_trials(trials: pd.DataFrame, roughness_ids=(1, 2, 3, 4)) -> np.ndarray:
    """How often each participant gave each answer, per mode, from its scored trials.

    Parameters
    ----------
    trials : pandas.DataFrame
        Columns participant, mode, response_id (as :func:`counts_from_trials`).

    Returns
    -------
    ndarray of int, shape (P, 2, C)
        Participants in the order of :func:`counts_from_trials`; answers 1# first.
    """
    people = trials.drop_duplicates("participant").sort_values("participant")["participant"]
    out = np.zeros((len(people), 2, len(roughness_ids)), dtype=int)
    answered = trials.dropna(subset=["response_id"])
    table = answered.groupby(["participant", "mode", answered["response_id"].astype(int)]).size()
    for i, pid in enumerate(people):
        for m, mode in enumerate(("real", "simulated")):
            for j, rid in enumerate(roughness_ids):
                out[i, m, j] = int(table.get((pid, mode, int(rid)), 0))
    return out


def claim_probabilities(verdicts: dict, level: float = 0.95) -> pd.DataFrame:
    """Probability (with its Monte-Carlo Wilson interval) that a study shows each claim.

    Parameters
    ----------
    verdicts : dict
        From :func:`evaluate_claims` on many simulated studies.
    level : float
        Confidence level of the Wilson score interval (:func:`wilson_interval`) over studies.

    Returns
    -------
    pandas.DataFrame
        Columns claim, probability, mc_low, mc_high, n_studies, mean_statistic; a last row
        ``all``: the probability that one study shows every claim at once (the likelihood of
        the paper's evidence under the scenario).
    """
    rows = []
    shown = [(c.id, *verdicts[c.id]) for c in CLAIMS if c.id in verdicts]
    joint = np.logical_and.reduce([h for _, _, h in shown])
    for cid, stat, holds in shown + [("all", joint.astype(float), joint)]:
        n = holds.size
        k = int(np.sum(holds))
        lo, hi = wilson_interval(k, n, level)
        rows.append({"claim": cid, "probability": k / n, "mc_low": float(lo),
                     "mc_high": float(hi), "n_studies": n,
                     "mean_statistic": float(np.mean(stat[np.isfinite(stat)])) if np.any(np.isfinite(stat)) else float("nan")})
    return pd.DataFrame(rows)
