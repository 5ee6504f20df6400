"""Figure 9 as distributions: what simulated 15 + 15 studies give, with one emulated study on top.

Each panel shows, per group x mode x sample, the median of the simulated studies' proportion
correct (marker), the range of the middle 50 % of studies (thick bar) and of 95 % (thin bar).
The right panel adds the headline scenario's one emulated study (its 30 sessions): each of the
four series (group A / B x real / simulated) with its own marker, drawn large and hollow with a
black edge, so that every series of the simulated studies and of the emulated study has its own
legend entry.  Under each panel, the probability that a study shows each claim in both readings
(descriptive / inferential) with the claim's status at this precision (✓ / ✗ / ?).  A third
panel shows the paper's own Figure 9 as far as it can be shown: the paper prints it as a bar
chart without numbers and its text gives none, so no bar is digitised; the panel lists the
paper's statements about it (:data:`analysis.claims.CLAIMS`) instead.
"""
from __future__ import annotations

from pathlib import Path

import pandas as pd

__all__ = ["plot_figure9_distribution", "figure9_distribution", "claims_note"]


def claims_note(probabilities: pd.DataFrame, scenario) -> str:
    """Lines 'P desc / P inf  claim' for ``scenario`` from a ScenarioResult's claims table."""
    from analysis.claims import CLAIMS
    sel = probabilities[(probabilities.hypothesis == scenario[0])
                        & (probabilities.observer == scenario[1])]
    table = sel.pivot_table(index="claim", columns="reading", values="probability")
    from .precision import MARK, claim_status
    lows = sel.pivot_table(index="claim", columns="reading", values="mc_low")
    highs = sel.pivot_table(index="claim", columns="reading", values="mc_high")

    def cell(cid, reading):
        mark = MARK[claim_status(lows.loc[cid, reading], highs.loc[cid, reading])]
        return f"{mark}{table.loc[cid, reading]:4.2f}"
    lines = ["P(a 15+15 study shows it): descriptive / inferential (✓ ✗ ?: interval vs 0.5)"]
    for c in CLAIMS:
        if c.id in table.index:
            lines.append(f"{cell(c.id, 'descriptive')} / {cell(c.id, 'inferential')}  "
                         f"{c.text}{' *' if c.own else ''}")
    if "all" in table.index:
        lines.append(f" {table.loc['all', 'descriptive']:4.2f} /  "
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
                        linestyle="none", marker=marker, markerfacecolor="none",
                        markeredgecolor="black", markersize=11, markeredgewidth=1.6,
                        gid=f"study-{key[0]}-{key[1]}", label=f"{label}: the emulated study")
    roughness_axes(ax, props, title)


def _paper_panel(ax):
    """The paper's Figure 9: no numbers printed, so its claims, in words."""
    import textwrap

    from analysis.claims import CLAIMS
    ax.set_axis_off()
    ax.set_title("The paper's Figure 9\n(printed as a bar chart without numbers;\nno bar can be "
                 "digitised: its claims instead)", fontsize=9)
    lines = []
    for c in CLAIMS:
        lines += textwrap.wrap(f"• {c.text}{' *' if c.own else ''}: {c.quote}", 46) + [""]
    lines.append("* the criterion is the project's reading")
    ax.text(0.0, 1.0, "\n".join(lines), va="top", ha="left", fontsize=6.5,
            transform=ax.transAxes, gid="paper-claims")


def plot_figure9_distribution(left: pd.DataFrame, right: pd.DataFrame, observed, path,
                              **titles) -> list:
    """Write :func:`figure9_distribution` as ``path`` (PNG) and ``.pdf``; return both paths."""
    from analysis.figures import agg_pyplot
    plt = agg_pyplot()
    fig = figure9_distribution(left, right, observed, **titles)
    path = Path(path)
    out = [path, path.with_suffix(".pdf")]
    for p in out:
        fig.savefig(p)
    plt.close(fig)
    return out


def figure9_distribution(left: pd.DataFrame, right: pd.DataFrame, observed, *, left_title: str,
                         right_title: str, left_note: str = "", right_note: str = ""):
    """The three-panel figure (a matplotlib Figure): the printed Eq. 7, the headline with its
    emulated study, the paper's Figure 9 as its claims.

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
    fig, axes = plt.subplots(1, 3, figsize=(17, 7.6), dpi=150,
                             gridspec_kw={"width_ratios": [1, 1, 0.8]})
    axes[1].sharey(axes[0])
    _panel(axes[0], left, left_title)
    _panel(axes[1], right, right_title, observed)
    _paper_panel(axes[2])
    axes[0].set_ylabel("Proportions of correct recognition")
    handles, labels = axes[1].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=8, loc="lower center", ncol=4, frameon=False)
    fig.subplots_adjust(left=0.045, right=0.99, top=0.84, bottom=0.38, wspace=0.08)
    for ax, note in ((axes[0], left_note), (axes[1], right_note)):
        fig.text(ax.get_position().x0, 0.27, note, ha="left", va="top", fontsize=7,
                 family="DejaVu Sans Mono")
    fig.text(0.5, 0.975, "small filled / white markers: median of simulated studies; thick bars: "
             "middle 50 %; thin bars: 95 %; large black outlines: the one emulated study",
             ha="center", fontsize=8)
    return fig
