"""The power curve drawn: power against participants per group, with Monte Carlo intervals.

Kept apart from :mod:`analysis.power` so that computing a curve never needs matplotlib.
"""

from __future__ import annotations

from pathlib import Path

from sessionfiles.atomicfile import output_path

from .power import PowerResult

__all__ = ["plot_power"]


def plot_power(result: PowerResult, path) -> Path:
    """Plot power against participants per group, with Monte Carlo intervals.

    Parameters
    ----------
    result : PowerResult
    path : str or Path
        PNG file to write.

    Returns
    -------
    Path
    """
    from .figures import agg_pyplot
    plt = agg_pyplot()
    t = result.table
    fig, ax = plt.subplots(figsize=(5.6, 4.2), dpi=150)
    curves = ([(f"A - B {e:+g} points", t[t["effect_pp"] == e]) for e in t["effect_pp"].unique()]
              if "effect_pp" in t else [(f"{result.settings['test']} test", t)])
    for label, c in curves:
        ax.errorbar(c["n_per_group"], c["power"],
                    yerr=[c["power"] - c["power_low"], c["power_high"] - c["power"]],
                    marker="o", capsize=3, label=label)
    ax.axhline(0.8, color="0.5", linestyle="--", linewidth=1, label="80 %")
    ax.axhline(result.settings["alpha"], color="0.5", linestyle=":", linewidth=1, label="alpha")
    ax.set_ylim(0, 1)
    ax.set_xlabel("participants per group")
    ax.set_ylabel("power (share of cohorts detecting A ≠ B)")
    s = result.settings
    what = ("stated effects (A−B, percentage points)" if "effect_pp" in t else
             f"expected A−B {t['expected_difference_A_minus_B'].iloc[0]:+.3f}")
    ax.set_title(f"Group difference, {s['mode']} mode: {what}, SD(u) {s['participant_sd']:.2f}",
                 fontsize=9)
    ax.legend(fontsize=8, frameon=False)
    fig.tight_layout()
    path = Path(path)
    with output_path(path) as tmp:
        fig.savefig(tmp)
    plt.close(fig)
    return path
