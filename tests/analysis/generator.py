"""An in-memory trial generator for the recovery suite, independent of the code under test.

Random-intercept logistic model with known conditional cell probabilities
``p_cell`` (participant ``i`` answers correctly with probability
``expit(logit(p_cell) + u_i)``, ``u_i ~ N(0, sigma²)``), an explicit confusion
structure for wrong answers (a neighbouring sample twice as likely as a far one),
unequal groups, and trials lost at random (faults, time-outs: the cell then has
fewer than ``reps`` answers). Only numpy and pandas; nothing from ``analysis``.
"""
from __future__ import annotations

import numpy as np
import pandas as pd


def null_cells(base=(0.30, 0.45, 0.55, 0.70)):
    """No group effect anywhere; simulated samples 0.05 easier (conditional probabilities)."""
    return {(g, m, r + 1): p + (0.05 if m == "simulated" else 0.0)
            for g in ("A", "B") for m in ("real", "simulated") for r, p in enumerate(base)}


def effect_cells():
    """Group A above B with real samples only (a group × mode interaction)."""
    cells = null_cells()
    for r in range(1, 5):
        cells[("A", "real", r)] = min(cells[("B", "real", r)] + 0.15, 0.95)
    return cells


def generate(cells, *, n_a=13, n_b=17, reps=3, sigma=0.8, missing=0.03, seed=0,
             slope_sd=0.0) -> pd.DataFrame:
    """Analysable trials of one simulated study (columns as ``TrialLog.analysable``).

    ``slope_sd`` > 0 adds a participant effect of simulated vs real samples,
    ``N(0, slope_sd²)``, independent of the intercept.
    """
    rng = np.random.default_rng(seed)
    rows = []
    for group, n in (("A", n_a), ("B", n_b)):
        for i in range(n):
            pid = f"{group}{i:02d}"
            u = rng.normal(0.0, sigma)
            u_sim = rng.normal(0.0, slope_sd) if slope_sd > 0 else 0.0
            thickness = rng.uniform(600, 750) if group == "A" else rng.uniform(900, 1200)
            index = 0
            for mode in ("real", "simulated"):
                plan = [(r, k) for r in range(1, 5) for k in range(reps)]
                for j in rng.permutation(len(plan)):
                    r, rep = plan[j]
                    index += 1
                    if rng.random() < missing:
                        continue
                    q = cells[(group, mode, r)]
                    shift = u + (u_sim if mode == "simulated" else 0.0)
                    p = 1 / (1 + np.exp(-(np.log(q / (1 - q)) + shift)))
                    correct = rng.random() < p
                    if correct:
                        response = r
                    else:
                        others = np.array([s for s in range(1, 5) if s != r])
                        weight = np.where(np.abs(others - r) == 1, 2.0, 1.0)
                        response = int(rng.choice(others, p=weight / weight.sum()))
                    rows.append((pid, group, "S1", mode, index, mode, r, rep + 1, response,
                                 int(correct), float(rng.lognormal(1.5, 0.3)), thickness))
    return pd.DataFrame(rows, columns=["participant", "group", "session", "block", "trial_index",
                                       "mode", "roughness_id", "repetition", "response_id",
                                       "correct", "rt_s", "skin_thickness_um"])
