"""Figure 9's two panels: the plotted data read back from the Figure equal the tables."""
import itertools

import numpy as np
import pandas as pd
import pytest

from analysis.figures import DODGE, SERIES, figure9_panels, plot_figure9, plot_figure9_panels


def _tables():
    rng = np.random.default_rng(20261124)
    rows_p, rows_o = [], []
    for (g, mode), r in itertools.product([("A", "real"), ("B", "real"), ("A", "simulated"),
                                           ("B", "simulated")], range(1, 5)):
        v = [0.0, 1.0, 0.31, 0.77][r - 1] if mode == "simulated" else float(rng.random())
        rows_p.append({"group": g, "mode": mode, "roughness_id": r, "roughness_um": [1.6, 12.5, 50, 100][r - 1],
                       "expected": v, "study_low": max(0, v - 0.2), "study_high": min(1, v + 0.2)})
        w = float(rng.random())
        rows_o.append({"group": g, "mode": mode, "roughness_id": r, "roughness_um": [1.6, 12.5, 50, 100][r - 1],
                       "proportion_correct": w, "boot_low": max(0, w - 0.1), "boot_high": min(1, w + 0.1),
                       "wilson_low": max(0, w - 0.1), "wilson_high": min(1, w + 0.1),
                       "n_participants": 15, "n_trials": 45})
    return pd.DataFrame(rows_p), pd.DataFrame(rows_o)


def _plotted(ax):
    """label -> (x, y, y_low, y_high) read from the axis's errorbar containers."""
    out = {}
    for c in ax.containers:
        line, _caps, (bars,) = c.lines[0], c.lines[1], c.lines[2]
        segs = np.array([s for s in bars.get_segments()])
        out[c.get_label()] = (np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float),
                              segs[:, 0, 1], segs[:, 1, 1])
    return out


def test_plotted_points_are_the_tables():
    predicted, observed = _tables()
    fig = figure9_panels(predicted, observed, left_title="left", right_title="right")
    left, right = fig.axes[:2]
    for ax, table, value, lo, hi in ((left, predicted, "expected", "study_low", "study_high"),
                                     (right, observed, "proportion_correct", "boot_low", "boot_high")):
        got = _plotted(ax)
        assert len(got) == 4
        for key, (label, *_rest) in SERIES.items():
            want = table[(table.group == key[0]) & (table["mode"] == key[1])].sort_values("roughness_id")
            x, y, ylo, yhi = got[label]
            np.testing.assert_allclose(x, want.roughness_id + DODGE[key])
            np.testing.assert_allclose(y, want[value])
            np.testing.assert_allclose(ylo, want[lo])
            np.testing.assert_allclose(yhi, want[hi])
        # points at 0 and 1 are whole: the axis extends past both
        low, high = ax.get_ylim()
        assert low <= -0.04 and high >= 1.04
    import matplotlib.pyplot as plt
    plt.close(fig)


def test_dodge_keeps_series_apart():
    xs = sorted(DODGE.values())
    # at the figure's width a 6-pt marker spans < 0.06 roughness units: centres 0.12 apart
    assert min(np.diff(xs)) >= 0.12 and max(abs(x) for x in xs) < 0.25


def test_png_and_pdf_written(tmp_path):
    predicted, observed = _tables()
    png, pdf = plot_figure9_panels(predicted, observed, tmp_path / "figure9.png",
                                   left_title="Figure 9 as the paper's method predicts it",
                                   right_title="best match")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert pdf.read_bytes()[:5] == b"%PDF-"
    one = plot_figure9(observed, tmp_path / "single.png")
    assert one.with_suffix(".pdf").read_bytes()[:5] == b"%PDF-"


def test_claim_notes_under_the_panels():
    import matplotlib.pyplot as plt
    predicted, observed = _tables()
    fig = figure9_panels(predicted, observed, left_title="l", right_title="r",
                         left_note="✓ 1.00 rise", right_note="✗ rise")
    texts = [t.get_text() for t in fig.texts]
    assert "✓ 1.00 rise" in texts and "✗ rise" in texts
    for ax in fig.axes[:2]:            # under the axes, not over the data
        assert ax.get_position().y0 > 0.3
    plt.close(fig)
