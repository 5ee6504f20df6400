"""Power to detect the group difference (A vs B) by simulating cohorts and running the analysis.

One concept (~500 lines): power by simulation, from the cells it starts from to the curve it returns.

Cohorts are drawn from the participant-level model the report fits: participant
``i`` answers a trial of cell ``c`` (group × mode × sample) correctly with
probability ``expit(logit(p_c) + u_i)``, ``u_i ~ N(0, participant_sd²)``, where
``p_c`` is the probability for a *typical* participant (``u = 0``; the GLMM's
cells, see :func:`glmm_cells`). Observed or population-averaged proportions
(the simulated-participant model's predictions, ``proportions.csv``) already
contain the spread between participants: with ``cells_scale="marginal"`` they
are converted to typical-participant probabilities first (solving
``E[expit(c + u)] = p`` by 60-node Gauss-Hermite), so the spread is not counted twice.

Each simulated participant answers every cell of both modes ``repetitions``
times; each trial is lost at random with probability ``missing_rate`` (faults,
time-outs, no contact), and groups may differ in size (``(n_A, n_B)`` entries).

Tests (``test=``):

``"gee"`` (default: the report's primary test)
    Exactly what ``analyze`` does: :func:`analysis.fit_gee` with the report's
    formula and fallbacks (``correct ~ group * mode * C(roughness_id)``,
    participant clusters, exchangeable, bias-reduced covariance) on both modes'
    trials, then the A - B log odds ratio in ``mode`` averaged over the samples,
    two-sided Wald test. A cohort whose fit fails counts as not rejecting.
    About 50-100 ms a cohort.
``"cluster-t"``
    Welch's t-test on the per-participant proportion correct in ``mode``: a
    fast approximation (not the report's test).

Power is the share of cohorts rejecting "no group difference" at ``alpha``
(two-sided), with a Wilson interval for the Monte Carlo error;
``power_right_sign`` counts only rejections with group A higher;
``fallbacks`` the share fitted with a simpler formula (separation).
:func:`n_for_power` interpolates the n per group reaching a target power.

The cohorts are simulated in fixed tasks of :data:`COHORTS_PER_TASK` (:func:`cohort_task`), each
from its own seed, run here or handed to ``map_tasks`` (``thermocue power`` runs them on a
``dask.distributed`` cluster): the same seed gives the same table whoever runs the tasks.
"""
from __future__ import annotations

import json
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import special, stats
from threadpoolctl import threadpool_limits

from .errors import LogError
from .proportions import wilson_interval

__all__ = ["PowerResult", "power_curve", "read_cells", "cells_frame", "n_for_power",
           "to_conditional", "glmm_cells", "cohort_task", "cohort_chunks", "COHORTS_PER_TASK"]

_CELL_COLUMNS = ("group", "mode", "roughness_id", "p_correct")


@dataclass
class PowerResult:
    """Power per cohort size.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per cohort size (see :func:`power_curve`), fractions 0–1.
    cells : pandas.DataFrame
        The per-cell probabilities used.
    settings : dict
        Mode, test, alpha, participant_sd, repetitions, seed, missing rate, cells scale,
        ``n_for_80`` and ``n_for_90``.
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


def _marginal(c, sd, z, w):
    return float(w @ special.expit(c + sd * z))


def to_conditional(p, participant_sd: float) -> np.ndarray:
    """Typical-participant probabilities whose population average is ``p``.

    Parameters
    ----------
    p : array_like
        Population-averaged probabilities, 0-1 (clipped to [1e-6, 1 - 1e-6]).
    participant_sd : float
        SD of the random intercepts, log odds.

    Returns
    -------
    ndarray
        ``q`` with ``E[expit(logit(q) + u)] = p``, ``u ~ N(0, participant_sd²)``.
    """
    from scipy import optimize
    p = np.clip(np.asarray(p, float), 1e-6, 1 - 1e-6)
    if participant_sd == 0:
        return p
    z, w = np.polynomial.hermite_e.hermegauss(60)
    w = w / w.sum()
    out = [special.expit(optimize.brentq(lambda c: _marginal(c, participant_sd, z, w) - q, -30, 30))
           for q in p]
    return np.array(out)


def glmm_cells(analysis_dir) -> tuple[pd.DataFrame, float]:
    """Typical-participant cell probabilities and the participant SD from an ``analyze`` output.

    Reads ``glmm.csv`` and ``glmm_convergence.json`` (the fitted formula).

    Parameters
    ----------
    analysis_dir : str or Path

    Returns
    -------
    cells : pandas.DataFrame
        ``group, mode, roughness_id, p_correct`` (u = 0).
    participant_sd : float

    Raises
    ------
    LogError
        Missing or unreadable files.
    """
    import patsy   # only here: the fitted model's own design
    folder = Path(analysis_dir)
    try:
        table = pd.read_csv(folder / "glmm.csv").set_index("term")
        formula = json.loads((folder / "glmm_convergence.json").read_text("utf-8"))["formula"]
    except (OSError, ValueError, KeyError) as exc:
        raise LogError(f"{folder / 'glmm.csv'}: term: expected the mixed-model table and "
                       f"glmm_convergence.json of `thermocue analyze`, got {exc}") from None
    grid = pd.DataFrame([(g, m, r, 0) for g in ("A", "B") for m in ("real", "simulated")
                         for r in (1, 2, 3, 4)], columns=["group", "mode", "roughness_id", "correct"])
    rhs = formula.split("~", 1)[1]
    x = patsy.dmatrix(rhs, grid, return_type="dataframe")
    beta = table.loc[list(x.columns), "log_odds"].to_numpy(float)
    grid["p_correct"] = special.expit(x.to_numpy() @ beta)
    return grid.drop(columns="correct"), float(table.loc["participant_sd", "log_odds"])


def _sizes(entry) -> tuple[int, int]:
    if isinstance(entry, (tuple, list)):
        n_a, n_b = (int(v) for v in entry)
    else:
        n_a = n_b = int(entry)
    if min(n_a, n_b) < 2:
        raise ValueError(f"power_curve: n_per_group: expected sizes >= 2, got {entry!r}")
    return n_a, n_b


def _simulate(q, keys, n_a, n_b, reps, sd, missing_rate, rng):
    """Per participant × cell counts (k correct of n answered) of one cohort, as a table."""
    k, n, groups = _simulate_arrays(q, keys, n_a, n_b, reps, sd, missing_rate, rng)
    return _counts_table(k, n, groups, keys)


def _simulate_arrays(q, keys, n_a, n_b, reps, sd, missing_rate, rng):
    """Counts ``k``, ``n`` of shape (people, cells of the person's group) and the groups."""
    out_k, out_n, groups = [], [], []
    for g, size in (("A", n_a), ("B", n_b)):
        cols = [j for j, key in enumerate(keys) if key[0] == g]
        u = rng.normal(0.0, sd, size=(size, 1)) if sd > 0 else np.zeros((size, 1))
        n = rng.binomial(reps, 1 - missing_rate, size=(size, len(cols))) if missing_rate > 0 \
            else np.full((size, len(cols)), reps)
        k = rng.binomial(n, special.expit(special.logit(q[cols])[None, :] + u))
        out_k.append(k)
        out_n.append(n)
        groups.append(g)
    return out_k, out_n, groups


def _counts_table(k, n, groups, keys) -> pd.DataFrame:
    parts = []
    for kg, ng, g in zip(k, n, groups):
        cells = [key for key in keys if key[0] == g]
        people, cols = kg.shape
        parts.append(pd.DataFrame({
            "participant": np.repeat([f"{g}{i:03d}" for i in range(people)], cols),
            "group": g, "mode": [c[1] for c in cells] * people,
            "roughness_id": [c[2] for c in cells] * people,
            "k": kg.ravel(), "n": ng.ravel()}))
    return pd.concat(parts, ignore_index=True)


def _as_trials(counts: pd.DataFrame) -> pd.DataFrame:
    """One row per trial (``correct`` 0/1) from per participant × cell counts."""
    n = counts["n"].to_numpy()
    rep = counts.loc[counts.index.repeat(n)].reset_index(drop=True)
    within = np.concatenate([np.arange(v) for v in n]) if len(n) else np.array([], int)
    rep["correct"] = (within < np.repeat(counts["k"].to_numpy(), n)).astype(int)
    return rep.drop(columns=["k", "n"])


def _gee_primary(trials, mode, alpha, samples):
    from .inference import averaged_contrast
    from .models import FORMULA, fit_gee
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            fit = fit_gee(trials)
        except (np.linalg.LinAlgError, ValueError, ZeroDivisionError):
            return False, 0.0, True
        row = averaged_contrast(fit, mode, samples)
    fallback = fit.formula != FORMULA
    if row is None or not np.isfinite(row["p_value"]):
        return False, 0.0, fallback
    return bool(row["p_value"] < alpha), row["log_odds_ratio"], fallback


def _gee_cohort(k, n, groups, keys, prop, mode, alpha, samples):
    """The report's primary test on one simulated cohort (:func:`_gee_primary`)."""
    return _gee_primary(_as_trials(_counts_table(k, n, groups, keys)), mode, alpha, samples)


def _cluster_t(k, n, groups, keys, prop, mode, alpha, samples):
    """Welch's t on the per-participant proportions of one simulated cohort."""
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        res = stats.ttest_ind(prop["A"], prop["B"], equal_var=False)
    pv = float(res.pvalue) if np.isfinite(res.pvalue) else 1.0
    return pv < alpha, prop["A"].mean() - prop["B"].mean(), False


#: Simulated cohorts per task: fixed, so that the tasks (hence their seeds and results) are the
#: same whoever runs them (this process, or any number of workers of a cluster).
COHORTS_PER_TASK = 25


def cohort_chunks(simulations: int, size: int = COHORTS_PER_TASK) -> list[int]:
    """Cohort counts of the tasks that make ``simulations``: ``size`` each, the rest last."""
    full, rest = divmod(int(simulations), int(size))
    return [size] * full + ([rest] if rest else [])


@threadpool_limits.wrap(limits=1)   # small BLAS calls per cohort: threads only spin
def cohort_task(test, q, keys, n_a, n_b, repetitions, participant_sd, missing_rate, mode, alpha,
                ids, in_mode, n_cohorts, seed):
    """``n_cohorts`` simulated cohorts of one size and the test on each (one task of a sweep).

    Module level and picklable, so that a cluster's workers can run it; its random numbers come
    from ``seed`` alone (:func:`numpy.random.default_rng`).

    Returns
    -------
    tuple of lists
        Per cohort: rejected, estimate > 0, fitted with a fallback formula, the A - B difference
        of the mean per-participant proportions in ``mode``.
    """
    rng = np.random.default_rng(list(seed))
    reject, sign, fallback, diffs = [], [], [], []
    for _ in range(int(n_cohorts)):
        k, n, groups = _simulate_arrays(q, keys, n_a, n_b, repetitions, participant_sd,
                                        missing_rate, rng)
        prop = {}
        for kg, ng, g in zip(k, n, groups):
            kk, nn = kg[:, in_mode[g]].sum(axis=1), ng[:, in_mode[g]].sum(axis=1)
            prop[g] = kk[nn > 0] / nn[nn > 0]
        diffs.append(float(prop["A"].mean() - prop["B"].mean()))
        r, est, fb = TESTS[test](k, n, groups, keys, prop, mode, alpha, ids)
        reject.append(bool(r))
        sign.append(bool(est > 0))
        fallback.append(bool(fb))
    return reject, sign, fallback, diffs


def _local_map(progress):
    """A ``map_tasks`` that runs the tasks here, in order, saying how far and how long is left."""
    def run(fn, tasks, what="tasks", weights=None):
        weights = list(weights) if weights is not None else [1] * len(tasks)
        total, done, start, last = sum(weights), 0, time.perf_counter(), time.perf_counter()
        out = []
        for task, w in zip(tasks, weights):
            out.append(fn(*task))
            done += w
            now = time.perf_counter()
            if progress and (now - last >= 2.0 or done == total):
                elapsed = now - start
                progress(f"{done} of {total} {what}; elapsed {elapsed:5.1f} s, remaining "
                         f"{elapsed / done * (total - done):5.1f} s")
                last = now
        return out
    return run


#: The tests :func:`power_curve` simulates: name -> ``f(k, n, groups, keys, prop, mode, alpha,
#: samples) -> (rejected, estimate, fallback)`` for one cohort (the ``solve_ivp`` ``METHODS`` shape).
TESTS = {"gee": _gee_cohort, "cluster-t": _cluster_t}


@threadpool_limits.wrap(limits=1)   # small BLAS calls per cohort: threads only spin
def power_curve(cells, n_per_group=(5, 10, 15, 20, 30, 40, 60), *, simulations: int = 400,
                repetitions: int = 3, participant_sd: float = 0.5, mode: str = "real",
                alpha: float = 0.05, test: str = "gee", cells_scale: str = "conditional",
                missing_rate: float = 0.0, seed: int = 20261122, progress=None,
                map_tasks=None) -> PowerResult:
    """Estimate the power of the report's primary test for each cohort size.

    Parameters
    ----------
    cells : pandas.DataFrame or dict
        Per-cell probabilities of a correct answer (see :func:`cells_frame`) for
        groups A and B in both modes.
    n_per_group : sequence of int or (int, int)
        Participants per group, or ``(n_A, n_B)`` for unequal groups.
    simulations : int
        Simulated cohorts per size.
    repetitions : int
        Scheduled trials per participant and cell (the protocol's 3).
    participant_sd : float
        SD of the participants' random intercepts, log odds.
    mode : {"real", "simulated"}
        The mode whose averaged group difference is tested (the primary test: real).
    alpha : float
        Two-sided significance level.
    test : {"gee", "cluster-t"}
        See the module notes.
    cells_scale : {"conditional", "marginal"}
        Whether ``cells`` are typical-participant probabilities (the GLMM's) or
        population averages (observed proportions, the simulated-participant
        model's predictions), converted with :func:`to_conditional`.
    missing_rate : float
        Probability that a scheduled trial yields no answer, 0-1.
    seed : int
    progress : callable, optional
        Called with a message per cohort size and, running here, with the cohorts done and the
        time remaining.
    map_tasks : callable, optional
        ``map_tasks(fn, tasks, what=..., weights=...) -> [fn(*task) for task in tasks]`` in the
        order of ``tasks``: runs the simulated cohorts elsewhere, e.g. on a ``dask.distributed``
        cluster (``thermocue power`` passes :meth:`experiments.simulation.sweep.Sweep.map`).
        Default: here, in order. The cohorts come in fixed tasks of :data:`COHORTS_PER_TASK`,
        each from its own seed ``(seed, n_A, n_B, task)``, so the result is the same whoever
        runs them and with how many workers.

    Returns
    -------
    PowerResult
        ``table`` columns: ``n_group_A, n_group_B, n_per_group`` (their mean),
        ``simulations, power, power_low, power_high, power_right_sign, fallbacks,
        mean_difference_A_minus_B, expected_difference_A_minus_B, test, mode,
        participant_sd, alpha, missing_rate, cells_scale``; ``settings`` also holds
        ``n_for_80`` and ``n_for_90`` (:func:`n_for_power`).

    Raises
    ------
    LogError
        Cells missing for a group, mode or sample.
    ValueError
        An unknown ``test`` or ``cells_scale``, a size below 2, a rate outside [0, 1).
    """
    table = cells_frame(cells)
    _check_arguments(test, cells_scale, missing_rate)
    ids, keys, full = _cell_keys(table, test, mode)
    p = np.clip(np.array([full[k] for k in keys], float), 1e-6, 1 - 1e-6)
    q = to_conditional(p, participant_sd) if cells_scale == "marginal" else p
    z, w = np.polynomial.hermite_e.hermegauss(60)
    w = w / w.sum()
    marg = {k: _marginal(special.logit(v), participant_sd, z, w) for k, v in zip(keys, q)}
    expected = float(np.mean([marg[("A", mode, r)] for r in ids])
                     - np.mean([marg[("B", mode, r)] for r in ids]))
    in_mode = {g: [j for j, key in enumerate([kk for kk in keys if kk[0] == g])
                   if key[1] == mode] for g in ("A", "B")}
    sizes = [_sizes(entry) for entry in n_per_group]
    tasks, owner, weights = [], [], []
    for si, (n_a, n_b) in enumerate(sizes):
        if progress:
            label = f"n = {n_a} per group" if n_a == n_b else f"n = {n_a}:{n_b} (A:B)"
            progress(f"{label}: {simulations} cohorts ({test})")
        for ci, count in enumerate(cohort_chunks(simulations)):
            # each task's random numbers from its own seed: the same whoever runs it, and a
            # size's cohorts the same whatever other sizes the grid holds
            tasks.append((test, q, keys, n_a, n_b, repetitions, participant_sd, missing_rate,
                          mode, alpha, ids, in_mode, count, (int(seed), n_a, n_b, ci)))
            owner.append(si)
            weights.append(count)
    results = (map_tasks or _local_map(progress))(cohort_task, tasks, what="cohorts",
                                                  weights=weights)
    common = {"expected_difference_A_minus_B": expected, "test": test, "mode": mode,
              "participant_sd": participant_sd, "alpha": alpha, "missing_rate": missing_rate,
              "cells_scale": cells_scale}
    out = pd.DataFrame(_tally(sizes, results, owner, simulations, common))
    settings = {"mode": mode, "test": test, "alpha": alpha, "participant_sd": participant_sd,
                "repetitions": repetitions, "seed": seed, "samples": ids,
                "missing_rate": missing_rate, "cells_scale": cells_scale,
                "simulations": simulations,
                "test_description": ("GEE correct ~ group * mode * C(roughness_id) (report's "
                                     "fallbacks), Wald t(participants - 2) of the A-B log odds ratio averaged over "
                                     "samples" if test == "gee" else
                                     "Welch t on per-participant proportions (approximation)"),
                "n_for_80": n_for_power(out, 0.8), "n_for_90": n_for_power(out, 0.9)}
    return PowerResult(out, table, settings)


def _check_arguments(test: str, cells_scale: str, missing_rate: float) -> None:
    """:func:`power_curve`'s arguments in their domains (ValueError naming the argument)."""
    if test not in TESTS:
        raise ValueError(f"power_curve: test: expected {' or '.join(map(repr, TESTS))}, "
                         f"got {test!r}")
    if cells_scale not in ("conditional", "marginal"):
        raise ValueError(f"power_curve: cells_scale: expected 'conditional' or 'marginal', "
                         f"got {cells_scale!r}")
    if not 0 <= missing_rate < 1:
        raise ValueError(f"power_curve: missing_rate: expected 0 <= rate < 1, got {missing_rate!r}")


def _cell_keys(table: pd.DataFrame, test: str, mode: str):
    """The samples (``ids``), the simulated cells' ``(group, mode, roughness_id)`` keys and the
    cells' probabilities by key; LogError when a group or cell the test needs is missing."""
    sel = table[table["mode"] == mode]
    pa = sel[sel["group"] == "A"].set_index("roughness_id")["p_correct"]
    pb = sel[sel["group"] == "B"].set_index("roughness_id")["p_correct"]
    if pa.empty or pb.empty or set(pa.index) != set(pb.index):
        raise LogError(f"cells: group: expected probabilities for groups A and B on the same samples "
                       f"in mode {mode!r}, got A {sorted(pa.index)!r}, B {sorted(pb.index)!r}")
    ids = sorted(pa.index)
    if test == "gee":
        full = table.set_index(["group", "mode", "roughness_id"])["p_correct"]
        keys = [k for k in full.index if k[2] in ids]
        missing_cells = [(g, m, r) for g in ("A", "B") for m in sorted(table["mode"].unique())
                         for r in ids if (g, m, r) not in full.index]
        if missing_cells:
            raise LogError(f"cells: group: expected every group x mode x sample, got none for "
                           f"{missing_cells[0]!r}")
    else:
        keys = [(g, mode, r) for g in ("A", "B") for r in ids]
        full = table.set_index(["group", "mode", "roughness_id"])["p_correct"]
    return ids, keys, full


def _tally(sizes: list, results: list, owner: list, simulations: int, common: dict) -> list:
    """One row per size from its tasks' results (power, Wilson interval, fallbacks, the mean
    difference), with ``common``'s columns."""
    rows = []
    for si, (n_a, n_b) in enumerate(sizes):
        parts = [r for r, o in zip(results, owner) if o == si]
        reject = np.array([v for r in parts for v in r[0]], dtype=bool)
        sign = np.array([v for r in parts for v in r[1]], dtype=bool)
        fallback = [v for r in parts for v in r[2]]
        diffs = [v for r in parts for v in r[3]]
        hits = int(reject.sum())
        low, high = wilson_interval(hits, simulations)
        rows.append({"n_group_A": n_a, "n_group_B": n_b, "n_per_group": (n_a + n_b) / 2,
                     "simulations": simulations, "power": hits / simulations,
                     "power_low": float(low), "power_high": float(high),
                     "power_right_sign": float((reject & sign).mean()),
                     "fallbacks": float(np.mean(fallback)),
                     "mean_difference_A_minus_B": float(np.nanmean(diffs)), **common})
    return rows


def n_for_power(table: pd.DataFrame, target: float) -> float | None:
    """Participants per group at which power first reaches ``target`` (linear interpolation).

    Parameters
    ----------
    table : pandas.DataFrame
        ``PowerResult.table`` (``n_per_group``, ``power``), sizes increasing.
    target : float
        Power, 0-1.

    Returns
    -------
    float or None
        The interpolated n per group (mean of the two groups), rounded up to an
        integer; ``None`` if the grid never reaches the target.

    Examples
    --------
    >>> n_for_power(pd.DataFrame({"n_per_group": [10, 20], "power": [0.6, 0.9]}), 0.8)
    17.0
    """
    t = table.sort_values("n_per_group")
    n, pw = t["n_per_group"].to_numpy(float), t["power"].to_numpy(float)
    above = np.flatnonzero(pw >= target)
    if not len(above):
        return None
    i = above[0]
    if i == 0:
        return float(np.ceil(n[0]))
    frac = (target - pw[i - 1]) / (pw[i] - pw[i - 1])
    return float(np.ceil(n[i - 1] + frac * (n[i] - n[i - 1]) - 1e-9))

