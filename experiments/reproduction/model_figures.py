"""Figures 3, 4a, 4b, 5 and 6 of the paper, recomputed with every model method.

Each figure is written as ``figN.csv`` (long format, units in the headers) and
``figN.png`` with one panel per method: the paper's formulas as printed, the
corrected closed forms, and the exact solution, side by side.

Parameters the paper states: stainless steel (Table 1), skin 36 degC and steel
20 degC (Fig. 3), a smooth contact R = 0 for Fig. 3, Eq. 5 with the paper's
defaults for the rough samples (R_S = 21.69 um, 2 N on 135 mm^2). Choices we had
to make (the paper does not state them; nothing was tuned):

* Fig. 3 varies the epidermis thickness L - d at a fixed dermis d = 600 um
  (receptors 600 um above the core boundary).
* Figs. 4-6 use the same temperatures (36 / 20 degC) and a 650 um skin
  (the paper's group A mean) with dermis 0.6 L = 390 um.
* The material is a half-space (the paper's closed forms are half-space forms).
"""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from sessionfiles.atomicfile import output_file, output_path
from stimuli.paper import TABLE2_ROUGHNESS_UM

__all__ = ["FIGURES", "figure_rows", "write_figures", "METHODS", "ROUGHNESS_UM"]

METHODS = ("paper-as-printed", "paper", "exact")
ROUGHNESS_UM = TABLE2_ROUGHNESS_UM
FIG3_EPIDERMIS_UM = (100.0, 200.0, 300.0, 400.0, 500.0)
FIG3_DERMIS_UM = 600.0
SKIN_C, MATERIAL_C = 36.0, 20.0
SKIN_THICKNESS_UM = 650.0
TIMES_S = np.linspace(0.0, 20.0, 201)

#: Panel titles: what each method is, and what to expect of it (stimuli.paper_forms documents
#: every printed error; the printed e_SR has no n, so its sum over n warms the receptors above
#: T_S0 in Fig. 4a, and the printed Eq. 8 prefactor shrinks psi by beta_S / beta_M in Fig. 6).
METHOD_TITLES = {
    "paper-as-printed": "paper-as-printed\n(Eqs. 3a/7/8 as printed; see stimuli.paper_forms)",
    "paper": "paper\n(closed forms, printed errors corrected)",
    "exact": "exact\n(Laplace inversion, to 1e-12 in θ)",
}

FIGURES = {
    "fig3": ("Receptor temperature, epidermis thickness varied (SS, R = 0)", "epidermis_um", "receptor_C"),
    "fig4a": ("Receptor temperature, SS roughness varied", "roughness_um", "receptor_C"),
    "fig4b": ("Receptor temperature at 20 s vs SS roughness", None, "receptor_at_20s_C"),
    "fig5": ("Interface temperature (material side, Eq. 7's quantity)", "roughness_um", "interface_C"),
    "fig6": ("Relative recognizing profile psi (Eq. 8's quantity)", "roughness_um", "psi"),
}


def _contact(skin, roughness_um):
    from stimuli import Contact, contact_resistance, material
    steel = material("stainless_steel")
    R = 0.0 if roughness_um is None else contact_resistance(roughness_um * 1e-6, skin, steel)
    return Contact(skin, steel, R, SKIN_C, MATERIAL_C)


def figure_rows(name: str):
    """Header and rows (lists) of one figure's CSV."""
    from stimuli import Skin
    if name not in FIGURES:
        raise ValueError(f"figure_rows: name: expected one of {sorted(FIGURES)}, got {name!r}")
    _, param, quantity = FIGURES[name]
    rows = []
    if name == "fig4b":
        skin = Skin(SKIN_THICKNESS_UM * 1e-6)
        header = ["roughness_um", "R_m2K_per_W", "method", quantity]
        for ra in np.linspace(0.0, 100.0, 51):
            c = _contact(skin, ra)
            for m in METHODS:
                rows.append([ra, c.resistance, m, float(c.receptor_temperature([20.0], method=m)[0])])
        return header, rows
    header = ["time_s", param, "R_m2K_per_W", "method", quantity]
    if name == "fig3":
        series = [(ep, Skin((FIG3_DERMIS_UM + ep) * 1e-6, dermis=FIG3_DERMIS_UM * 1e-6), None)
                  for ep in FIG3_EPIDERMIS_UM]
    else:
        skin = Skin(SKIN_THICKNESS_UM * 1e-6)
        series = [(ra, skin, ra) for ra in ROUGHNESS_UM]
    for value, skin, ra in series:
        c = _contact(skin, ra)
        for m in METHODS:
            if quantity == "receptor_C":
                y = c.receptor_temperature(TIMES_S, method=m)
            elif quantity == "interface_C":
                y = c.interface_temperature(TIMES_S, method=m)
            else:
                y = c.recognizing_profile(TIMES_S, method=m)
            rows.extend([t, value, c.resistance, m, v] for t, v in zip(TIMES_S, y))
    return header, rows


def _write_csv(path: Path, header, rows):
    with output_file(path) as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for r in rows:
            w.writerow([f"{v:.10g}" if isinstance(v, float) else v for v in r])


def _plot(path: Path, name: str, header, rows):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    title, param, quantity = FIGURES[name]
    label = {"receptor_C": "receptor temperature (°C)", "receptor_at_20s_C": "receptor temperature at 20 s (°C)",
             "interface_C": "interface temperature (°C)", "psi": "ψ (–)"}[quantity]
    if name == "fig4b":
        fig, ax = plt.subplots(figsize=(5, 3.5))
        for m in METHODS:
            pts = [(r[0], r[3]) for r in rows if r[2] == m]
            ax.plot(*zip(*pts), marker=".", label=m)
        ax.set_xlabel("roughness Ra (µm)")
        ax.set_ylabel(label)
        ax.legend(fontsize=8)
    else:
        fig, axes = plt.subplots(1, len(METHODS), figsize=(13, 3.8), sharey=True)
        for ax, m in zip(axes, METHODS):
            for value in dict.fromkeys(r[1] for r in rows):
                pts = [(r[0], r[4]) for r in rows if r[3] == m and r[1] == value]
                ax.plot(*zip(*pts), label=f"{value:g} µm")
            ax.set_title(METHOD_TITLES[m], fontsize=9)
            ax.set_xlabel("time (s)")
        axes[0].set_ylabel(label)
        axes[-1].legend(title=param.replace("_um", " (µm)"), fontsize=8)
    fig.suptitle(f"{name}: {title}", fontsize=10)
    fig.tight_layout()
    with output_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


def write_figures(out_dir) -> list[Path]:
    """Write fig3, fig4a, fig4b, fig5, fig6 as PNG + CSV into ``out_dir``; return the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in FIGURES:
        header, rows = figure_rows(name)
        _write_csv(out / f"{name}.csv", header, rows)
        _plot(out / f"{name}.png", name, header, rows)
        paths += [out / f"{name}.csv", out / f"{name}.png"]
    return paths
