"""The random-slope model's profile ends at singular fits: with and without the extra start off
a degenerate covariance (``profile_end(..., off_boundary=...)`` of
``analysis.glmm_slope_profile``), against a many-start reference.

Not a test. Datasets from ``tests/analysis/generator.py`` (independent of the code under test),
the scenarios of ``bench_profile_restart.py``: ``--studies`` studies per scenario, each fitted
once (``fit_glmm_slope``), then the four SD ends computed from the fit's conditional modes with
``off_boundary=True`` (the default) and ``False`` (the rule before 2026-11-29). Where the two
differ by more than Brent's tolerance (2e-5), and at every SD upper end of a singular fit
(``is_singular``: lme4's rule, the correlation at +-1 or an SD at 0), the end is computed a
third time by this script's reference:
Brent's method on a profile whose every point is minimised from the estimate with the
correlation started at -0.997, -0.68, 0, 0.68 and 0.997 (five starts from the fit's
conditional modes; the lowest deviance kept). Prints one JSON line per scenario: how many fits were singular, how many ends the rule
changed, the largest distance of each rule's ends from the reference, and the CPU time
(``time.process_time``) of each rule's ends.

    .venv/bin/python benchmarks/bench_profile_boundary.py [--studies 40] [--seed 1]
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy import optimize

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from analysis.glmm import profile_cut, profile_upper  # noqa: E402
from analysis.glmm_slope import fit_glmm_slope  # noqa: E402
from analysis.glmm_slope_deviance import SD_BOUND  # noqa: E402
from analysis.glmm_slope_profile import (_sd_params, is_singular,  # noqa: E402
                                         lowest_deviance, profile_end)
from analysis.models import FORMULA  # noqa: E402
from bench_profile_restart import SCENARIOS, generate  # noqa: E402

SD_ENDS = ((0, 0), (0, 1), (1, 0), (1, 1))


def reference_end(data, z, theta, dev_min, n_agq, level, df, which, side, modes) -> float:
    """An SD's end on a profile minimised from five correlations at every point
    (``lowest_deviance``)."""
    cut = profile_cut(level, df)
    value_hat = _sd_params(theta[-3:])[which]

    def zeta(v):
        best = lowest_deviance(data, z, theta, n_agq, modes, which, v)
        return np.sqrt(max(best - dev_min, 0.0)) - np.sqrt(cut)

    with np.errstate(all="ignore"):
        if side == 0:
            if value_hat <= 1e-6 or zeta(0.0) <= 0:
                return 0.0
            return optimize.brentq(zeta, 0.0, value_hat, xtol=2e-5, rtol=1e-6)
        return profile_upper(zeta, value_hat, max(2 * value_hat, 0.5), SD_BOUND)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--studies", type=int, default=40, help="studies per scenario")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    for s, (name, kw) in enumerate(SCENARIOS.items()):
        fitted = singular = changed = 0
        far = {"new": 0.0, "old": 0.0}
        cpu = {"new": 0.0, "old": 0.0}
        cases = []
        start = time.monotonic()
        for i in range(args.studies):
            seed = args.seed * 100_000 + s * 1000 + i
            pieces = []
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fit = fit_glmm_slope(generate(seed=seed, **kw), FORMULA,
                                     submit=lambda f, *a: pieces.append(a) or None)
            if fit.formula is None or not pieces:
                continue
            fitted += 1
            data, z, theta, dev_min, n_agq, level, df, *_, modes = pieces[0]
            singular_fit = is_singular(theta)
            singular += int(singular_fit)
            ends = {}
            for rule, flag in (("new", True), ("old", False)):
                t = time.process_time()
                ends[rule] = [profile_end(data, z, theta, dev_min, n_agq, level, df, w, sd,
                                          modes, off_boundary=flag) for w, sd in SD_ENDS]
                cpu[rule] += time.process_time() - t
            for j, (w, sd) in enumerate(SD_ENDS):
                differs = abs(ends["new"][j] - ends["old"][j]) > 2e-5
                changed += int(differs)
                if differs or (singular_fit and sd == 1):
                    ref = reference_end(data, z, theta, dev_min, n_agq, level, df, w, sd, modes)
                    case = {"seed": seed, "singular": singular_fit, "end": [w, sd],
                            "new": float(ends["new"][j]),
                            "old": float(ends["old"][j]), "reference": float(ref)}
                    for rule in far:
                        far[rule] = max(far[rule], abs(ends[rule][j] - ref))
                    if differs or max(abs(ends["new"][j] - ref), abs(ends["old"][j] - ref)) > 1e-3:
                        cases.append(case)
            print(f"  {name}: {i + 1}/{args.studies}, {time.monotonic() - start:.0f} s",
                  file=sys.stderr, end="\r")
        print(json.dumps({"scenario": name, "studies": args.studies, "fitted": fitted,
                          "singular": singular, "ends_changed": changed,
                          "largest_distance_from_reference_new": float(far["new"]),
                          "largest_distance_from_reference_old": float(far["old"]),
                          "cases": cases, "cpu_s_new": round(cpu["new"], 2),
                          "cpu_s_old": round(cpu["old"], 2),
                          "machine": f"{platform.machine()}, Python {platform.python_version()}"}),
              flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
