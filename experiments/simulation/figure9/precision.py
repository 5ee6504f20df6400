"""Monte Carlo precision before verdicts: when a claim's probability is decided, and the
per-study tables every probability is recomputed from.

A claim's probability (the share of simulated 15 + 15 studies that show it) is an estimate from
a finite number of studies.  Each carries a Wilson score interval at :data:`MC_LEVEL`
(:func:`analysis.claims.wilson_interval`).  A claim is *shown* by a scenario when the whole
interval lies above :data:`THRESHOLD`, *not shown* when it lies below, and *undecided at this
precision* when it contains 0.5.  A scenario *reproduces* the paper (in a reading, on a set of
claims) when every claim is shown, does *not* when one claim is not shown, and is *undecided*
otherwise.

Studies are added sequentially per scenario (:func:`round_sizes`: a first batch, then doubling
the total) until every status above is decided or the cap is reached.  With the defaults
(:data:`FIRST_STUDIES` then up to :data:`MAX_STUDIES`) there are at most five looks; the
interval's level, 0.99, is 0.95 Bonferroni-corrected over those five looks, so stopping at the
first look that decides does not inflate the error rate above 5 %.  At the cap a probability of
0.5 has a Monte Carlo standard error of 0.5 / sqrt(3200) = 0.0088 <= 0.01.

The chunks of studies keep their seeds ``(seed, scenario tag, chunk index)`` across rounds, and
the rounds depend only on results, so the outcome is the same on any number of workers.

:func:`study_table` writes one row per study x scenario (every claim's statistic and its
outcome in both readings, the proportions correct and the simulated block's answer shares);
:func:`runs_from_table` reads it back, so that ``reproduce figure9 --from DIR`` recomputes the
claims, the verdict and the figure without simulating.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["MC_LEVEL", "THRESHOLD", "FIRST_STUDIES", "MAX_STUDIES", "SENSITIVITY_MAX_STUDIES",
           "claim_status", "scenario_status", "round_sizes", "needs_more", "study_table",
           "runs_from_table", "MODES", "interval_text", "MARK"]

#: Confidence level of every claim probability's Monte Carlo interval (Wilson score).
MC_LEVEL = 0.99
#: A claim is shown by a scenario when its probability is above this (the interval says so).
THRESHOLD = 0.5
#: Studies per scenario in the first round (``--studies``).
FIRST_STUDIES = 200
#: Cap on the studies of one scenario (``--max-studies``): SE of 0.5 at the cap 0.0088.
MAX_STUDIES = 3200
#: Cap on the studies of one sensitivity row (a row still undecided there says so).
SENSITIVITY_MAX_STUDIES = 800
#: The two blocks of a study, in the order of the per-study arrays.
MODES = ("real", "simulated")
#: How a claim's status is marked in tables.
MARK = {"shown": "✓", "not shown": "✗", "undecided": "?"}


def claim_status(low: float, high: float) -> str:
    """``"shown"`` (interval above 0.5), ``"not shown"`` (below) or ``"undecided"``."""
    if low > THRESHOLD:
        return "shown"
    if high < THRESHOLD:
        return "not shown"
    return "undecided"


def scenario_status(statuses) -> str:
    """``"reproduced"`` (every claim shown), ``"not reproduced"`` (one not shown) or
    ``"undecided"`` (none not shown, one undecided)."""
    statuses = list(statuses)
    if any(s == "not shown" for s in statuses):
        return "not reproduced"
    if all(s == "shown" for s in statuses):
        return "reproduced"
    return "undecided"


def interval_text(p: float, low: float, high: float) -> str:
    """``0.47 [0.41, 0.54]``."""
    return f"{p:.2f} [{low:.2f}, {high:.2f}]"


def round_sizes(first: int, cap: int) -> list[int]:
    """Studies added per round: ``first``, then as many as there are (doubling), up to ``cap``.

    >>> round_sizes(200, 3200)
    [200, 200, 400, 800, 1600]
    >>> round_sizes(200, 200)
    [200]
    """
    first, cap = int(first), max(int(cap), int(first))
    sizes, total = [first], first
    while total < cap:
        add = min(total, cap - total)
        sizes.append(add)
        total += add
    return sizes


def _probabilities(readings: dict, level: float) -> dict:
    """reading -> claim id -> (p, low, high) from per-study outcomes."""
    from analysis.claims import wilson_interval
    out = {}
    for reading, verdicts in readings.items():
        out[reading] = {}
        for cid, (_, holds) in verdicts.items():
            n, k = holds.size, int(np.sum(holds))
            lo, hi = wilson_interval(k, n, level)
            out[reading][cid] = (k / n, float(lo), float(hi))
    return out


def needs_more(readings: dict, level: float = MC_LEVEL) -> bool:
    """Whether a scenario is undecided in a reading, on all its claims or on the paper's own."""
    from analysis.claims import CLAIMS
    own = {c.id for c in CLAIMS if c.own}
    for probs in _probabilities(readings, level).values():
        st = {cid: claim_status(lo, hi) for cid, (_, lo, hi) in probs.items()}
        if scenario_status(st.values()) == "undecided":
            return True
        if scenario_status(s for cid, s in st.items() if cid not in own) == "undecided":
            return True
    return False


def study_table(runs, groups=("A", "B")) -> pd.DataFrame:
    """One row per simulated study of every run: ``runs`` is a list of ``(keys, result)``.

    ``keys``: dict of the scenario's columns (hypothesis, observer; or choice, setting);
    ``result``: ``readings`` (reading -> claim -> (statistic, holds), (S,) each),
    ``proportions`` (S, groups, 2 modes, C) and ``answer_share`` (S, C).

    Columns: the keys, ``study`` (0-based), per claim ``<claim>`` (the statistic) and
    ``<claim>_descriptive`` / ``<claim>_inferential`` (1 when the study shows it), ``p_<group>_
    <mode>_<k>#`` (proportion correct) and ``answer_share_simulated_<k>#``.
    """
    frames = []
    for keys, res in runs:
        readings = res["readings"]
        first = next(iter(readings.values()))
        n = next(iter(first.values()))[0].size
        cols = {k: [v] * n for k, v in keys.items()}
        cols["study"] = np.arange(n)
        for cid, (stat, _) in first.items():
            cols[cid] = np.asarray(stat, dtype=float)
            for reading, verdicts in readings.items():
                cols[f"{cid}_{reading}"] = np.asarray(verdicts[cid][1]).astype(int)
        props = res["proportions"]
        for gi, g in enumerate(groups):
            for m, mode in enumerate(MODES):
                for c in range(props.shape[-1]):
                    cols[f"p_{g}_{mode}_{c + 1}#"] = props[:, gi, m, c]
        share = res.get("answer_share")
        if share is not None:
            for c in range(share.shape[-1]):
                cols[f"answer_share_simulated_{c + 1}#"] = share[:, c]
        frames.append(pd.DataFrame(cols))
    return pd.concat(frames, ignore_index=True)


def runs_from_table(table: pd.DataFrame, key_columns, source: str = "studies.csv",
                    groups=("A", "B")) -> list:
    """The runs of :func:`study_table` read back (its inverse), in the table's order.

    Raises
    ------
    ValueError
        Naming ``source`` and the missing column.
    """
    from analysis.claims import CLAIMS, READINGS
    for col in list(key_columns) + ["study"]:
        if col not in table.columns:
            raise ValueError(f"{source}: {col}: expected a column of the per-study table")
    claim_ids = [c.id for c in CLAIMS if c.id in table.columns]
    for cid in claim_ids:
        for reading in READINGS:
            if f"{cid}_{reading}" not in table.columns:
                raise ValueError(f"{source}: {cid}_{reading}: expected a column for claim {cid}")
    n_classes = sum(1 for c in table.columns if c.startswith(f"p_{groups[0]}_real_"))
    runs = []
    for keys, sel in table.groupby(list(key_columns), sort=False):
        sel = sel.sort_values("study")
        readings = {r: {cid: (sel[cid].to_numpy(float), sel[f"{cid}_{r}"].to_numpy() == 1)
                        for cid in claim_ids} for r in READINGS}
        props = np.stack([np.stack([np.stack([sel[f"p_{g}_{mode}_{c + 1}#"].to_numpy(float)
                                              for c in range(n_classes)], axis=-1)
                                    for mode in MODES], axis=1) for g in groups], axis=1)
        share_cols = [f"answer_share_simulated_{c + 1}#" for c in range(n_classes)]
        share = (sel[share_cols].to_numpy(float) if all(c in sel for c in share_cols) else None)
        keys = keys if isinstance(keys, tuple) else (keys,)
        runs.append((dict(zip(key_columns, keys)),
                     {"readings": readings, "proportions": props, "answer_share": share}))
    return runs
