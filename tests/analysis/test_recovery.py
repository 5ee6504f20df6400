"""Parameter recovery: logs generated from known per-cell probabilities, analysed from disk.

Each replicate writes a 30-person study (15 per group, 3 repetitions per cell,
familiarisation and faulted attempts included) with the ``study`` fixture
(``_study_writer.write_study``, known probabilities ``_study_writer.paper_like_cells``),
loads it with :func:`analysis.load_trials` and computes the intervals with
:func:`analysis.cell_proportions`, exactly as ``thermocue analyze`` does.

Tolerance: 40 replicates × 16 cells = 640 intervals. Were they independent, the
number covering the truth would be Binomial(640, 0.95): SE = sqrt(0.95·0.05/640)
= 0.0086. The accepted band [0.92, 0.98] is ±3.5 SE, leaving room for the
correlation between cells that share participants when sigma > 0. Measured with
100-150 replicates (see ``analysis.cluster_bootstrap``): the default bootstrap
interval 0.95-0.96 in every scenario; the plain percentile bootstrap (0.91-0.92)
and, with extreme cells, the bootstrap-t (0.83-0.90) would fail this test, which
is why neither is the default.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.special import logit

from analysis import cell_proportions, fit_gee, group_contrasts, load_trials

REPLICATES = 40
BAND = (0.92, 0.98)


def _marginal_truth(cells, sigma):
    """E[expit(logit p + u)], u ~ N(0, sigma^2): 80-node Gauss-Hermite (exact p when sigma = 0)."""
    z, w = np.polynomial.hermite_e.hermegauss(80)
    w = w / w.sum()
    return {k: float(w @ (1 / (1 + np.exp(-(logit(p) + sigma * z))))) for k, p in cells.items()}


def _extreme_cells():
    """Sample 1# hard (0.06) and 4# easy (0.93) for everyone; A above B on 2# and 3# (real)."""
    rows = {("A", "real"): (0.06, 0.55, 0.65, 0.93), ("B", "real"): (0.06, 0.40, 0.50, 0.93),
            ("A", "simulated"): (0.06, 0.45, 0.55, 0.93), ("B", "simulated"): (0.06, 0.45, 0.55, 0.93)}
    return {(g, m, r + 1): p for (g, m), ps in rows.items() for r, p in enumerate(ps)}


def _coverage(study, sigma, seed0, cells=None):
    hits = {"wilson": 0, "boot": 0}
    total = 0
    for rep in range(REPLICATES):
        data, cells = study(cells, name=f"rep{rep}", sigma=sigma, seed=seed0 + rep,
                            fault_rate=0.03, write_events=False)   # events.jsonl: see test_load
        truth = _marginal_truth(cells, sigma)
        table = cell_proportions(load_trials(data).analysable, n_boot=1000, seed=rep)
        assert len(table) == 16 and (table["n_trials"] == 45).all()
        for row in table.itertuples():
            t = truth[(row.group, row.mode, row.roughness_id)]
            hits["wilson"] += row.wilson_low <= t <= row.wilson_high
            hits["boot"] += row.boot_low <= t <= row.boot_high
            total += 1
    return {k: v / total for k, v in hits.items()}


@pytest.mark.slow
def test_intervals_cover_known_probabilities_without_participant_differences(study):
    cov = _coverage(study, sigma=0.0, seed0=20261122)
    assert BAND[0] <= cov["wilson"] <= BAND[1], cov
    assert BAND[0] <= cov["boot"] <= BAND[1], cov


@pytest.mark.slow
def test_bootstrap_covers_with_participant_random_effects_and_extreme_cells(study):
    cov = _coverage(study, sigma=0.8, seed0=19270101, cells=_extreme_cells())
    assert BAND[0] <= cov["boot"] <= BAND[1], cov
    # Wilson treats trials as independent: it must do worse here (negative control)
    assert cov["wilson"] < cov["boot"], cov


@pytest.mark.slow
def test_gee_recovers_the_sign_of_the_group_effect(study):
    # A is 0.15 above B in real mode, equal in simulated mode (_study_writer.paper_like_cells)
    signs, excluded_zero = [], 0
    for rep in range(10):
        data, _ = study(name=f"g{rep}", sigma=0.5, seed=777 + rep)
        trials = load_trials(data).analysable
        c = group_contrasts(fit_gee(trials), trials).set_index(["mode", "roughness_id"])
        signs.append(c.loc[("real", 0), "log_odds_ratio_A_vs_B"] > 0)
        sim = c.loc[("simulated", 0)]
        excluded_zero += not (sim["ci_low"] <= 0 <= sim["ci_high"])
    # P(right sign) ~ 0.98 per replicate (difference 0.15, SE ~0.07): >= 9 of 10 has P ~ 0.98
    assert sum(signs) >= 9, signs
    # simulated mode has no group effect: its 95 % CI excludes zero rarely (P(>= 3 of 10) ~ 0.01)
    assert excluded_zero <= 2
