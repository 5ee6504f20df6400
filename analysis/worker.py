"""A second process for the analysis's independent steps, run while the parent fits the models.

Figure 9 and the confusion heatmaps need only the proportions and the confusion counts, known
before any model is fitted; drawing them (matplotlib's import included) takes 1-2 s of CPU. A
forked worker draws them into memory while the parent fits the models, and the parent writes
the bytes when it writes its other outputs (each file whole: temporary file, then renamed; nothing
is written before :func:`analysis.analyze`'s ``before_write``). The same worker then computes the
random-slope model's profile intervals (six ends, :func:`analysis.glmm_slope_profile.profile_end`,
~2 s in all) while the parent goes on with the tests; the parent, once done, takes back the
ends the worker has not started (:meth:`Job.steal`) and computes them itself. Where ``fork``
is not available or not safe (:func:`can_fork`), or the worker cannot start, everything is
done in the parent: the same files and numbers.

A caller that already runs workers (a dask cluster, whose threads rule out a fork) can give
them instead (``executor``: anything with ``submit(function, *args)`` returning
a future with ``result()``, such as a ``dask.distributed.Client``); the steps then run there,
the figures and the profile intervals side by side on two of its workers (the same bytes and
numbers). A step whose worker fails (killed, lost) is done in the parent. Each worker that
runs a step keeps the analysis's libraries (~190 MiB) until its cluster closes, which is why
``reproduce figure9`` does not give its own (its study's 1 GB budget).

The worker is started before the sessions are loaded (:meth:`AnalysisWorker.warm_up`): it imports
matplotlib and pyplot (~0.5 s of CPU) while the parent reads the logs, so the drawing itself is
all that is left when the proportions are known. (The worker's share, drawing plus profile
intervals, is already the longer of the two after the load: other independent steps, such as
the ordinal table, stay in the parent.)
"""
from __future__ import annotations

import io
import multiprocessing
import pickle
import threading
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import pandas as pd

from sessionfiles.atomicfile import output_file

__all__ = ["AnalysisWorker", "Job", "can_fork", "render_figures", "run_pickled", "warm_up",
           "warm_up_workers"]


def render_figures(proportions: pd.DataFrame, confusion: pd.DataFrame,
                   figure9: bool = True) -> dict[str, bytes]:
    """``figure9.png``, ``figure9.pdf`` (unless not ``figure9``) and ``confusion.png`` as bytes,
    by file name (what :func:`analysis.figures.plot_figure9` and
    :func:`analysis.figures.plot_confusion` write)."""
    from .figures import agg_pyplot, confusion_figure
    from .figures import figure9 as figure9_of
    plt = agg_pyplot()
    out = {}
    drawn = [(lambda: figure9_of(proportions), ("figure9.png", "figure9.pdf"))] if figure9 else []
    drawn.append((lambda: confusion_figure(confusion), ("confusion.png",)))
    for make, names in drawn:
        fig = make()
        for name in names:
            buf = io.BytesIO()
            fig.savefig(buf, format=Path(name).suffix[1:])
            out[name] = buf.getvalue()
        plt.close(fig)
    return out


def warm_up() -> None:
    """Import what :func:`render_figures` needs (matplotlib, pyplot with the Agg backend)."""
    from .figures import agg_pyplot
    agg_pyplot()


def run_pickled(blob: bytes):
    """``function(*args)`` of ``blob = pickle.dumps((function, args))``: what a caller's executor
    is given, so that the arguments arrive as the forked worker's do (pickled: the same
    memory layout, hence the same sums to the last bit; a dask client serialises arrays its
    own way, which moved the profile intervals' last digits)."""
    function, args = pickle.loads(blob)
    return function(*args)


def warm_up_workers(task: int) -> int:
    """On a caller's worker: import what :func:`render_figures` and the profile intervals
    need (the analysis package, matplotlib with pyplot); ``task`` only tells the two calls
    apart (a dask client would merge two identical tasks into one)."""
    from .glmm_slope_profile import profile_end  # noqa: F401
    warm_up()
    return task


def can_fork() -> bool:
    """Whether a worker is forked: ``fork`` exists, this process is not a daemonic one (which
    may have no children), and it runs no other thread (a fork copies a lock another thread
    holds, locked for ever in the child: with a GUI or a finished dask cluster's threads
    around, everything is done in this process instead)."""
    return ("fork" in multiprocessing.get_all_start_methods()
            and not multiprocessing.current_process().daemon
            and threading.active_count() == 1)


class AnalysisWorker:
    """A forked worker (when possible) for the analysis's independent steps: the figures
    (:meth:`draw`, or given to the constructor) and more through :meth:`submit`; a
    context manager that stops the worker on exit.

    Examples
    --------
    ``with AnalysisWorker(proportions, confusion) as worker: ...; files = worker.write(out)``

    ``with AnalysisWorker() as worker: worker.warm_up(); ...; worker.draw(p, c); ...``

    ``with AnalysisWorker(executor=client) as worker: ...`` (a running ``dask.distributed``
    client: its workers instead of a fork)
    """

    def __init__(self, proportions: pd.DataFrame | None = None,
                 confusion: pd.DataFrame | None = None, executor=None):
        self._args: tuple | None = None
        self._pool = executor      # a ProcessPoolExecutor of one forked worker, or the caller's
        self._own = executor is None
        self._warming: list = []   # the executor's warm-up tasks (kept until close)
        self._future: Future | None = None
        if self._own and can_fork():
            try:
                self._pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("fork"))
            except (OSError, AssertionError):   # no process to spare: drawn at write time
                self.close()
        if proportions is not None:
            self.draw(proportions, confusion)

    def warm_up(self) -> None:
        """Start the worker now, importing matplotlib (:func:`warm_up`) while this process
        goes on (a fork of this process as it is now: call it before anything large is
        loaded). With the caller's ``executor``, two tasks that import what the steps need
        (:func:`warm_up_workers`), one for each of the two workers the steps will likely run on
        (which ones is the executor's choice)."""
        if self._own:
            self._start(warm_up)
        else:
            self._warming = [self._start(warm_up_workers, task) for task in range(2)]

    def draw(self, proportions: pd.DataFrame, confusion: pd.DataFrame,
             figure9: bool = True) -> None:
        """Have :func:`render_figures` drawn now (in the worker) for :meth:`write`."""
        self._args = (proportions, confusion, bool(figure9))
        self._future = self._start(render_figures, *self._args)

    def _start(self, function, *args) -> Future | None:
        if self._pool is None:
            return None
        try:
            if not self._own:
                return self._pool.submit(run_pickled, pickle.dumps((function, args)))
            return self._pool.submit(function, *args)
        except (OSError, AssertionError, BrokenProcessPool):  # no worker: done in this process
            self.close()
            return None
        except Exception:       # noqa: BLE001  the caller's executor refused (closed, ...)
            if self._own:
                raise
            self.close()
            return None

    def submit(self, function, *args) -> "Job | None":
        """``function(*args)`` in the worker, after what it was given before; None without a
        worker (the caller then calls it itself)."""
        future = self._start(function, *args)
        return None if future is None else Job(future, function, args, anything=not self._own)

    def write(self, out: Path) -> dict[str, Path]:
        """Write the figures into ``out``: ``{"figure9": png, "confusion_png": png}`` (the PDF
        beside ``figure9.png``, as :func:`analysis.figures.plot_figure9`; no ``figure9`` when
        :meth:`draw` was told not to draw it)."""
        files = (Job(self._future, render_figures, self._args, anything=not self._own).result()
                 if self._future is not None else render_figures(*self._args))
        for name, data in files.items():
            with output_file(Path(out) / name, "wb") as fh:
                fh.write(data)
        written = {"figure9": Path(out) / "figure9.png", "confusion_png": Path(out) / "confusion.png"}
        return {k: v for k, v in written.items() if v.name in files}

    def close(self) -> None:
        """Stop the worker (waiting for a drawing under way); the caller's ``executor`` is
        left running (what it was given and not waited for is dropped)."""
        if self._pool is not None:
            if self._own:
                self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
            self._future = None
            self._warming = []

    def __enter__(self) -> "AnalysisWorker":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class Job:
    """A function given to the worker: :meth:`result` waits for it; if the worker died (killed,
    out of memory), the function is run here instead (the same result, later).  With
    ``anything`` (a caller's executor, whose failures have many names: a killed worker, a lost
    connection), any exception the future raises has the function run here (an error of the
    function itself is then raised again here)."""

    def __init__(self, future: Future, function, args: tuple, anything: bool = False):
        self._future, self._function, self._args = future, function, args
        self._anything = anything

    def steal(self):
        """The function run here, now, if the worker has not started it (its future cancelled
        while still queued); None when it is under way or done there (then :meth:`result`), and
        always None on a caller's executor (whose cancel does not say whether a task ran)."""
        if self._anything or not self._future.cancel():
            return None
        return self._function(*self._args)

    def result(self):
        try:
            return self._future.result()
        except BrokenProcessPool:
            return self._function(*self._args)
        except Exception:       # noqa: BLE001  see the class's docstring
            if not self._anything:
                raise
            return self._function(*self._args)
