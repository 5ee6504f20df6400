"""Figure 9 and the confusion heatmaps are written and show the data."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from analysis import cell_proportions, confusion_matrices, load_trials, plot_confusion, plot_figure9  # noqa: E402


@pytest.fixture
def tables(study):
    data, _ = study(n_per_group=5, sigma=0.3, seed=41)
    trials = load_trials(data).analysable
    return cell_proportions(trials, n_boot=200, seed=1), confusion_matrices(trials)


def test_figure9_written_and_non_empty(tmp_path, tables):
    props, _ = tables
    path = plot_figure9(props, tmp_path / "figure9.png")
    assert path.stat().st_size > 20_000
    image = mpimg.imread(path)
    assert image.shape[0] >= 750 and image.shape[1] >= 900      # 6.4 x 5.4 in at 150 dpi
    # coloured series drawn (red and blue pixels), not a blank canvas
    rgb = image[..., :3]
    red = (rgb[..., 0] > 0.7) & (rgb[..., 1] < 0.3) & (rgb[..., 2] < 0.3)
    blue = (rgb[..., 2] > 0.6) & (rgb[..., 0] < 0.3)
    assert red.sum() > 200 and blue.sum() > 200
    wilson = plot_figure9(props, tmp_path / "w.png", interval="wilson")
    assert not np.array_equal(mpimg.imread(wilson), image)
    with pytest.raises(ValueError, match="interval"):
        plot_figure9(props, tmp_path / "x.png", interval="sd")


def test_confusion_heatmaps_written(tmp_path, tables):
    _, conf = tables
    path = plot_confusion(conf, tmp_path / "confusion.png")
    assert path.stat().st_size > 20_000
    # a panel missing (no B simulated trials) is drawn as "no trials", not an error
    partial = conf[~((conf["group"] == "B") & (conf["mode"] == "simulated"))]
    assert plot_confusion(partial, tmp_path / "partial.png").stat().st_size > 20_000
