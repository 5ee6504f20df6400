"""Information transfer, kappa and Hu per participant, with studentized bootstrap intervals.

The pooled confusion matrices (:mod:`analysis.psychophysics`) treat every trial as independent
and give no uncertainty. Here each participant's own 4 x 4 matrix per mode (their 12 scored
trials) gives their information transfer (Miller-Madow corrected, bits), Cohen's kappa and
mean Wagner Hu; the participants are the units:

- per group x mode, the mean over participants with a **studentized (bootstrap-t)** interval:
  the participants resampled with replacement, each resample's t = (mean* - mean) / se*, the
  interval ``mean - t*_(0.975) se`` to ``mean - t*_(0.025) se`` [1]_ (Efron-Tibshirani ch. 12);
- group A - group B per mode: the difference of the means, each group resampled on its own
  (stratified), studentized with the Welch SE; the **union** of that interval and Welch's t
  interval (the wider on each side); the test is Welch's t (Welch-Satterthwaite df).

Why: these values are bounded and skewed (12 trials each). Measured over 400 null studies
(``benchmarks/bench_agreement_coverage.py``): t(n - 1) intervals of the group means covered
0.928-0.943, the studentized ones 0.944-0.953; Welch's A - B 0.932-0.951 and the studentized
0.934-0.946, each alone below 0.94 for some measure (BCa: 0.90-0.92, and the percentile
bootstrap 0.89-0.92: no small-sample correction). The resamples use a fixed seed, so a report
is reproducible.

With 12 trials a participant's plug-in information is biased upwards (the correction removes
most of it) and their kappa is coarse; the means are comparable between groups and modes,
not with the pooled values.

References
----------
.. [1] B. Efron, R. J. Tibshirani, *An Introduction to the Bootstrap*, Chapman & Hall (1993),
   ch. 12 (the bootstrap-t interval).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats

from .psychophysics import confusion_counts, hu_values, information_transfer

__all__ = ["participant_agreement", "agreement_comparison", "studentized_interval",
           "MEASURES"]

#: Bootstrap resamples of every studentized interval, and their seed (reproducible reports).
RESAMPLES = 1999
SEED = 20261128

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


def studentized_interval(a, b=None, *, level: float = 0.95, resamples: int = RESAMPLES,
                         seed: int = SEED) -> tuple[float, float]:
    """Bootstrap-t interval of ``mean(a)`` (or of ``mean(a) - mean(b)``, each sample resampled
    on its own), studentized with the (Welch) standard error.

    ``(NaN, NaN)`` when a sample has fewer than 2 values or no spread. Resamples with no
    spread (every value drawn the same) are left out of the t quantiles.
    """
    rng = np.random.default_rng(seed)
    samples = [np.asarray(a, float)] + ([] if b is None else [np.asarray(b, float)])
    if any(len(v) < 2 for v in samples):
        return np.nan, np.nan
    sign = [1.0, -1.0]
    est = sum(s * v.mean() for s, v in zip(sign, samples))
    se = np.sqrt(sum(v.var(ddof=1) / len(v) for v in samples))
    if not se > 0:
        return np.nan, np.nan
    boot_est = np.zeros(resamples)
    boot_var = np.zeros(resamples)
    for s, v in zip(sign, samples):
        draw = v[rng.integers(0, len(v), (resamples, len(v)))]
        boot_est += s * draw.mean(axis=1)
        boot_var += draw.var(axis=1, ddof=1) / len(v)
    ok = boot_var > 0
    t = (boot_est[ok] - est) / np.sqrt(boot_var[ok])
    lo, hi = np.quantile(t, [0.5 - level / 2, 0.5 + level / 2])
    return float(est - hi * se), float(est - lo * se)


def agreement_comparison(per: pd.DataFrame, *, level: float = 0.95) -> pd.DataFrame:
    """Means per group x mode and A - B differences, with studentized bootstrap intervals on the
    per-participant values.

    Parameters
    ----------
    per : pandas.DataFrame
        From :func:`participant_agreement`.
    level : float

    Returns
    -------
    pandas.DataFrame
        ``measure, mode, group`` ("A", "B" or "A - B"), ``n_participants, estimate, ci_low,
        ci_high, interval, test, statistic, df, p_value`` (test columns on the A - B rows).

    Notes
    -----
    A group's mean: studentized bootstrap (:func:`studentized_interval`); A - B: the union of
    the stratified studentized bootstrap interval and Welch's t interval, tested by Welch's t
    (module docstring; ``benchmarks/bench_agreement_coverage.py``).
    """
    rows = []
    for measure in MEASURES:
        for mode, sel in per.groupby("mode"):
            values = {g: s[measure].dropna().to_numpy(float) for g, s in sel.groupby("group")}
            for g, v in values.items():
                row = {"measure": measure, "mode": mode, "group": g, "n_participants": len(v),
                       "estimate": float(v.mean()) if len(v) else np.nan,
                       "ci_low": np.nan, "ci_high": np.nan, "interval": "",
                       "test": "", "statistic": np.nan, "df": np.nan, "p_value": np.nan}
                low, high = studentized_interval(v, level=level)
                if np.isfinite(low):
                    row.update(ci_low=low, ci_high=high,
                               interval=f"studentized bootstrap ({RESAMPLES} resamples of the "
                                        f"participants)")
                elif len(v) > 1:
                    row["interval"] = "none (no spread between participants)"
                rows.append(row)
            if {"A", "B"} <= set(values) and len(values["A"]) > 1 and len(values["B"]) > 1:
                rows.append(_welch_row(measure, mode, values["A"], values["B"], level))
    return pd.DataFrame(rows)


def _welch_row(measure: str, mode: str, a: np.ndarray, b: np.ndarray, level: float) -> dict:
    """Group A - B: Welch's t-test; interval the union of Welch's and the studentized one."""
    va, vb = a.var(ddof=1) / len(a), b.var(ddof=1) / len(b)
    se = np.sqrt(va + vb)
    df = (va + vb) ** 2 / (va ** 2 / (len(a) - 1) + vb ** 2 / (len(b) - 1)) if se > 0 else np.nan
    t = (a.mean() - b.mean()) / se if se > 0 else np.nan
    est = float(a.mean() - b.mean())
    half = stats.t.ppf(0.5 + level / 2, df) * se if np.isfinite(df) else np.nan
    low, high = studentized_interval(a, b, level=level)
    return {"measure": measure, "mode": mode, "group": "A - B",
            "n_participants": len(a) + len(b), "estimate": est,
            "ci_low": min(est - half, low), "ci_high": max(est + half, high),
            "interval": f"union of Welch t({df:.1f}) and the studentized bootstrap "
                        f"({RESAMPLES} resamples per group)" if np.isfinite(df)
            else "none (no spread between participants)",
            "test": f"Welch t({df:.1f})" if np.isfinite(df) else
                    "not tested: no spread between participants",
            "statistic": t, "df": df,
            "p_value": float(2 * stats.t.sf(abs(t), df)) if np.isfinite(t) else np.nan}
