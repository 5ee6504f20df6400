"""Figure 9 (proportion correct per roughness number) and confusion-matrix heatmaps."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from sessionfiles.atomicfile import output_path
from stimuli.paper import SAMPLE_NAMES

__all__ = ["plot_figure9", "plot_confusion", "figure9", "confusion_figure", "figure9_panels",
           "plot_figure9_panels", "DODGE", "Y_LIMITS"]

#: Series of Figure 9: (group, mode) -> (label, colour, marker, line style).
SERIES = {
    ("A", "real"): ("Group A, real", "tab:red", "o", "-"),
    ("B", "real"): ("Group B, real", "tab:blue", "s", "-"),
    ("A", "simulated"): ("Group A, simulated", "tab:red", "^", "--"),
    ("B", "simulated"): ("Group B, simulated", "tab:blue", "D", "--"),
}
CHANCE = 0.25
#: Horizontal offsets of the four series (in roughness-number units): markers 0.12 apart, so
#: 6-point markers and 3-point caps at the figure's scale never overlap.
DODGE = dict(zip(SERIES, (-0.18, -0.06, 0.06, 0.18)))
#: y-axis limits: padded so that points (and error caps) at 0 and 1 are drawn whole.
Y_LIMITS = (-0.05, 1.05)


def agg_pyplot():
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    return plt


def plot_figure9(proportions: pd.DataFrame, path, *, interval: str = "boot",
                 title: str | None = None) -> Path:
    """Draw Figure 9: proportion correct against roughness number, four series.

    Parameters
    ----------
    proportions : pandas.DataFrame
        From :func:`analysis.cell_proportions`.
    path : str or Path
        PNG file to write.
    interval : {"boot", "wilson"}
        Which interval the error bars show (participant-cluster bootstrap or Wilson).
    title : str, optional
        Figure title.

    Returns
    -------
    Path
        The file written.
    """
    if interval not in ("boot", "wilson"):
        raise ValueError(f"plot_figure9: interval: expected 'boot' or 'wilson', got {interval!r}")
    fig = figure9(proportions, interval=interval, title=title)
    path = Path(path)
    _save(fig, path)
    _save(fig, path.with_suffix(".pdf"))           # vector copy beside the PNG
    agg_pyplot().close(fig)
    return path


def figure9(proportions: pd.DataFrame, *, interval: str = "boot", title: str | None = None):
    """Figure 9 as a matplotlib figure, laid out (:func:`plot_figure9` saves it)."""
    plt = agg_pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 5.4), dpi=150)
    offsets = DODGE
    for key, (label, colour, marker, style) in SERIES.items():
        sel = proportions[(proportions["group"] == key[0]) & (proportions["mode"] == key[1])]
        if sel.empty:
            continue
        sel = sel.sort_values("roughness_id")
        x = sel["roughness_id"].to_numpy(float) + offsets[key]
        y = sel["proportion_correct"].to_numpy(float)
        low, high = sel[f"{interval}_low"].to_numpy(float), sel[f"{interval}_high"].to_numpy(float)
        yerr = np.vstack([np.clip(y - low, 0, None), np.clip(high - y, 0, None)])
        ax.errorbar(x, y, yerr=yerr, label=label, color=colour, marker=marker, linestyle=style,
                    capsize=3, linewidth=1.4, markersize=6,
                    markerfacecolor=colour if key[1] == "real" else "white")
    ax.axhline(CHANCE, color="0.4", linestyle=":", linewidth=1, label="chance (0.25)")
    ticks = proportions.drop_duplicates("roughness_id").set_index("roughness_id")["roughness_um"]
    ax.set_xticks([1, 2, 3, 4], [f"{r}#\n{ticks[r]:g} µm" if r in ticks.index else f"{r}#"
                                 for r in (1, 2, 3, 4)])
    ax.set_xlim(0.5, 4.5)
    ax.set_ylim(*Y_LIMITS)
    ax.set_xlabel("Roughness Number (Ra)")
    ax.set_ylabel("Proportions of correct recognition")
    people = int(proportions["n_participants"].max()) if not proportions.empty else 0
    which = interval_caption(interval, int(proportions["n_participants"].min())
                             if not proportions.empty else 0)
    trials = int(proportions["n_trials"].max()) if not proportions.empty else 0
    ax.set_title(title or f"Figure 9: correct recognition\n95% {which} intervals; "
                          f"≤ {people} participants, ≤ {trials} trials per point", fontsize=9)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=3, frameon=False)
    fig.tight_layout()
    _layout_done(fig)
    return fig


def _layout_done(fig) -> None:
    """Keep the positions ``tight_layout`` set and drop the placeholder layout engine it leaves:
    with an engine, every ``savefig`` first draws the whole figure once more to lay it out (two
    draws per file); the placeholder's layout does nothing, so the files are the same."""
    fig.set_layout_engine("none")


def _save(fig, path: Path, **options) -> None:
    """``fig.savefig(path)``, whole or not at all (a temporary file renamed over ``path``)."""
    with output_path(path) as tmp:
        fig.savefig(tmp, **options)


def interval_caption(interval: str, min_participants: int) -> str:
    """What the error bars are, in words (the figure's caption).

    ``boot`` is a Wilson interval at the effective sample size a participant-cluster bootstrap
    implies (:func:`analysis.proportions.cluster_bootstrap`); with one participant in a cell
    there is nothing to resample, the design effect is 1 and the bars are plain Wilson
    intervals, trials treated as independent.
    """
    if interval == "wilson":
        return "Wilson, trials independent"
    if min_participants < 2:
        return "Wilson, trials independent (one participant: no participant bootstrap)"
    return "Wilson at the participant-bootstrap effective n"


def _draw_panel(ax, table: pd.DataFrame, value: str, low: str, high: str, title: str) -> None:
    """Four dodged series of ``table`` (group, mode, roughness_id, value, low, high) on ``ax``."""
    for key, (label, colour, marker, style) in SERIES.items():
        sel = table[(table["group"] == key[0]) & (table["mode"] == key[1])].sort_values("roughness_id")
        if sel.empty:
            continue
        x = sel["roughness_id"].to_numpy(float) + DODGE[key]
        y = sel[value].to_numpy(float)
        yerr = np.vstack([np.clip(y - sel[low].to_numpy(float), 0, None),
                          np.clip(sel[high].to_numpy(float) - y, 0, None)])
        ax.errorbar(x, y, yerr=yerr, label=label, color=colour, marker=marker, linestyle=style,
                    capsize=3, linewidth=1.4, markersize=6, gid=f"{key[0]}-{key[1]}",
                    markerfacecolor=colour if key[1] == "real" else "white")
    roughness_axes(ax, table, title)


def roughness_axes(ax, table: pd.DataFrame, title: str) -> None:
    """Figure 9's frame on ``ax``: chance line, the four samples (number and Ra in µm, from
    ``table``'s ``roughness_id``/``roughness_um``) on x, proportion 0–1 on y, ``title``."""
    ax.axhline(CHANCE, color="0.4", linestyle=":", linewidth=1, label="chance (0.25)")
    ticks = table.drop_duplicates("roughness_id").set_index("roughness_id")["roughness_um"]
    ax.set_xticks([1, 2, 3, 4], [f"{r}#\n{ticks[r]:g} µm" if r in ticks.index else f"{r}#"
                                 for r in (1, 2, 3, 4)])
    ax.set_xlim(0.5, 4.5)
    ax.set_ylim(*Y_LIMITS)
    ax.set_yticks(np.linspace(0, 1, 6))
    ax.grid(axis="y", color="0.9", linewidth=0.8)
    ax.set_xlabel("Roughness Number (Ra)")
    ax.set_title(title, fontsize=9)


def figure9_panels(predicted: pd.DataFrame, observed: pd.DataFrame, *, left_title: str,
                   right_title: str, interval: str = "boot", left_note: str = "",
                   right_note: str = ""):
    """The two-panel Figure 9: the paper's method as printed, beside the best-matching scenario.

    Parameters
    ----------
    predicted : pandas.DataFrame
        Left panel: columns group, mode, roughness_id, roughness_um, expected, study_low,
        study_high (expected proportion correct over many simulated studies and the 95 % range
        of a single study's; :class:`experiments.simulation.figure9.scenarios.ScenarioResult`).
    observed : pandas.DataFrame
        Right panel: :func:`analysis.cell_proportions` of the emulated sessions.
    left_title, right_title : str
    interval : {"boot", "wilson"}
        The right panel's interval.
    left_note, right_note : str
        Text under each panel (the claims each panel shows).

    Returns
    -------
    matplotlib.figure.Figure
        Axes 0 (left) and 1 (right); each series is an errorbar container whose line has the
        ``gid`` ``"<group>-<mode>"``.
    """
    plt = agg_pyplot()
    notes = bool(left_note or right_note)
    fig, axes = plt.subplots(1, 2, figsize=(11.5, 7.0 if notes else 5.4), dpi=150, sharey=True)
    _draw_panel(axes[0], predicted, "expected", "study_low", "study_high", left_title)
    _draw_panel(axes[1], observed, "proportion_correct", f"{interval}_low", f"{interval}_high",
                right_title)
    axes[0].set_ylabel("Proportions of correct recognition")
    handles, labels = axes[1].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=8, loc="lower center", ncol=5, frameon=False)
    if notes:
        fig.subplots_adjust(left=0.06, right=0.99, top=0.88, bottom=0.36, wspace=0.08)
        for ax, note in ((axes[0], left_note), (axes[1], right_note)):
            fig.text(ax.get_position().x0, 0.235, note, ha="left", va="top", fontsize=7.5,
                     family="DejaVu Sans Mono")
    else:
        fig.tight_layout(rect=(0, 0.06, 1, 1))
    _layout_done(fig)
    return fig


def plot_figure9_panels(predicted: pd.DataFrame, observed: pd.DataFrame, path, **titles) -> list:
    """Write :func:`figure9_panels` as ``path`` (PNG) and the same name ``.pdf``; return both."""
    plt = agg_pyplot()
    fig = figure9_panels(predicted, observed, **titles)
    path = Path(path)
    out = [path, path.with_suffix(".pdf")]
    for p in out:
        _save(fig, p)
    plt.close(fig)
    return out


def plot_confusion(confusion: pd.DataFrame, path) -> Path:
    """Heatmaps of the confusion matrices, one panel per group × mode.

    Parameters
    ----------
    confusion : pandas.DataFrame
        From :func:`analysis.confusion_matrices`.
    path : str or Path
        PNG file to write.

    Returns
    -------
    Path
        The file written. Colours are the share of a stimulus's trials given
        each response (rows sum to 1); numbers are trial counts.
    """
    fig = confusion_figure(confusion)
    path = Path(path)
    _save(fig, path)
    agg_pyplot().close(fig)
    return path


def confusion_figure(confusion: pd.DataFrame):
    """The confusion heatmaps as a matplotlib figure (:func:`plot_confusion` saves it)."""
    plt = agg_pyplot()
    panels = list(SERIES)
    fig, axes = plt.subplots(2, 2, figsize=(8, 7.2), dpi=120, squeeze=False)
    image = None
    for k, (ax, (group, mode)) in enumerate(zip(axes.ravel(), panels)):
        sel = confusion[(confusion["group"] == group) & (confusion["mode"] == mode)]
        ax.set_title(f"Group {group}, {mode}", fontsize=10)
        ax.set_xticks(range(4), SAMPLE_NAMES)
        ax.set_yticks(range(4), SAMPLE_NAMES)
        if k >= 2:
            ax.set_xlabel("response")
        if k % 2 == 0:
            ax.set_ylabel("stimulus")
        if sel.empty:
            ax.text(1.5, 1.5, "no trials", ha="center", va="center")
            ax.set_xlim(-0.5, 3.5)
            ax.set_ylim(3.5, -0.5)
            continue
        share = sel.pivot(index="stimulus_roughness_id", columns="response_id",
                          values="proportion_of_stimulus").to_numpy(float)
        counts = sel.pivot(index="stimulus_roughness_id", columns="response_id",
                           values="n_trials").to_numpy(int)
        image = ax.imshow(share, vmin=0, vmax=1, cmap="viridis")
        for i in range(4):
            for j in range(4):
                ax.text(j, i, str(counts[i, j]), ha="center", va="center", fontsize=9,
                        color="white" if (np.nan_to_num(share[i, j]) < 0.5) else "black")
    if image is not None:
        fig.colorbar(image, ax=axes.ravel().tolist(), shrink=0.8,
                     label="share of the stimulus's trials")
    return fig
