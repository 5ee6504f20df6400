"""Power to detect the group difference (A vs B) by simulating cohorts of varying size.

Each simulated participant gets a random intercept ``u ~ N(0, participant_sd²)``
on the log-odds scale; in each cell (group × mode × roughness) they answer
``repetitions`` trials correctly with probability ``expit(logit(p_cell) + u)``
(``p_cell`` is thus the probability for a typical participant, ``u = 0``).

Tests (``test=``):

``"cluster-t"`` (default)
    Welch's t-test on the per-participant proportion correct in the chosen
    mode (all samples pooled). Participants are the units, so the clustering
    is respected by construction; it targets the same quantity as the GEE's
    group effect averaged over roughness, at a thousandth of the cost, so
    thousands of cohorts take seconds.
``"gee"``
    The report's own test: a logit GEE ``correct ~ group + C(roughness_id)``
    on that mode's trials, participant clusters, exchangeable, bias-reduced
    covariance, two-sided Wald test of the group term. Slower (~20 ms a cohort).

Power is the share of cohorts rejecting "no group difference" at ``alpha``
(two-sided), with a Wilson interval for the Monte Carlo error;
``power_right_sign`` counts only rejections with group A higher.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import special, stats

from .errors import LogError
from .proportions import wilson_interval

__all__ = ["PowerResult", "power_curve", "read_cells", "cells_frame", "plot_power"]

_CELL_COLUMNS = ("group", "mode", "roughness_id", "p_correct")


@dataclass
class PowerResult:
    """Power per cohort size.

    Attributes
    ----------
    table : pandas.DataFrame
        ``n_per_group, simulations, power, power_low, power_high, power_right_sign,
        mean_difference_A_minus_B, expected_difference_A_minus_B`` (fractions 0–1).
    cells : pandas.DataFrame
        The per-cell probabilities used.
    settings : dict
        Mode, test, alpha, participant_sd, repetitions, seed.
    """

    table: pd.DataFrame
    cells: pd.DataFrame
    settings: dict = field(default_factory=dict)


def cells_frame(cells, source: str = "cells") -> pd.DataFrame:
    """Per-cell probabilities as a validated table.

    Parameters
    ----------
    cells : pandas.DataFrame or dict
        A table with ``group, mode, roughness_id, p_correct`` or a dict
        ``{(group, mode, roughness_id): p_correct}``.
    source : str
        Name used in error messages (e.g. the file).

    Returns
    -------
    pandas.DataFrame
        ``group, mode, roughness_id, p_correct``.

    Raises
    ------
    LogError
        A missing column or a probability outside [0, 1].
    """
    if isinstance(cells, dict):
        cells = pd.DataFrame([(g, m, r, p) for (g, m, r), p in cells.items()],
                             columns=list(_CELL_COLUMNS))
    for column in _CELL_COLUMNS:
        if column not in cells.columns:
            raise LogError(f"{source}: {column}: expected a column named {column!r}, "
                           f"got columns {list(cells.columns)!r}")
    out = cells[list(_CELL_COLUMNS)].copy()
    out["group"] = out["group"].astype(str)
    out["mode"] = out["mode"].astype(str)
    p = pd.to_numeric(out["p_correct"], errors="coerce")
    bad = p.isna() | (p < 0) | (p > 1)
    if bad.any():
        raise LogError(f"{source}: p_correct: expected a probability between 0 and 1, "
                       f"got {cells['p_correct'][bad].iloc[0]!r}")
    out["p_correct"] = p.astype(float)
    r = pd.to_numeric(out["roughness_id"], errors="coerce")
    if r.isna().any():
        raise LogError(f"{source}: roughness_id: expected an integer, "
                       f"got {cells['roughness_id'][r.isna()].iloc[0]!r}")
    out["roughness_id"] = r.astype(int)
    return out.sort_values(["group", "mode", "roughness_id"], ignore_index=True)


def read_cells(path) -> pd.DataFrame:
    """Read per-cell probabilities from a CSV (``group, mode, roughness_id, p_correct``).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    pandas.DataFrame

    Raises
    ------
    LogError
        Unreadable file, missing column, bad value (message names file and column).
    """
    path = Path(path)
    try:
        table = pd.read_csv(path)
    except (OSError, ValueError) as exc:
        raise LogError(f"{path}: file: expected a CSV with columns {', '.join(_CELL_COLUMNS)}, "
                       f"got {exc}") from None
    return cells_frame(table, str(path))


def _simulate_counts(p_a, p_b, n, sims, reps, sd, rng):
    """Correct counts, shape (sims, n, cells), for both groups."""
    out = []
    for p in (p_a, p_b):
        u = rng.normal(0.0, sd, size=(sims, n, 1)) if sd > 0 else np.zeros((sims, n, 1))
        prob = special.expit(special.logit(p)[None, None, :] + u)
        out.append(rng.binomial(reps, prob))
    return out


def _gee_reject(k_a, k_b, reps, alpha):
    import statsmodels.api as sm
    n, cells = k_a.shape
    rows = []
    for g, k in (("A", k_a), ("B", k_b)):
        for i in range(n):
            for c in range(cells):
                ones = int(k[i, c])
                rows += [(f"{g}{i}", g, c, 1)] * ones + [(f"{g}{i}", g, c, 0)] * (reps - ones)
    data = pd.DataFrame(rows, columns=["participant", "group", "roughness", "correct"])
    x = np.column_stack([np.ones(len(data)), (data["group"] == "A").to_numpy(float)] +
                        [(data["roughness"] == c).to_numpy(float) for c in range(1, cells)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            res = sm.GEE(data["correct"].to_numpy(float), x, groups=data["participant"],
                         family=sm.families.Binomial(),
                         cov_struct=sm.cov_struct.Exchangeable()).fit(cov_type="bias_reduced")
            est, se = float(res.params[1]), float(res.bse[1])
        except (np.linalg.LinAlgError, ValueError, ZeroDivisionError):
            return False, 0.0
    if not (np.isfinite(est) and np.isfinite(se) and se > 0 and abs(est) < 10):
        return False, 0.0
    return 2 * stats.norm.sf(abs(est / se)) < alpha, est


def power_curve(cells, n_per_group=(5, 10, 15, 20, 30), *, simulations: int = 2000,
                repetitions: int = 3, participant_sd: float = 0.5, mode: str = "real",
                alpha: float = 0.05, test: str = "cluster-t", seed: int = 20261122,
                progress=None) -> PowerResult:
    """Estimate the power to detect the group difference for each cohort size.

    Parameters
    ----------
    cells : pandas.DataFrame or dict
        Per-cell probabilities of a correct answer (see :func:`cells_frame`);
        must cover groups A and B in ``mode``.
    n_per_group : sequence of int
        Participants per group.
    simulations : int
        Simulated cohorts per size.
    repetitions : int
        Trials per participant and cell (the protocol's 3).
    participant_sd : float
        SD of the participants' random intercepts, log-odds.
    mode : {"real", "simulated"}
        The mode whose group difference is tested.
    alpha : float
        Two-sided significance level.
    test : {"cluster-t", "gee"}
        See the module notes.
    seed : int
        Seed of the simulation.
    progress : callable, optional
        Called with a message per cohort size.

    Returns
    -------
    PowerResult

    Raises
    ------
    LogError
        Cells missing for a group or sample.
    ValueError
        An unknown ``test`` or a non-positive size.
    """
    table = cells_frame(cells)
    if test not in ("cluster-t", "gee"):
        raise ValueError(f"power_curve: test: expected 'cluster-t' or 'gee', got {test!r}")
    sel = table[table["mode"] == mode]
    pa = sel[sel["group"] == "A"].set_index("roughness_id")["p_correct"]
    pb = sel[sel["group"] == "B"].set_index("roughness_id")["p_correct"]
    if pa.empty or pb.empty or set(pa.index) != set(pb.index):
        raise LogError(f"cells: group: expected probabilities for groups A and B on the same samples "
                       f"in mode {mode!r}, got A {sorted(pa.index)!r}, B {sorted(pb.index)!r}")
    ids = sorted(pa.index)
    # 0 and 1 have no log odds: nudge them inside by 1e-6 (no visible change in the simulation)
    p_a = np.clip(pa.loc[ids].to_numpy(float), 1e-6, 1 - 1e-6)
    p_b = np.clip(pb.loc[ids].to_numpy(float), 1e-6, 1 - 1e-6)
    rng = np.random.default_rng(seed)
    # the difference the model implies, averaged over participants (Gauss-Hermite, 40 nodes)
    z, w = np.polynomial.hermite_e.hermegauss(40)
    w = w / w.sum()
    def marginal(p):
        return float(np.mean([w @ special.expit(special.logit(q) + participant_sd * z) for q in p]))

    expected = marginal(p_a) - marginal(p_b)
    rows = []
    for n in n_per_group:
        n = int(n)
        if n < 2:
            raise ValueError(f"power_curve: n_per_group: expected integers >= 2, got {n!r}")
        if progress:
            progress(f"n = {n} per group: {simulations} cohorts ({test})")
        k_a, k_b = _simulate_counts(p_a, p_b, n, simulations, repetitions, participant_sd, rng)
        prop_a = k_a.sum(axis=2) / (repetitions * len(ids))
        prop_b = k_b.sum(axis=2) / (repetitions * len(ids))
        diff = prop_a.mean(axis=1) - prop_b.mean(axis=1)
        if test == "cluster-t":
            with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)   # identical proportions: p = nan
                res = stats.ttest_ind(prop_a, prop_b, axis=1, equal_var=False)
            pvals = np.nan_to_num(np.asarray(res.pvalue, float), nan=1.0)
            reject = pvals < alpha
            sign = diff > 0
        else:
            out = [_gee_reject(k_a[s], k_b[s], repetitions, alpha) for s in range(simulations)]
            reject = np.array([o[0] for o in out])
            sign = np.array([o[1] > 0 for o in out])
        hits = int(reject.sum())
        low, high = wilson_interval(hits, simulations)
        rows.append({"n_per_group": n, "simulations": simulations, "power": hits / simulations,
                     "power_low": float(low), "power_high": float(high),
                     "power_right_sign": float((reject & sign).mean()),
                     "mean_difference_A_minus_B": float(diff.mean()),
                     "expected_difference_A_minus_B": expected})
    settings = {"mode": mode, "test": test, "alpha": alpha, "participant_sd": participant_sd,
                "repetitions": repetitions, "seed": seed, "samples": ids}
    return PowerResult(pd.DataFrame(rows), table, settings)


def plot_power(result: PowerResult, path) -> Path:
    """Plot power against participants per group, with Monte Carlo intervals.

    Parameters
    ----------
    result : PowerResult
    path : str or Path
        PNG file to write.

    Returns
    -------
    Path
    """
    from .figures import _pyplot
    plt = _pyplot()
    t = result.table
    fig, ax = plt.subplots(figsize=(5.6, 4.2), dpi=150)
    ax.errorbar(t["n_per_group"], t["power"],
                yerr=[t["power"] - t["power_low"], t["power_high"] - t["power"]],
                marker="o", capsize=3, label=f"{result.settings['test']} test")
    ax.axhline(0.8, color="0.5", linestyle="--", linewidth=1, label="80 %")
    ax.axhline(result.settings["alpha"], color="0.5", linestyle=":", linewidth=1, label="alpha")
    ax.set_ylim(0, 1)
    ax.set_xlabel("participants per group")
    ax.set_ylabel("power (share of cohorts detecting A ≠ B)")
    s = result.settings
    ax.set_title(f"Group difference, {s['mode']} mode: expected A−B "
                 f"{t['expected_difference_A_minus_B'].iloc[0]:+.3f}, SD(u) {s['participant_sd']}",
                 fontsize=9)
    ax.legend(fontsize=8, frameon=False)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path)
    plt.close(fig)
    return path
