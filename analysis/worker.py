"""A second process for the analysis's independent steps, run while the parent fits the models.

Figure 9 and the confusion heatmaps need only the proportions and the confusion counts, known
before any model is fitted; drawing them (matplotlib's import included) takes 1-2 s of CPU. A
forked worker draws them into memory while the parent fits the models, and the parent writes
the bytes when it writes its other outputs (each file whole: temporary file, then renamed; nothing
is written before :func:`analysis.analyze`'s ``before_write``). The same worker then computes the
random-slope model's profile intervals (six ends, :func:`analysis.glmm_slope_profile.profile_end`,
~1 s in all) while the parent goes on with the tests; the parent, once done, takes back the
ends the worker has not begun (:meth:`Job.steal`; each job has a slot in a small table shared
with the worker, :class:`Claims`, so that even the jobs already handed to its process can be
taken back) and computes them itself. Where ``fork``
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
import itertools
import multiprocessing
import pickle
import threading
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import pandas as pd

from sessionfiles.atomicfile import output_file

__all__ = ["AnalysisWorker", "Claims", "Job", "can_fork", "render_figures", "run_claimed",
           "run_pickled", "warm_up", "warm_up_workers"]


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


#: Whose each job given to a forked worker is, by slot: nobody's yet, the worker's, the caller's.
FREE, WORKER, CALLER = 0, 1, 2
_BOARDS: dict = {}          # a worker's :class:`Claims` by token, inherited by its forked process
_TOKENS = itertools.count()


class Claims:
    """Who runs each job given to a forked worker: a small table of slots shared with it (made
    before the fork, the worker's process inherits it).

    A process pool hands its process up to two jobs ahead of the one it runs, and a job handed
    over can no longer be cancelled, so the caller could not take back the last jobs even when
    the worker had not begun them. With a slot per job, whoever begins it first marks it theirs
    (:meth:`take`, under a lock); the other then leaves it: the worker returns at once, the
    caller waits for the worker's result.
    """

    def __init__(self, size: int = 64):
        ctx = multiprocessing.get_context("fork")
        self._lock = ctx.Lock()
        self._slots = ctx.RawArray("b", size)
        self._next = 0

    def new(self) -> int | None:
        """A fresh slot (None once all are used: that job is then not shared)."""
        if self._next >= len(self._slots):
            return None
        self._next += 1
        return self._next - 1

    def take(self, slot: int, who: int) -> bool:
        """Mark ``slot`` as ``who``'s (WORKER or CALLER) if nobody has it; whether it now is.
        A lock held for more than 10 s (its holder killed inside those few instructions)
        counts as taken: the caller then waits for the job, or runs it once the worker is
        found dead (:meth:`Job.result`)."""
        if not self._lock.acquire(timeout=10):
            return False
        try:
            if self._slots[slot] != FREE:
                return False
            self._slots[slot] = who
            return True
        finally:
            self._lock.release()


def run_claimed(token: int, slot: int, function, args: tuple):
    """In the forked worker: ``(True, function(*args))`` if the slot was still free, else
    ``(False, None)`` (the caller took the job)."""
    board = _BOARDS.get(token)
    if board is not None and not board.take(slot, WORKER):
        return False, None
    return True, function(*args)


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
        self._token: int | None = None      # this worker's Claims in _BOARDS (a forked worker)
        if self._own and can_fork():
            try:
                self._token = next(_TOKENS)
                _BOARDS[self._token] = Claims()   # before the pool forks its process
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
        board = _BOARDS.get(self._token) if self._pool is not None else None
        slot = board.new() if board is not None else None
        if slot is None:
            future = self._start(function, *args)
            return None if future is None else Job(future, function, args, anything=not self._own)
        future = self._start(run_claimed, self._token, slot, function, args)
        return None if future is None else Job(future, function, args,
                                               claim=lambda: board.take(slot, CALLER))

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
        _BOARDS.pop(self._token, None)

    def __enter__(self) -> "AnalysisWorker":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class Job:
    """A function given to the worker: :meth:`result` waits for it; if the worker died (killed,
    out of memory), the function is run here instead (the same result, later).  With
    ``anything`` (a caller's executor, whose failures have many names: a killed worker, a lost
    connection), any exception the future raises has the function run here (an error of the
    function itself is then raised again here). With ``claim`` (a job given as
    :func:`run_claimed` under a :class:`Claims` slot: ``claim()`` marks the slot the caller's and
    says whether it could), :meth:`steal` takes the job back until the worker begins it, even
    once handed to its process."""

    def __init__(self, future: Future, function, args: tuple, anything: bool = False,
                 claim=None):
        self._future, self._function, self._args = future, function, args
        self._anything, self._claim = anything, claim

    def steal(self):
        """The function run here, now, if the worker has not begun it (its slot taken, or else
        its future cancelled while still queued); None when it is under way or done there (then
        :meth:`result`), and always None on a caller's executor (whose cancel does not say
        whether a task ran)."""
        if self._claim is not None:
            if not self._claim():
                return None
            self._future.cancel()          # if still queued; else the worker returns at once
            return self._function(*self._args)
        if self._anything or not self._future.cancel():
            return None
        return self._function(*self._args)

    def result(self):
        try:
            value = self._future.result()
        except BrokenProcessPool:
            return self._function(*self._args)
        except Exception:       # noqa: BLE001  see the class's docstring
            if not self._anything:
                raise
            return self._function(*self._args)
        if self._claim is None:
            return value
        ran, value = value
        return value if ran else self._function(*self._args)   # taken here: run here
