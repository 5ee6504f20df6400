"""Power for a stated effect: the design and nuisance parameters from an analysis, the effect
from the user.

Power computed at the effect a study *observed* ("observed" or post-hoc power) is a one-to-one
function of that study's p-value: it says nothing the p-value does not (a non-significant
result always has observed power below about 0.5) and it is not the power to detect anything
of interest. ``thermocue power --from-analysis`` therefore takes from the analysis only what
describes the design and the nuisance (group sizes, repetitions per cell, the share of
scheduled trials without an answer, the participant SD and the typical participant's cell
probabilities of group B), and takes the effect, the smallest difference worth detecting,
from the user: :func:`cells_with_effect` sets group A's cells so that the population-averaged
A - B difference of mean proportions in the tested mode is exactly that effect (one logit
shift over the samples, solved over 60-node Gauss-Hermite population averages).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy import optimize, special

from .errors import LogError
from .power import PowerResult, cells_frame, glmm_cells, n_for_power, power_curve

__all__ = ["design_from_analysis", "cells_with_effect", "power_by_effect",
           "OBSERVED_POWER_WHY"]

#: Why ``power --from-analysis`` refuses without a stated effect (printed with the refusal).
OBSERVED_POWER_WHY = ("observed (post-hoc) power, computed at the effect the study found, is a "
                      "function of the study's p-value and says nothing beyond it; give the "
                      "smallest effect of interest")


def design_from_analysis(analysis_dir) -> dict:
    """Design and nuisance parameters of a ``thermocue analyze`` output folder.

    Returns
    -------
    dict
        ``cells`` (typical-participant probabilities from the mixed model), ``participant_sd``
        (log odds), ``n_group_A``, ``n_group_B`` (participants analysed), ``repetitions``
        (largest answered trials per participant and cell), ``missing_rate`` (missing /
        scheduled scored trials, ``missing.csv``; 0 without it).

    Raises
    ------
    LogError
        Missing or unreadable files (the message names the file).
    """
    folder = Path(analysis_dir)
    cells, sd = glmm_cells(folder)
    path = folder / "cell_counts.csv"
    try:
        counts = pd.read_csv(path)
        people = counts.drop_duplicates("participant")["group"].astype(str).value_counts()
        reps = int(counts["n"].max())
    except (OSError, ValueError, KeyError) as exc:
        raise LogError(f"{path}: n: expected the per-participant cell counts of `thermocue "
                       f"analyze`, got {exc}") from None
    missing_rate = 0.0
    try:
        m = pd.read_csv(folder / "missing.csv")
        if m["scheduled"].sum() > 0:
            missing_rate = float(m["missing"].sum() / m["scheduled"].sum())
    except (OSError, ValueError, KeyError):
        pass
    return {"cells": cells, "participant_sd": sd, "n_group_A": int(people.get("A", 0)),
            "n_group_B": int(people.get("B", 0)), "repetitions": reps,
            "missing_rate": missing_rate, "participant_sd_interval": sd_interval(folder)}


def sd_interval(folder: Path) -> tuple[float, float] | None:
    """The participant SD's 95 % profile interval of the analysis (``glmm.csv``), or None.

    A pilot's SD is an estimate: at 30 participants its profile interval is wide (0.62-1.24
    around 0.9 in the worked example), and power moves with it (by up to 0.15 between pilots of
    one truth), so ``thermocue power --from-analysis`` computes power at both ends as well.
    """
    try:
        row = pd.read_csv(folder / "glmm.csv").set_index("term").loc["participant_sd"]
        low, high = float(row["ci_low"]), float(row["ci_high"])
    except (OSError, ValueError, KeyError):
        return None
    return (max(low, 0.0), high) if np.isfinite(low) and np.isfinite(high) and high > low else None


def sd_scenarios(design: dict, stated: float | None) -> list[tuple[str, float]]:
    """The participant SDs power is computed at, each with what it is.

    A stated ``--participant-sd``: that value alone. Else the analysis's point estimate and
    both ends of its 95 % profile interval (the range the pilot cannot rule out).
    """
    if stated is not None:
        return [("stated (--participant-sd)", float(stated))]
    out = [("point estimate of the analysis", float(design["participant_sd"]))]
    interval = design.get("participant_sd_interval")
    if interval is not None:
        out += [("lower end of its 95 % profile interval", interval[0]),
                ("upper end of its 95 % profile interval", interval[1])]
    return out


def cells_with_effect(cells, effect_pp: float, *, participant_sd: float,
                      mode: str = "real") -> pd.DataFrame:
    """Group A's cells in ``mode`` set so that the population-averaged A - B difference of
    mean proportions is ``effect_pp`` percentage points; every other cell kept.

    Parameters
    ----------
    cells : pandas.DataFrame or dict
        Typical-participant probabilities (``group, mode, roughness_id, p_correct``).
    effect_pp : float
        The stated effect, percentage points (A - B, may be negative or 0).
    participant_sd : float
        SD of the random intercepts, log odds.
    mode : str

    Returns
    -------
    pandas.DataFrame
        The cells, group A's in ``mode`` = expit(logit(B's) + shift).

    Raises
    ------
    LogError
        An effect no shift can give (beyond what B's cells leave room for).
    """
    table = cells_frame(cells)
    z, w = np.polynomial.hermite_e.hermegauss(60)
    w = w / w.sum()
    b = table[(table["group"] == "B") & (table["mode"] == mode)].set_index("roughness_id")
    lb = special.logit(np.clip(b["p_correct"].to_numpy(float), 1e-9, 1 - 1e-9))

    def marg(logits):
        return np.mean([w @ special.expit(c + participant_sd * z) for c in logits])

    target = effect_pp / 100.0
    base = marg(lb)
    f = lambda s: marg(lb + s) - base - target
    if not f(-30) < 0 < f(30):
        raise LogError(f"--effect-pp: expected an A - B difference group B's proportion "
                       f"({100 * base:.1f} %) leaves room for, got {effect_pp:g} points")
    shift = optimize.brentq(f, -30, 30, xtol=1e-12)
    out = table.copy()
    sel = (out["group"] == "A") & (out["mode"] == mode)
    out.loc[sel, "p_correct"] = out.loc[sel, "roughness_id"].map(
        dict(zip(b.index, special.expit(lb + shift)))).to_numpy(float)
    return out


def power_by_effect(cells, effects_pp, n_per_group, *, participant_sd: float,
                    mode: str = "real", progress=None, **options) -> PowerResult:
    """The power curve over stated effects and cohort sizes (:func:`analysis.power_curve` per
    effect, on cells from :func:`cells_with_effect`).

    Returns
    -------
    PowerResult
        ``table`` as :func:`analysis.power_curve`'s plus ``effect_pp``; ``settings`` gains
        ``effects_pp`` and ``n_for_80_by_effect`` / ``n_for_90_by_effect`` (dicts keyed by the
        effect).
    """
    tables, last, used = [], None, []
    for effect in effects_pp:
        c = cells_with_effect(cells, effect, participant_sd=participant_sd, mode=mode)
        if progress:
            progress(f"effect {effect:g} percentage points")
        r = power_curve(c, n_per_group, participant_sd=participant_sd, mode=mode,
                        cells_scale="conditional", progress=progress, **options)
        t = r.table.copy()
        t.insert(0, "effect_pp", float(effect))
        tables.append(t)
        used.append(c.assign(effect_pp=float(effect)))
        last = r
    table = pd.concat(tables, ignore_index=True)
    settings = dict(last.settings)
    settings.update(effects_pp=[float(e) for e in effects_pp],
                    n_for_80_by_effect={f"{e:g}": n_for_power(table[table["effect_pp"] == e], 0.8)
                                        for e in effects_pp},
                    n_for_90_by_effect={f"{e:g}": n_for_power(table[table["effect_pp"] == e], 0.9)
                                        for e in effects_pp})
    settings.pop("n_for_80", None)
    settings.pop("n_for_90", None)
    return PowerResult(table, pd.concat(used, ignore_index=True), settings)
