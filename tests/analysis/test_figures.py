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


@pytest.mark.parametrize("how", ["fork", "no fork", "threads"])
def test_figures_drawn_in_a_worker_are_the_files_plot_writes(tmp_path, tables, monkeypatch, how):
    """``analyze`` has its figures drawn by a forked worker while the models fit
    (:class:`analysis.worker.AnalysisWorker`) and, without ``fork`` or while another thread
    runs (a fork would copy its locks), in the process at write time: either way the files
    are those ``plot_figure9`` / ``plot_confusion`` write (PNG to the byte; the PDF but for
    its creation date); nothing is written before ``write``."""
    import multiprocessing
    import re
    import threading
    from analysis import worker
    props, conf = tables
    if how == "no fork":
        monkeypatch.setattr(multiprocessing, "get_all_start_methods", lambda: ["spawn"])
    stop = threading.Event()
    if how == "threads":
        threading.Thread(target=stop.wait, daemon=True).start()
    # "fork": a worker unless an earlier test left a thread running
    fork = how == "fork" and threading.active_count() == 1
    plot_figure9(props, tmp_path / "figure9.png")
    plot_confusion(conf, tmp_path / "confusion.png")
    out = tmp_path / "out"
    out.mkdir()
    with worker.AnalysisWorker(props, conf) as job:
        assert (job._future is not None) == fork
        assert list(out.iterdir()) == []
        files = job.write(out)
    assert files == {"figure9": out / "figure9.png", "confusion_png": out / "confusion.png"}
    for name in ("figure9.png", "confusion.png"):
        assert (out / name).read_bytes() == (tmp_path / name).read_bytes()
    undated = [re.sub(rb"/CreationDate \(D:\d+Z\)", b"", (folder / "figure9.pdf").read_bytes())
               for folder in (out, tmp_path)]
    assert undated[0] == undated[1] and undated[0].startswith(b"%PDF")
    assert sorted(p.name for p in out.iterdir()) == ["confusion.png", "figure9.pdf", "figure9.png"]
    stop.set()


def _exit_in_child(parent_pid: int) -> int:
    import os
    if os.getpid() != parent_pid:
        os._exit(1)                 # the worker dies (as if killed)
    return 42


def test_a_dead_worker_costs_time_not_results(tmp_path, tables, monkeypatch):
    """If the worker process dies, what it was given is done in the process instead: the
    figures are still written and a submitted function still returns its value."""
    import os
    from analysis import worker
    from analysis.worker import AnalysisWorker
    props, conf = tables
    monkeypatch.setattr(worker, "can_fork", lambda: True)   # a worker even if a thread runs
    out = tmp_path / "out"
    out.mkdir()
    with AnalysisWorker(props, conf) as job:
        dead = job.submit(_exit_in_child, os.getpid())
        assert dead is not None and dead.result() == 42
        files = job.write(out)
    assert files["figure9"].stat().st_size > 20_000
    assert (out / "figure9.pdf").read_bytes().startswith(b"%PDF")
    assert files["confusion_png"].stat().st_size > 20_000


@pytest.mark.parametrize("fork", [True, False])
def test_a_worker_started_early_draws_what_it_is_given(tables, tmp_path, monkeypatch, fork):
    """``analyze`` starts the worker before loading (``warm_up``: a fork importing matplotlib),
    then gives it the figures (``draw``) and the profile intervals (``submit``): the files
    are those ``plot_figure9`` writes, with a worker and without one (drawn at write time);
    nothing is written before ``write``."""
    from analysis import worker
    monkeypatch.setattr(worker, "can_fork", lambda: fork)
    props, conf = tables
    out = tmp_path / "out"
    out.mkdir()
    with worker.AnalysisWorker() as job:
        job.warm_up()
        job.draw(props, conf)
        value = job.submit(divmod, 17, 5)
        assert (value.result() == (3, 2)) if fork else value is None
        assert list(out.iterdir()) == []
        files = job.write(out)
    assert files["figure9"].read_bytes() == plot_figure9(props, tmp_path / "f.png").read_bytes()


@pytest.mark.parametrize("fork", [True, False])
def test_a_worker_told_not_to_draw_figure9_writes_the_confusion_heatmap_only(tables, tmp_path,
                                                                               monkeypatch, fork):
    """``analyze(..., figure9=False)`` (``reproduce figure9``, which draws its own Figure 9 in
    its place): no figure9.png or .pdf, the same confusion.png."""
    from analysis import worker
    monkeypatch.setattr(worker, "can_fork", lambda: fork)
    props, conf = tables
    both, one = tmp_path / "both", tmp_path / "one"
    for out, figure9 in ((both, True), (one, False)):
        out.mkdir()
        with worker.AnalysisWorker() as job:
            job.draw(props, conf, figure9=figure9)
            files = job.write(out)
    assert sorted(p.name for p in one.iterdir()) == ["confusion.png"]
    assert set(files) == {"confusion_png"}
    assert (one / "confusion.png").read_bytes() == (both / "confusion.png").read_bytes()
    assert sorted(p.name for p in both.iterdir()) == ["confusion.png", "figure9.pdf", "figure9.png"]
