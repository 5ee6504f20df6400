"""Where the width of the random-slope mixed model's mode-contrast rows comes from, from the
per-dataset rows ``bench_unequal_groups.py --mixed-only --rows`` writes.

Not a test. Per row (real - simulated in group A, B, both; the interaction, truth 0): the
empirical SD of the estimate across datasets against the mean reported SE of each candidate
(model-based; participant sandwich without leverage adjustment, CR0; Mancl-DeRouen, MD;
Bell-McCaffrey CR2; the larger of model-based and MD, the rule before), then the coverage each
SE/df rule gives on the same datasets (a row covers when |estimate - truth| <= t_{0.975, df} *
SE), with the binomial Monte Carlo SE.

    .venv/bin/python benchmarks/mixed_se_rules.py 20+8.rows.json:20:8 24+6.rows.json:24:6
"""
from __future__ import annotations

import json
import sys

import numpy as np
from scipy import stats

ROWS = ("A", "B", "both", "interaction")


def _before(r, g, m):
    md, model = r[f"mixed_{g}_var_MD"], r[f"mixed_{g}_var_model"]
    return max(md, model), (r[f"mixed_{g}_welch_df_MD"] if md > model else m - 2)


RULES = {
    "before: larger of model-based and MD, its df": _before,
    "model-based SE, t(m - 2)": lambda r, g, m: (r[f"mixed_{g}_var_model"], m - 2),
    "CR0 sandwich, Welch df": lambda r, g, m: (r[f"mixed_{g}_var_CR0"],
                                               r[f"mixed_{g}_welch_df_CR0"]),
    "MD sandwich, Welch df": lambda r, g, m: (r[f"mixed_{g}_var_MD"],
                                              r[f"mixed_{g}_welch_df_MD"]),
    "CR2 sandwich, Welch df": lambda r, g, m: (r[f"mixed_{g}_var_CR2"],
                                               r[f"mixed_{g}_welch_df_CR2"]),
    "CR2 sandwich, Bell-McCaffrey df (now)": lambda r, g, m: (r[f"mixed_{g}_var_CR2"],
                                                              r[f"mixed_{g}_df"]),
}


def spread(rows: list) -> dict:
    """{row: (empirical SD of the estimate, {candidate: mean SE})}."""
    out = {}
    for g in ROWS:
        err = np.array([r[f"mixed_{g}_error"] for r in rows])
        ses = {k: float(np.mean([np.sqrt(r[f"mixed_{g}_var_{k}"]) for r in rows]))
               for k in ("model", "CR0", "MD", "CR2")}
        ses["max(model, MD)"] = float(np.mean([np.sqrt(_before(r, g, 0)[0]) for r in rows]))
        out[g] = (float(err.std(ddof=1)), ses)
    return out


def coverage(rows: list, m: int) -> dict:
    """{rule: {row: (coverage, binomial SE)}} over the datasets with a full slope fit."""
    out = {}
    for name, rule in RULES.items():
        out[name] = {}
        for g in ROWS:
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
        rows = [r for p in paths[0].split(",") for r in json.load(open(p))
                if r.get("mixed_full_formula")]
        print(f"{paths[0]}: {len(rows)} datasets with the full slope model")
        for g, (sd, ses) in spread(rows).items():
            cells = " ".join(f"{k} {v:.3f}" for k, v in ses.items())
            print(f"  {g:12s} SD of estimate {sd:.3f} | mean SE: {cells}")
        for name, by_row in coverage(rows, int(m_a) + int(m_b)).items():
            cells = " | ".join(f"{g} {p:.3f} ± {se:.3f}" for g, (p, se) in by_row.items())
            print(f"  {name:46s} {cells}")


if __name__ == "__main__":
    main()
