"""Figure 9 as distributions: what simulated 15 + 15 studies give, with one emulated study on top.

Each panel shows, per group x mode x sample, the median of the simulated studies' proportion
correct (marker), the range of the middle 50 % of studies (thick bar) and of 95 % (thin bar).
The right panel adds the headline scenario's one emulated study (its 30 sessions) as black
crosses; under each panel, the probability that a study shows each claim in both readings
(descriptive / inferential), not a tick for one seed.
"""
from __future__ import annotations

from pathlib import Path

import pandas as pd

__all__ = ["plot_figure9_distribution", "claims_note"]


def claims_note(probabilities: pd.DataFrame, scenario) -> str:
    """Lines 'P desc / P inf  claim' for ``scenario`` from a ScenarioResult's claims table."""
    from analysis.claims import CLAIMS
    sel = probabilities[(probabilities.hypothesis == scenario[0])
                        & (probabilities.observer == scenario[1])]
    table = sel.pivot_table(index="claim", columns="reading", values="probability")
    lines = ["P(a 15+15 study shows it): descriptive / inferential"]
    for c in CLAIMS:
        if c.id in table.index:
            d, i = table.loc[c.id, "descriptive"], table.loc[c.id, "inferential"]
            lines.append(f"{d:4.2f} / {i:4.2f}  {c.text}{' *' if c.own else ''}")
    if "all" in table.index:
        lines.append(f"{table.loc['all', 'descriptive']:4.2f} / "
                     f"{table.loc['all', 'inferential']:4.2f}  every claim in the same study")
    lines.append("* the project's own criterion")
    return "\n".join(lines)


def _panel(ax, props: pd.DataFrame, title: str, observed: pd.DataFrame | None = None):
    from analysis.figures import DODGE, SERIES, roughness_axes
    for key, (label, colour, marker, style) in SERIES.items():
        sel = props[(props["group"] == key[0]) & (props["mode"] == key[1])].sort_values("roughness_id")
        if sel.empty:
            continue
        x = sel["roughness_id"].to_numpy(float) + DODGE[key]
        ax.vlines(x, sel["study_low"], sel["study_high"], color=colour, linewidth=1.0)
        ax.vlines(x, sel["study_q25"], sel["study_q75"], color=colour, linewidth=4.5, alpha=0.55)
        ax.plot(x, sel["study_median"], color=colour, marker=marker, linestyle=style,
                linewidth=1.2, markersize=6, label=label, gid=f"{key[0]}-{key[1]}",
                markerfacecolor=colour if key[1] == "real" else "white")
        if observed is not None:
            obs = observed[(observed["group"] == key[0]) & (observed["mode"] == key[1])]
            obs = obs.sort_values("roughness_id")
            if not obs.empty:
                ax.plot(obs["roughness_id"].to_numpy(float) + DODGE[key], obs["proportion_correct"],
                        linestyle="none", marker="x", color="black", markersize=7,
                        markeredgewidth=1.6, gid=f"study-{key[0]}-{key[1]}",
                        label="the emulated study" if key == ("A", "real") else None)
    roughness_axes(ax, props, title)


def plot_figure9_distribution(left: pd.DataFrame, right: pd.DataFrame, observed, path, *,
                              left_title: str, right_title: str, left_note: str = "",
                              right_note: str = "") -> list:
    """Write the two-panel figure as ``path`` (PNG) and ``.pdf``; return both paths.

    Parameters
    ----------
    left, right : pandas.DataFrame
        Rows of :attr:`ScenarioResult.proportions` for one scenario each (columns group, mode,
        roughness_id, roughness_um, study_low, study_q25, study_median, study_q75, study_high).
    observed : pandas.DataFrame or None
        :func:`analysis.cell_proportions` of the emulated study (right panel, on top).
    """
    from analysis.figures import agg_pyplot
    plt = agg_pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(12, 7.6), dpi=150, sharey=True)
    _panel(axes[0], left, left_title)
    _panel(axes[1], right, right_title, observed)
    axes[0].set_ylabel("Proportions of correct recognition")
    handles, labels = axes[1].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=8, loc="lower center", ncol=6, frameon=False)
    fig.subplots_adjust(left=0.06, right=0.99, top=0.84, bottom=0.38, wspace=0.08)
    for ax, note in ((axes[0], left_note), (axes[1], right_note)):
        fig.text(ax.get_position().x0, 0.27, note, ha="left", va="top", fontsize=7,
                 family="DejaVu Sans Mono")
    fig.text(0.5, 0.975, "markers: median of simulated studies; thick bars: middle 50 %; thin "
             "bars: 95 %", ha="center", fontsize=8)
    path = Path(path)
    out = [path, path.with_suffix(".pdf")]
    for p in out:
        fig.savefig(p)
    plt.close(fig)
    return out
