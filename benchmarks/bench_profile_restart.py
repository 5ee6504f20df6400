"""The random-slope model's profile intervals under the two restart rules of
``analysis.glmm_slope_profile`` (``RESTARTS``): the intervals each gives, and the CPU each takes.

Not a test. Datasets from ``tests/analysis/generator.py`` (independent of the code under test):
``--studies`` studies per scenario, each fitted once (``fit_glmm_slope``, the analysis's model
``correct ~ group * mode * C(roughness_id)`` with ``(1 + mode | participant)``), then its six
profile ends computed from the fit's conditional modes under ``"far-side"`` (the default: a point
is optimised again from the estimate only when its warm start came from outside the interval
and landed above the cut-off) and under ``"always"`` (again whenever it landed above the
cut-off). Prints one JSON line per scenario: the largest difference between the two rules' ends,
how many ends differ by more than Brent's tolerance (2e-5 on the SD scale; 1e-4 on the
correlation's angle) and which (``beyond``: the study's seed, the end as ``(which, side)``, each
rule's value), and the CPU time (``time.process_time``) of each rule's ends.

    .venv/bin/python benchmarks/bench_profile_restart.py [--studies 40] [--seed 1]
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

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "analysis"))

from analysis.glmm_slope import fit_glmm_slope  # noqa: E402
from analysis.glmm_slope_profile import PROFILE_ENDS, RESTARTS, profile_end  # noqa: E402
from analysis.models import FORMULA  # noqa: E402
from generator import effect_cells, generate, null_cells  # noqa: E402

#: name: generator arguments
SCENARIOS = {
    "balanced 15+15, slope SD 1.0": dict(cells=effect_cells(), n_a=15, n_b=15, slope_sd=1.0),
    "balanced 15+15, no slope": dict(cells=null_cells(), n_a=15, n_b=15, slope_sd=0.0),
    "20+8, slope SD 0.5": dict(cells=effect_cells(), n_a=20, n_b=8, slope_sd=0.5),
    "8+8, slope SD 1.5, intercept SD 0.3": dict(cells=null_cells(), n_a=8, n_b=8, slope_sd=1.5,
                                                sigma=0.3),
}


def ends_of(trials) -> tuple[dict, dict] | None:
    """Per rule the six ends and their CPU seconds; None if the model was not fitted."""
    pieces = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_glmm_slope(trials, FORMULA, submit=lambda f, *a: pieces.append(a) or None)
    if fit.formula is None or not pieces:
        return None
    data, z, theta, dev_min, n_agq, level, df, *_, modes = pieces[0]
    ends, cpu = {}, {}
    for rule in RESTARTS:
        t = time.process_time()
        ends[rule] = np.array([profile_end(data, z, theta, dev_min, n_agq, level, df, which,
                                           side, modes, restart=rule)
                               for which, side in PROFILE_ENDS])
        cpu[rule] = time.process_time() - t
    return ends, cpu


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--studies", type=int, default=40, help="studies per scenario")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    tolerance = np.array([2e-5, 2e-5, 2e-5, 2e-5, 1e-4, 1e-4])     # Brent's xtol per end
    for s, (name, kw) in enumerate(SCENARIOS.items()):
        worst, beyond, fitted, cases = 0.0, 0, 0, []
        cpu = {rule: 0.0 for rule in RESTARTS}
        start = time.monotonic()
        for i in range(args.studies):
            seed = args.seed * 100_000 + s * 1000 + i
            got = ends_of(generate(seed=seed, **kw))
            if got is None:
                continue
            fitted += 1
            ends, spent = got
            a, b = ends["far-side"], ends["always"]
            both_inf = np.isinf(a) & np.isinf(b) & (np.sign(a) == np.sign(b))
            diff = np.where(both_inf, 0.0, np.abs(a - b))
            worst = max(worst, float(np.nanmax(diff)))
            beyond += int(np.sum(diff > tolerance))
            cases += [{"seed": seed, "end": list(PROFILE_ENDS[j]), "far_side": float(a[j]),
                       "always": float(b[j])} for j in np.flatnonzero(diff > tolerance)]
            for rule in RESTARTS:
                cpu[rule] += spent[rule]
            print(f"  {name}: {i + 1}/{args.studies}, {time.monotonic() - start:.0f} s",
                  file=sys.stderr, end="\r")
        print(json.dumps({"scenario": name, "studies": args.studies, "fitted": fitted,
                          "largest_difference": worst, "ends_beyond_tolerance": beyond,
                          "beyond": cases,
                          "cpu_s_far_side": round(cpu["far-side"], 2),
                          "cpu_s_always": round(cpu["always"], 2),
                          "machine": f"{platform.machine()}, Python {platform.python_version()}"}),
              flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
