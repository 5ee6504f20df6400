"""Report a calibration fit: residual-trace figure, parameter tables (CSV, Markdown), fit.json.

Files written into ``out``:

``residuals.png``
    Top: each trace (points) and the fitted model (line); bottom: the residuals.
``resistances.csv``
    One row per sample: ``sample, roughness_id, roughness_um, n_traces, R_m2K_W, R_low_m2K_W,
    R_high_m2K_W, R_eq5_m2K_W, rms_residual_C`` (``R_eq5`` is the paper's Eq. 5 for comparison).
``skin.csv``
    One row: ``skin_thickness_um`` with its interval, ``skin_temperature_C`` (the shared fitted
    value with its interval, else the mean of the per-trace fitted or given values),
    ``skin_temperature_fitted`` (none, shared, per-trace), ``residual_sd_C``, ``level``,
    ``interval_method``.
``parameters.md``
    Both tables, the set-up and the diagnostics in words.
``fit.json``
    Everything, SI, JSON-ready.
"""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np

from sessionfiles.atomicfile import output_file, output_path
from experiments.calibration.fit import CalibrationFit

__all__ = ["write_report", "fit_summary", "plot_residuals"]


def _eq5(roughness_um):
    if roughness_um is None or not math.isfinite(roughness_um):
        return float("nan")
    from stimuli import contact_resistance
    return float(contact_resistance(roughness_um * 1e-6))


def fit_summary(fit: CalibrationFit) -> dict:
    """JSON-ready summary of a fit (SI units; temperatures °C)."""
    prob = fit.problem
    res = fit.residuals()
    per_sample = []
    for p in fit.resistances():
        mask = np.concatenate([np.full(tr.n, tr.sample == p.sample) for tr in prob.traces])
        per_sample.append({
            "sample": p.sample, "roughness_id": p.roughness_id, "roughness_um": p.roughness_um,
            "n_traces": sum(tr.sample == p.sample for tr in prob.traces),
            "resistance_m2K_W": p.value, "low_m2K_W": p.low, "high_m2K_W": p.high,
            "eq5_m2K_W": _eq5(p.roughness_um),
            "rms_residual_C": float(np.sqrt(np.mean(res[mask] ** 2))),
        })
    L = fit.skin_thickness
    out = {
        "setup": {"description": prob.setup.describe(), "sensor": prob.setup.sensor.to_dict(),
                  "material": getattr(prob.setup.material, "name", ""),
                  "sample_thickness_m": prob.setup.sample_thickness,
                  "fit_skin_temperature": prob.skin_temperature_mode},
        "level": fit.level, "interval_method": fit.interval_method,
        "skin_thickness_m": {"value": L.value, "low": L.low, "high": L.high},
        "samples": per_sample,
        "residual_sd_C": fit.sigma_C,
        "traces": [{"source": tr.source, "sample": tr.sample, "n": tr.n, "duration_s": tr.duration_s,
                    "skin_temperature_C": tr.skin_temperature_C,
                    "material_temperature_C": tr.material_temperature_C, **tr.meta}
                   for tr in prob.traces],
        "diagnostics": fit.diagnostics, "warnings": list(fit.warnings),
    }
    if prob.skin_temperature_mode == "shared":
        T = fit.parameter("T_S0")
        out["skin_temperature_C"] = {"value": T.value, "low": T.low, "high": T.high}
    elif prob.skin_temperature_mode == "per-trace":
        for i, tr in enumerate(out["traces"]):
            T = fit.parameter(f"T_S0[{i + 1}]")
            tr["fitted_skin_temperature_C"] = {"value": T.value, "low": T.low, "high": T.high}
    return out


def plot_residuals(fit: CalibrationFit, path) -> Path:
    """Traces, fitted model and residuals (PNG)."""
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    prob = fit.problem
    pred = fit.predicted()
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 7), sharex=True,
                                   gridspec_kw={"height_ratios": [2, 1]})
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    i0 = 0
    labelled = set()
    for tr in prob.traces:
        i1 = i0 + tr.n
        c = colors[prob.samples.index(tr.sample) % len(colors)]
        lab = None if tr.sample in labelled else (
            f"{tr.roughness_um:g} µm" if tr.roughness_um is not None else tr.sample)
        labelled.add(tr.sample)
        ax1.plot(tr.time_s, tr.temperature_C, ".", ms=2, color=c, alpha=0.4)
        ax1.plot(tr.time_s, pred[i0:i1], "-", lw=1.2, color=c, label=lab)
        ax2.plot(tr.time_s, tr.temperature_C - pred[i0:i1], ".", ms=2, color=c, alpha=0.6)
        i0 = i1
    L = fit.skin_thickness
    ax1.set_ylabel("sensor temperature (°C)")
    ax1.set_title(f"Calibration fit: L = {L.value * 1e6:.0f} µm "
                  f"[{L.low * 1e6:.0f}, {L.high * 1e6:.0f}], residual SD {fit.sigma_C * 1e3:.1f} mK\n"
                  f"{prob.setup.describe()}", fontsize=8)
    ax1.legend(title="sample R_a", fontsize=7, loc="best")
    ax2.axhline(0.0, color="k", lw=0.6)
    ax2.set_xlabel("time since contact (s)")
    ax2.set_ylabel("data − model (°C)")
    fig.tight_layout()
    path = Path(path)
    with output_path(path) as tmp:
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
    return path


def _fmt(x, scale=1.0, digits=4):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return ""
    return f"{x * scale:.{digits}g}"


def _write_resistances(path: Path, summary: dict) -> None:
    """resistances.csv: each sample's fitted R with its interval, Eq. 5's R and the residual."""
    with output_file(path) as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["sample", "roughness_id", "roughness_um", "n_traces", "R_m2K_W", "R_low_m2K_W",
                    "R_high_m2K_W", "R_eq5_m2K_W", "rms_residual_C"])
        for s in summary["samples"]:
            w.writerow([s["sample"], "" if s["roughness_id"] is None else s["roughness_id"],
                        _fmt(s["roughness_um"], digits=6), s["n_traces"], _fmt(s["resistance_m2K_W"], digits=6),
                        _fmt(s["low_m2K_W"], digits=6), _fmt(s["high_m2K_W"], digits=6),
                        _fmt(s["eq5_m2K_W"], digits=6), _fmt(s["rms_residual_C"], digits=4)])


def _write_skin(path: Path, summary: dict) -> None:
    """skin.csv: the skin thickness and the initial skin temperature (fitted or given, mean)."""
    L = summary["skin_thickness_m"]
    T = summary.get("skin_temperature_C")
    mode = summary["setup"]["fit_skin_temperature"]
    if mode == "per-trace":
        ts0_mean = float(np.mean([t["fitted_skin_temperature_C"]["value"] for t in summary["traces"]]))
    else:
        ts0_mean = float(np.mean([t["skin_temperature_C"] for t in summary["traces"]]))
    with output_file(path) as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["skin_thickness_um", "skin_thickness_low_um", "skin_thickness_high_um",
                    "skin_temperature_C", "skin_temperature_low_C", "skin_temperature_high_C",
                    "skin_temperature_fitted", "residual_sd_C", "level", "interval_method"])
        w.writerow([_fmt(L["value"], 1e6, 6), _fmt(L["low"], 1e6, 6), _fmt(L["high"], 1e6, 6),
                    _fmt(T["value"] if T else ts0_mean, digits=6), _fmt(T["low"] if T else None, digits=6),
                    _fmt(T["high"] if T else None, digits=6), mode,
                    _fmt(summary["residual_sd_C"], digits=4), summary["level"], summary["interval_method"]])


def _parameter_lines(summary: dict, lvl: str) -> list:
    """parameters.md's head and its tables: the skin's parameters, then each sample's R."""
    L = summary["skin_thickness_m"]
    T = summary.get("skin_temperature_C")
    lines = [
        "# Calibration fit", "",
        f"Set-up: {summary['setup']['description']}.", "",
        f"Intervals: {lvl} {summary['interval_method']}"
        f"{' likelihood' if summary['interval_method'] == 'profile' else ' (parametric, percentile)'}; "
        f"residual SD {summary['residual_sd_C'] * 1e3:.2f} mK over "
        f"{summary['diagnostics']['n_observations']} samples in {len(summary['traces'])} traces.", "",
        f"| parameter | estimate | {lvl} interval |", "|---|---|---|",
        f"| skin thickness L (µm), the effective core depth | {_fmt(L['value'], 1e6)} | "
        f"{_fmt(L['low'], 1e6)} – {_fmt(L['high'], 1e6)} |",
    ]
    if T:
        lines.append(f"| initial skin temperature T_S0 (°C) | {_fmt(T['value'], digits=5)} | "
                     f"{_fmt(T['low'], digits=5)} – {_fmt(T['high'], digits=5)} |")
    for i, tr in enumerate(summary["traces"]):
        if "fitted_skin_temperature_C" in tr:
            Ti = tr["fitted_skin_temperature_C"]
            lines.append(f"| T_S0 of trace {i + 1} ({Path(tr['source']).name}, sample {tr['sample']}; "
                         f"given {tr['skin_temperature_C']:.2f}) (°C) | {_fmt(Ti['value'], digits=5)} | "
                         f"{_fmt(Ti['low'], digits=5)} – {_fmt(Ti['high'], digits=5)} |")
    lines += ["", f"| sample R_a (µm) | traces | R (m² K/W) | {lvl} interval (m² K/W) | Eq. 5 (m² K/W) | "
              "RMS residual (mK) |", "|---|---|---|---|---|---|"]
    for s in summary["samples"]:
        ra = _fmt(s["roughness_um"]) or s["sample"]
        lines.append(f"| {ra} | {s['n_traces']} | {_fmt(s['resistance_m2K_W'])} | {_fmt(s['low_m2K_W'])} – "
                     f"{_fmt(s['high_m2K_W'])} | {_fmt(s['eq5_m2K_W'])} | {s['rms_residual_C'] * 1e3:.2f} |")
    return lines


def write_report(fit: CalibrationFit, out, extra: dict | None = None) -> dict:
    """Write the report files into ``out`` (created); return the summary written to fit.json."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    summary = fit_summary(fit)
    if extra:
        summary.update(extra)
    _write_resistances(out / "resistances.csv", summary)
    _write_skin(out / "skin.csv", summary)
    lines = _parameter_lines(summary, f"{summary['level']:.0%}")
    d = summary["diagnostics"]
    lines += ["", "Checks passed: optimiser converged "
              f"({d['optimizer_message'].strip()}); no parameter at a bound; Jacobian rank "
              f"{d['jacobian_rank']} of {len(fit.parameters)}, condition number {d['condition_number']:.3g}; "
              "every profile closes within the bounds.",
              f"Residual lag-1 autocorrelation: {d['residual_lag1_autocorrelation']:.3f}."]
    lines += _correlation_lines(summary["diagnostics"])
    lines += _misspecification_lines(summary["diagnostics"])
    for wmsg in summary["warnings"]:
        lines.append(f"\n**Warning:** {wmsg}")
    lines += ["", "L is the *effective depth of the isothermal core* of the model (the depth at which the "
              "skin is held at T_S0), not an anatomical skin thickness: it absorbs the layers' "
              "properties and perfusion the model leaves out (docs/scene-physics.md)."]
    lines += ["", "R is the *effective* resistance between the sensor's side and the sample for this "
              "sensor placement; it is what simulated trials of this participant should use.", ""]
    with output_file(out / "parameters.md") as fh:
        fh.write("\n".join(lines))
    plot_residuals(fit, out / "residuals.png")
    with output_file(out / "fit.json") as fh:
        json.dump(summary, fh, indent=2, default=_json_default)
        fh.write("\n")
    return summary


def _correlation_lines(diag) -> list:
    """The estimates' correlation matrix as a Markdown table (in the fit's log coordinates)."""
    names, C = diag.get("correlation_parameters"), diag.get("correlation")
    if not names or not C:
        return []
    lines = ["", "Correlation of the estimates (log R, log L; T_S0 in °C): strongly correlated "
             "estimates are not separately determined by these traces.", "",
             "| | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for n, row in zip(names, C):
        lines.append(f"| {n} | " + " | ".join(f"{v:+.3f}" for v in row) + " |")
    return lines


def _misspecification_lines(diag) -> list:
    cases = diag.get("misspecification") or []
    if not cases:
        return []
    lines = ["", "Plausible misspecifications (first-order shift of each estimate; * = beyond its "
             "interval):", "", "| misspecification | size | " + " | ".join(cases[0]["shift"]) + " |",
             "|---|---|" + "---|" * len(cases[0]["shift"])]
    for c in cases:
        cells = []
        for n, v in c["shift"].items():
            txt = f"{v:+.2f} K" if n.startswith("T_S0") else f"{v:+.1%}"
            cells.append(txt + (" *" if n in c["beyond"] else ""))
        lines.append(f"| {c['name'].replace('_', ' ')} | {c['size']} | " + " | ".join(cells) + " |")
    return lines


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {o!r}")
