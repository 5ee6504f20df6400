"""Benchmark of the calibration fit: time and accuracy against trace length and sensor noise.

Not a test.  Run:  .venv/bin/python benchmarks/bench_calibration.py [--repeats 10] [--out DIR]

Each configuration fits ``--repeats`` independent synthetic data sets: four samples (the
paper's 1#-4#, 1.6-100 µm, R from Eq. 5), one 800 µm skin, 35 °C skin on a 24 °C 3 mm steel
slab, a massless sensor on the sample surface, 20 Hz, white Gaussian noise of the stated SD
then 1 mK quantisation; 95 % profile-likelihood intervals.  Reported per configuration: the
median wall time of one fit (profiles included), the RMS relative error of L and of the four
R, how often the 95 % intervals covered the truth, and how many fits were refused.
"""
from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np


def machine() -> str:
    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    import scipy
    return (f"{platform.node()} | {cpu} | {os.cpu_count()} CPUs | load {os.getloadavg()[0]:.1f} | "
            f"Python {platform.python_version()} | numpy {np.__version__} | scipy {scipy.__version__}")


def run(durations=(5.0, 10.0, 25.0), noises=(0.005, 0.02, 0.1), repeats=10, rate=20.0, seed=20261122,
        fit_skin_temperature="none"):
    from stimuli import contact_resistance

    from experiments.calibration import CalibrationRefused, fit_traces, synthetic_traces

    ra = [1.6, 12.5, 50.0, 100.0]
    r_true = np.array([float(contact_resistance(r * 1e-6)) for r in ra])
    l_true = 800e-6
    rows = []
    for duration in durations:
        for noise in noises:
            times, err_l, err_r, cov_l, cov_r, refused = [], [], [], [], [], 0
            reasons = set()
            for k in range(repeats):
                rng = np.random.default_rng([seed, int(duration * 10), int(noise * 1e4), k])
                traces = synthetic_traces(r_true, l_true, roughness_um=ra, duration_s=duration,
                                          rate_Hz=rate, noise_C=noise, rng=rng)
                t0 = time.perf_counter()
                try:
                    fit = fit_traces(traces, fit_skin_temperature=fit_skin_temperature)
                except CalibrationRefused as exc:
                    refused += 1
                    reasons.update(r.split(":")[0] for r in exc.reasons)
                    times.append(time.perf_counter() - t0)
                    continue
                times.append(time.perf_counter() - t0)
                L = fit.skin_thickness
                err_l.append(L.value / l_true - 1)
                cov_l.append(L.low <= l_true <= L.high)
                for p, r in zip(fit.resistances(), r_true):
                    err_r.append(p.value / r - 1)
                    cov_r.append(p.low <= r <= p.high)
            rms = lambda e: float(np.sqrt(np.mean(np.square(e)))) if e else float("nan")   # noqa: E731
            rows.append({
                "duration_s": duration, "noise_C": noise, "n_points": int(duration * rate) * len(ra),
                "median_fit_s": float(np.median(times)), "rms_err_L_pct": 100 * rms(err_l),
                "rms_err_R_pct": 100 * rms(err_r),
                "cover_L": float(np.mean(cov_l)) if cov_l else float("nan"),
                "cover_R": float(np.mean(cov_r)) if cov_r else float("nan"),
                "refused": refused, "repeats": repeats, "reasons": "; ".join(sorted(reasons))})
    return rows


def table(rows) -> str:
    head = ("| trace s | noise °C | points | median fit s | RMS err L % | RMS err R % | "
            "95% cover L | 95% cover R | refused |")
    lines = [head, "|" + "---|" * 9]
    for r in rows:
        lines.append(f"| {r['duration_s']:g} | {r['noise_C']:g} | {r['n_points']} | {r['median_fit_s']:.2f} | "
                     f"{r['rms_err_L_pct']:.2f} | {r['rms_err_R_pct']:.2f} | {r['cover_L']:.2f} | "
                     f"{r['cover_R']:.2f} | {r['refused']}/{r['repeats']}"
                     + (f" ({r['reasons']})" if r["reasons"] else "") + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=10)
    ap.add_argument("--durations-s", type=float, nargs="+", default=[5.0, 10.0, 25.0])
    ap.add_argument("--noises-C", type=float, nargs="+", default=[0.005, 0.02, 0.1])
    ap.add_argument("--rate-Hz", type=float, default=20.0)
    ap.add_argument("--fit-skin-temperature", choices=("none", "shared", "per-trace"), default="none",
                    help="also fit T_S0 (the data are made with the given 35 °C)")
    ap.add_argument("--out", default=None, help="also write bench_calibration.md here")
    ns = ap.parse_args(argv)
    print(f"machine: {machine()}")
    print("method: least squares on the exact Laplace model (fixed Talbot, 20 nodes), 4 samples + L, "
          f"{ns.rate_Hz:g} Hz, 95 % profile-likelihood intervals, T_S0 fitted: {ns.fit_skin_temperature}, "
          f"{ns.repeats} data sets per row")
    rows = run(ns.durations_s, ns.noises_C, ns.repeats, ns.rate_Hz, fit_skin_temperature=ns.fit_skin_temperature)
    text = table(rows)
    print(text)
    if ns.out:
        out = Path(ns.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "bench_calibration.md").write_text(f"machine: {machine()}\n\n{text}\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
