"""``analyze(..., executor=...)``: the independent steps on the caller's workers (a dask cluster's
in ``reproduce figure9``), the files those of the analysis done in one process."""
from __future__ import annotations

import re
from concurrent.futures import Future

import pytest

from _study_writer import paper_like_cells, write_study
from analysis import analyze

#: Files whose bytes may differ between two runs into two folders: settings.json names the
#: output folder; the PDF carries its creation date.
_NAMED_OR_DATED = {"settings.json", "figure9.pdf"}


def _same_outputs(a, b) -> None:
    names = sorted(p.name for p in a.iterdir())
    assert names == sorted(p.name for p in b.iterdir())
    assert {"figure9.png", "confusion.png", "glmm_slope.csv", "report.md"} <= set(names)
    for name in set(names) - _NAMED_OR_DATED:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    undated = [re.sub(rb"/CreationDate \(D:\d+Z\)", b"", (d / "figure9.pdf").read_bytes())
               for d in (a, b)]
    assert undated[0] == undated[1]
    settings = [(d / "settings.json").read_text().replace(str(d), "OUT") for d in (a, b)]
    assert settings[0] == settings[1]


@pytest.fixture(scope="module")
def here(tmp_path_factory):
    """``(data, out)``: a study and its analysis done wholly in this process."""
    from analysis import worker
    folder = tmp_path_factory.mktemp("executor")
    write_study(folder / "data", paper_like_cells())
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(worker, "can_fork", lambda: False)    # no fork: everything in this process
        analyze(folder / "data", folder / "here", n_boot=200)
    return folder / "data", folder / "here"


@pytest.mark.slow   # a two-worker LocalCluster and an analysis (~8 s on a quiet machine)
def test_analysis_on_dask_workers_writes_the_files_of_the_analysis_in_one_process(
        here, tmp_path):
    import logging

    from distributed import Client, LocalCluster
    data, _ = here
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        analyze(data, tmp_path / "there", n_boot=200, executor=client)
        done = client.run_on_scheduler(lambda dask_scheduler: {
            name: dict(p.state_counts) for name, p in dask_scheduler.task_prefixes.items()})
    # the figures and the six ends of the profile intervals were computed there (with the two
    # warm-up tasks: nine, each run at most once; the warm-ups may be dropped unfinished)
    assert 7 <= done["run_pickled"]["memory"] <= 9, done    # (counts of the tasks' transitions)
    assert done["run_pickled"].get("erred", 0) == 0, done
    _same_outputs(here[1], tmp_path / "there")


class _LostWorkers:
    """An executor whose every task is lost (as a killed dask worker's), counting them."""

    def __init__(self):
        self.submitted = []

    def submit(self, function, *args):
        import pickle
        self.submitted.append(pickle.loads(args[0])[0].__name__)
        future = Future()
        future.set_exception(RuntimeError("worker lost"))
        return future


@pytest.mark.slow   # two analyses (~7 s on a quiet machine)
def test_steps_lost_on_the_callers_workers_are_done_here(here, tmp_path, monkeypatch):
    # a failed task costs time, not results: the figures and profile intervals are computed in
    # this process, the same files as without an executor; no fork is made beside the executor
    from analysis import worker
    data, _ = here
    lost = _LostWorkers()
    monkeypatch.setattr(worker, "can_fork", lambda: pytest.fail("a fork beside the executor"))
    analyze(data, tmp_path / "there", n_boot=200, executor=lost)
    assert sorted(lost.submitted) == ["profile_end"] * 6 + ["render_figures", "warm_up_workers",
                                      "warm_up_workers"]
    _same_outputs(here[1], tmp_path / "there")
