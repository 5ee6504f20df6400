"""Sweeps of simulated studies on ``dask.distributed``: a LocalCluster, or a scheduler's address.

The claims table, the sensitivity table, the study's sessions and ``thermocue power``'s simulated
cohorts (:func:`analysis.power.cohort_task`) are many independent tasks.
:class:`Sweep` submits them to a ``dask.distributed`` cluster: by default a ``LocalCluster`` of
worker processes on this machine (one thread each: the tasks are NumPy-bound and small), or the
cluster whose scheduler listens at ``scheduler`` (``reproduce figure9 --scheduler
tcp://host:8786``; its workers need this package importable).  :meth:`Sweep.map` returns the
results in the order of the tasks, whatever order they finish in, and logs progress with the
time remaining. The local cluster starts at the first map of two tasks or more (or the first
scatter): a map of one task runs in this process, with the same result.

Results do not depend on the number of workers: a task's random numbers come from its own seed
(a tuple naming the sweep's seed and the task), never from which worker ran it or when, and
tasks are cut into fixed chunks of studies (:data:`STUDIES_PER_TASK`), not into one chunk per
worker.
"""
from __future__ import annotations

import logging
import math
import os
import time

__all__ = ["Sweep", "STUDIES_PER_TASK", "chunks", "default_workers", "WORKER_MALLOC", "trim_heap",
           "release_process_memory", "WORKER_NICE", "lower_priority", "QUIET_CLUSTER"]

log = logging.getLogger("thermocue.study")

#: Simulated studies per task: fixed, so that the tasks (hence their seeds and results) are the
#: same for any number of workers.
STUDIES_PER_TASK = 100


#: glibc malloc settings of the LocalCluster's worker processes (set before each starts).
#: dask's default trims the heap back to the OS above 64 KiB, and glibc maps every array over
#: 128 KiB afresh: a simulated study's arrays (a few MiB) were then mapped, faulted in page by
#: page and unmapped on every use, which doubled a study's CPU time (a third of it in the kernel).
#: Arrays up to 16 MiB now come from the heap, which keeps up to 64 MiB free per worker.
#: Only where memory comes from changes, never a number.
WORKER_MALLOC = {"MALLOC_MMAP_THRESHOLD_": 16 * 2**20, "MALLOC_TRIM_THRESHOLD_": 64 * 2**20}


#: dask settings of the LocalCluster whose defaults serve a dashboard or a long-lived cluster, not
#: a sweep of a minute: each server (the scheduler and the two nannies in this process, each
#: worker) measured its event loop's lag every 20 ms (``admin.tick``: it only logs a loop
#: blocked for over 3 s), each nanny read its worker's memory from /proc every 100 ms (the
#: limit it enforces, now checked every second) and each server sampled the machine's CPU,
#: memory and disks every 0.5 s for the dashboard's plots.  An idle 2-worker cluster took 6 %
#: of a core in this process and 2 % in each worker (1.2 + 0.46 + 0.42 s of CPU in 20 s), 0.37 s
#: in all with these.  Only when the chores run changes, never a task or a result.
QUIET_CLUSTER = {"distributed.admin.tick.interval": "1s",
                 "distributed.worker.memory.monitor-interval": "1s",
                 "distributed.admin.system-monitor.interval": "2s"}


#: How far below this process the LocalCluster's workers run (a nice increment; Linux's CFS
#: then gives a busy worker about a third of the CPU share of a busy process at 0).  This process
#: works on the workers' results as they arrive (a batch's claims, the emulated study's analysis
#: while the workers simulate the sensitivity rows), and that work is what everything after it
#: waits for: on a machine with fewer cores than busy processes it goes first.  Only the order
#: in which the CPU serves the processes changes, never a result.
WORKER_NICE = 5


def lower_priority(increment: int = WORKER_NICE) -> int:
    """Lower this process's CPU priority by ``increment`` (at most to 19), every thread of it
    (Linux's nice is per thread; threads started later inherit their creator's).  Returns the
    number of threads changed (0 where the system has no ``/proc``)."""
    pid = os.getpid()
    try:
        tids = [int(t) for t in os.listdir(f"/proc/{pid}/task")]
    except OSError:
        tids = []
    changed = 0
    for tid in tids:
        try:
            now = os.getpriority(os.PRIO_PROCESS, tid)
            os.setpriority(os.PRIO_PROCESS, tid, min(19, now + int(increment)))
            changed += 1
        except OSError:                      # a thread that has ended since the listing
            pass
    return changed


def chunks(n_studies: int, size: int = STUDIES_PER_TASK) -> list[int]:
    """Study counts of the tasks that make ``n_studies``: ``size`` each, the rest last."""
    full, rest = divmod(int(n_studies), int(size))
    return [size] * full + ([rest] if rest else [])


def default_workers() -> int:
    """Worker processes of the default LocalCluster: the CPU count, at most 4 (memory)."""
    return max(1, min(4, os.cpu_count() or 1))


class Sweep:
    """A ``dask.distributed`` client for one sweep (a context manager).

    Parameters
    ----------
    workers : int, optional
        Worker processes of the LocalCluster (default :func:`default_workers`); ignored with
        ``scheduler``.
    scheduler : str, optional
        Address of a running scheduler (``tcp://host:port``): no local cluster is started.
    label : str
        Names the sweep in progress lines.
    """

    def __init__(self, workers: int | None = None, scheduler: str | None = None,
                 label: str = "sweep"):
        self.workers = int(workers) if workers is not None else default_workers()
        self.scheduler = scheduler
        self.label = label
        self.cluster = None
        self.client = None

    def __enter__(self) -> "Sweep":
        if self.scheduler:                   # a given address is checked at once
            self._connect()
        return self

    def _connect(self):
        """The client: the scheduler at ``scheduler``, or a LocalCluster started now."""
        if self.client is not None:
            return self.client
        from distributed import Client, LocalCluster
        if self.scheduler:
            try:
                self.client = Client(self.scheduler, timeout="10s")
            except (OSError, TimeoutError) as exc:
                from experiments.errors import UserInputError
                raise UserInputError(f"--scheduler: expected a reachable dask scheduler, got "
                                     f"{self.scheduler!r} ({exc})") from None
        else:
            import dask
            # a nanny takes a variable from this process's environment over the config, and
            # writes its own values there before it spawns: after a cluster started here with
            # dask's defaults (MALLOC_TRIM_THRESHOLD_=65536), the config alone was ignored
            os.environ.update({k: str(v) for k, v in WORKER_MALLOC.items()})
            # worker-saturation inf: every task goes to a worker when submitted, where the
            # highest priority runs first (:meth:`map`'s ``priority``); with dask's default
            # (1.1) a large group waits in the scheduler's queue and a later, smaller group
            # goes straight to a worker ahead of it, whatever the priorities
            # worker profile off: dask's statistical profiler (every 10 ms, on each worker's
            # event loop, the running task's stack taken and tallied, for a dashboard this
            # cluster does not serve) cost 12 % of an emulated session's CPU (median 1.33
            # against 1.17 s, benchmarks/bench_dask_profiler.py); the same tasks and results
            # the servers' periodic chores at a pace this cluster needs (QUIET_CLUSTER)
            with dask.config.set({**{f"distributed.nanny.pre-spawn-environ.{k}": v
                                     for k, v in WORKER_MALLOC.items()},
                                  "distributed.scheduler.worker-saturation": math.inf,
                                  "distributed.worker.profile.enabled": False,
                                  **QUIET_CLUSTER}):
                self.cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1,
                                            processes=True, dashboard_address=":0",
                                            silence_logs=logging.ERROR)
            self.client = Client(self.cluster)
            self.client.run(lower_priority, WORKER_NICE)    # this process's work goes first
        return self.client

    def __exit__(self, *exc) -> None:
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()

    @property
    def n_workers(self) -> int:
        """Workers the scheduler knows now (0 while every map so far ran in this process)."""
        if self.client is None:
            return 0
        return len(self.client.scheduler_info().get("workers", {}))

    def release_memory(self) -> None:
        """Have every worker collect its garbage and give its free heap back to the OS.

        A worker keeps up to 64 MiB of freed heap (:data:`WORKER_MALLOC`) and whatever the
        stage's tasks left fragmented; between stages that is memory nobody uses.  Nothing
        runs on the workers then, so no result changes; the next task faults in the pages it
        needs again.  No-op before the cluster starts, or where glibc's ``malloc_trim`` is
        missing.
        """
        if self.client is None:
            return
        self.client.run(release_process_memory)

    def scatter(self, value):
        """``value`` sent once to every worker (a future to pass to tasks)."""
        return self._connect().scatter(value, broadcast=True)

    def map(self, fn, tasks, what: str = "tasks", weights=None, then=None,
            priority: int = 0) -> list:
        """``[fn(*task) for task in tasks]`` on the cluster, in the order of ``tasks``.

        Parameters
        ----------
        fn : callable
            Importable by the workers (a module-level function).
        tasks : sequence of tuples
            Positional arguments of each call.
        what : str
            Names the unit in progress lines.
        weights : sequence of int, optional
            Units per task (e.g. studies) for the progress lines; default one per task.
        then : callable, optional
            Applied in this process to each result as it arrives (``then(fn(*task))`` is
            returned), while the workers compute the others: work that needs modules the
            workers should not import.
        priority : int
            dask's task priority: a worker runs its waiting task of the highest first (default
            0; among equals, dask's order). Only the order of the work on the cluster changes,
            never a result.
        """
        tasks = list(tasks)
        weights = list(weights) if weights is not None else [1] * len(tasks)
        total = sum(weights)
        if len(tasks) <= 1 and self.client is None:
            # one task gains nothing from a cluster: run it here (its seed is its own, so the
            # result is the one a worker would return), and start no cluster for it
            start = time.perf_counter()
            out = [fn(*task) for task in tasks]
            if then is not None:
                out = [then(r) for r in out]
            log.info("%s: %d of %d %s; elapsed %5.1f s, remaining %5.1f s (in this process)",
                     self.label, total, total, what, time.perf_counter() - start, 0.0)
            return out
        from distributed import as_completed
        futures = [self._connect().submit(fn, *task, pure=False, priority=priority)
                   for task in tasks]
        index = {f.key: i for i, f in enumerate(futures)}
        out = [None] * len(tasks)
        start = time.perf_counter()
        done, last = 0, start
        for future in as_completed(futures):
            i = index[future.key]
            out[i] = future.result() if then is None else then(future.result())
            done += weights[i]
            now = time.perf_counter()
            if now - last >= 2.0 or done == total:
                elapsed = now - start
                remaining = elapsed / done * (total - done) if done else float("nan")
                log.info("%s: %d of %d %s; elapsed %5.1f s, remaining %5.1f s", self.label,
                         done, total, what, elapsed, remaining)
                last = now
        return out


def release_process_memory() -> None:
    """Collect garbage, then :func:`trim_heap`, in this process."""
    import gc
    gc.collect()
    trim_heap()


def trim_heap() -> None:
    """Give this process's free heap pages back to the OS (glibc's ``malloc_trim(0)``; a
    no-op elsewhere).  Only where memory comes from changes, never a number."""
    import ctypes
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):      # not glibc: nothing to give back this way
        pass
