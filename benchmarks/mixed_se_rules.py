"""Coverage of the random-slope mixed model's real - simulated rows under other SE/df rules,
from the per-dataset rows ``bench_unequal_groups.py --mixed --rows`` writes.

Not a test. Each rule gives a row its variance and df from the parts recorded per dataset
(model-based variance, bias-reduced participant-sandwich variance, the sandwich's
Welch-Satterthwaite df); a row covers when |estimate - truth| <= t_{0.975, df} * SE.

    .venv/bin/python benchmarks/mixed_se_rules.py 20+8.rows.json:20:8 24+6.rows.json:24:6
"""
from __future__ import annotations

import json
import sys

import numpy as np
from scipy import stats


def _max(r, g, m):
    return max(r[f"mixed_{g}_var_model"], r[f"mixed_{g}_var_sandwich"]), r[f"mixed_{g}_df"]


RULES = {
    "as reported (larger SE, its df)": _max,
    "model-based SE, t(m - 2)": lambda r, g, m: (r[f"mixed_{g}_var_model"], m - 2),
    "sandwich SE, Welch df": lambda r, g, m: (r[f"mixed_{g}_var_sandwich"],
                                              r[f"mixed_{g}_welch_df"]),
    "mean of the two variances, t(m - 2)": lambda r, g, m: (
        (r[f"mixed_{g}_var_model"] + r[f"mixed_{g}_var_sandwich"]) / 2, m - 2),
}


def coverage(rows: list, m: int) -> dict:
    """{rule: {group: (coverage, binomial SE)}} over the datasets with a mixed fit."""
    rows = [r for r in rows if "mixed_A_error" in r]
    out = {}
    for name, rule in RULES.items():
        out[name] = {}
        for g in ("A", "B", "both"):
            hits = []
            for r in rows:
                var, df = rule(r, g, m)
                hits.append(abs(r[f"mixed_{g}_error"]) <= stats.t.ppf(0.975, df) * np.sqrt(var))
            p = float(np.mean(hits))
            out[name][g] = (p, float(np.sqrt(p * (1 - p) / len(rows))))
    return out


def main() -> None:
    for arg in sys.argv[1:]:
        *paths, m_a, m_b = arg.split(":")
        rows = [r for p in paths[0].split(",") for r in json.load(open(p))]
        print(f"{paths[0]}: {sum('mixed_A_error' in r for r in rows)} datasets")
        for name, by_group in coverage(rows, int(m_a) + int(m_b)).items():
            cells = " | ".join(f"{g} {p:.3f} ± {se:.3f}" for g, (p, se) in by_group.items())
            print(f"  {name:38s} {cells}")


if __name__ == "__main__":
    main()
