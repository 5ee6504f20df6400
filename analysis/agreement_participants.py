"""Information transfer, kappa and Hu per participant, with cluster-bootstrap intervals and a
group comparison.

The pooled confusion matrices (:mod:`analysis.psychophysics`) treat every trial as independent
and give no uncertainty. Here each participant's own 4 x 4 matrix per mode (their 12 scored
trials) gives their information transfer (Miller-Madow corrected, bits), Cohen's kappa and
mean Wagner Hu; the participants are the units:

- per group x mode, the mean over participants with a **percentile bootstrap** interval
  (participants resampled with replacement within the group);
- group A - group B per mode: the difference of the means with a percentile bootstrap interval
  (each group resampled separately) and **Welch's t-test** (t with Welch-Satterthwaite df).

With 12 trials a participant's plug-in information is biased upwards (the correction removes
most of it) and their kappa is coarse; the means are comparable between groups and modes,
not with the pooled values.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats

from .psychophysics import confusion_counts, hu_values, information_transfer

__all__ = ["participant_agreement", "agreement_comparison", "MEASURES"]

#: The per-participant measures (column names).
MEASURES = ("it_bits_corrected", "kappa", "mean_hu")


def participant_agreement(trials: pd.DataFrame) -> pd.DataFrame:
    """Per participant x mode: ``n_trials, it_bits_corrected, kappa, mean_hu``.

    Returns
    -------
    pandas.DataFrame
        ``participant, group, mode, n_trials`` and :data:`MEASURES` (kappa NaN when the
        participant gave one answer only).
    """
    rows = []
    for (pid, group, mode), sel in trials.groupby(["participant", "group", "mode"]):
        n = confusion_counts(sel)
        total = n.sum()
        po = np.trace(n) / total
        pe = float(n.sum(axis=1) @ n.sum(axis=0)) / total ** 2
        hu = hu_values(n)[0]
        rows.append({"participant": pid, "group": group, "mode": mode, "n_trials": int(total),
                     "it_bits_corrected": information_transfer(n)["it_bits_corrected"],
                     "kappa": (po - pe) / (1 - pe) if pe < 1 else np.nan,
                     "mean_hu": float(np.nanmean(hu)) if np.isfinite(hu).any() else np.nan})
    return pd.DataFrame(rows, columns=["participant", "group", "mode", "n_trials", *MEASURES])


def _boot_means(values: np.ndarray, n_boot: int, rng) -> np.ndarray:
    idx = rng.integers(0, len(values), size=(n_boot, len(values)))
    return values[idx].mean(axis=1)


def agreement_comparison(per: pd.DataFrame, *, n_boot: int = 2000, level: float = 0.95,
                         seed: int = 20261122) -> pd.DataFrame:
    """Means per group x mode and A - B differences, with percentile bootstrap intervals.

    Parameters
    ----------
    per : pandas.DataFrame
        From :func:`participant_agreement`.
    n_boot : int
        Bootstrap resamples (0: no intervals).
    level : float
    seed : int

    Returns
    -------
    pandas.DataFrame
        ``measure, mode, group`` ("A", "B" or "A - B"), ``n_participants, estimate,
        pct_boot_low, pct_boot_high, interval, test, statistic, df, p_value`` (test columns on the
        A - B rows: Welch's t).
    """
    rng = np.random.default_rng(seed)
    lo_q, hi_q = 100 * (0.5 - level / 2), 100 * (0.5 + level / 2)
    how = f"percentile bootstrap over participants within group ({n_boot} resamples)"
    rows = []
    for measure in MEASURES:
        for mode, sel in per.groupby("mode"):
            values = {g: s[measure].dropna().to_numpy(float) for g, s in sel.groupby("group")}
            boots = {}
            for g, v in values.items():
                row = {"measure": measure, "mode": mode, "group": g, "n_participants": len(v),
                       "estimate": float(v.mean()) if len(v) else np.nan,
                       "pct_boot_low": np.nan, "pct_boot_high": np.nan, "interval": how,
                       "test": "", "statistic": np.nan, "df": np.nan, "p_value": np.nan}
                if len(v) > 1 and n_boot > 0:
                    boots[g] = _boot_means(v, n_boot, rng)
                    row["pct_boot_low"], row["pct_boot_high"] = np.percentile(
                        boots[g], [lo_q, hi_q])
                rows.append(row)
            if {"A", "B"} <= set(values) and len(values["A"]) > 1 and len(values["B"]) > 1:
                a, b = values["A"], values["B"]
                va, vb = a.var(ddof=1) / len(a), b.var(ddof=1) / len(b)
                se = np.sqrt(va + vb)
                df = (va + vb) ** 2 / (va ** 2 / (len(a) - 1) + vb ** 2 / (len(b) - 1)) \
                    if se > 0 else np.nan
                t = (a.mean() - b.mean()) / se if se > 0 else np.nan
                row = {"measure": measure, "mode": mode, "group": "A - B",
                       "n_participants": len(a) + len(b), "estimate": float(a.mean() - b.mean()),
                       "pct_boot_low": np.nan, "pct_boot_high": np.nan, "interval": how,
                       "test": f"Welch t({df:.1f})" if np.isfinite(df) else "Welch t",
                       "statistic": t, "df": df,
                       "p_value": float(2 * stats.t.sf(abs(t), df)) if np.isfinite(t) else np.nan}
                if "A" in boots and "B" in boots:
                    row["pct_boot_low"], row["pct_boot_high"] = np.percentile(
                        boots["A"] - boots["B"], [lo_q, hi_q])
                rows.append(row)
    return pd.DataFrame(rows)
