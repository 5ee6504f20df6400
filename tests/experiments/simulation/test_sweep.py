"""Sweep: the workers give their freed heap back between stages, and import no pandas or analysis."""
import sys

import pytest

MiB = 2 ** 20


def _rss_bytes() -> int:
    with open("/proc/self/status", encoding="ascii") as fh:
        return next(int(line.split()[1]) * 1024 for line in fh if line.startswith("VmRSS:"))


def _heap_churn(keep: list = []) -> int:      # noqa: B006 - one list per worker process on purpose
    """Allocate 48 MiB in 4 KiB blocks (glibc's heap, not Python's small-object arenas), keep
    only the last block (it pins the heap's top), free the rest; this process's RSS after."""
    blocks = [bytes(4096) for _ in range(48 * MiB // 4096)]
    keep.append(blocks[-1])
    del blocks
    return _rss_bytes()


@pytest.mark.slow   # starts a one-worker LocalCluster (~5 s)
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc and needs glibc")
def test_release_memory_gives_a_workers_freed_heap_back():
    from experiments.simulation.sweep import Sweep
    with Sweep(workers=1) as sweep:
        sweep.release_memory()                          # before the cluster: nothing to do
        assert sweep.client is None
        churned = sweep.map(_heap_churn, [(), ()])      # two tasks: on the worker
        before = sweep.client.run(_rss_bytes)
        # the worker's 64 MiB trim threshold (WORKER_MALLOC) keeps the freed 48 MiB mapped
        assert all(rss >= max(churned) - 8 * MiB for rss in before.values())
        sweep.release_memory()
        after = sweep.client.run(_rss_bytes)
    assert set(after) == set(before)
    for worker, rss in after.items():
        assert rss < before[worker] - 32 * MiB, (before[worker] / MiB, rss / MiB)


#: Modules a figure9 worker should not need.
HEAVY = ("pandas", "pyarrow", "analysis", "matplotlib", "statsmodels")


def _heavy_modules() -> list:
    """Of :data:`HEAVY`, those this process has imported."""
    return sorted(m for m in HEAVY if m in sys.modules)


def test_the_workers_task_module_imports_no_pandas_or_analysis():
    # a worker imports the module of each task it runs: reproduce figure9's tasks (and the
    # sessions' runner) must not pull in pandas, pyarrow or the analysis package
    import subprocess
    code = ("import sys; import experiments.simulation.figure9.tasks, "
            "experiments.simulation.figure9.study, experiments.simulation.sweep; "
            f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout + out.stderr


@pytest.mark.slow   # starts a one-worker LocalCluster (~5 s)
def test_studies_on_a_worker_give_the_claims_of_studies_here_without_analysis_there():
    # study_task runs on the worker (no analysis there); its claims are evaluated here as each
    # result arrives (Sweep.map's ``then``): the same readings, bit for bit, as evaluating the
    # same studies' counts in one process
    import numpy as np

    from analysis.claims import evaluate_readings
    from experiments.participant_model.observers import get_observer
    from experiments.simulation.figure9.scenarios import table2_replay_temperatures
    from experiments.simulation.figure9.tasks import claims_of_studies, study_task
    from experiments.simulation.studies import build_pool, simulate_studies
    from experiments.simulation.sweep import Sweep
    pool = build_pool(hypotheses=("slab",), dermis_fraction=(0.6, 0.6), seed=1)
    temps = table2_replay_temperatures("slab")
    tasks = [(pool, "slab", "absolute", 30, 15, 1, None, (1, 2, ci), temps, None)
             for ci in range(2)]
    with Sweep(workers=1) as sweep:
        done = sweep.map(study_task, tasks, what="simulated studies", then=claims_of_studies)
        there = sweep.client.run(_heavy_modules)
    assert list(there.values()) == [[]]
    for task, res in zip(tasks, done):
        out = simulate_studies(pool, "slab", get_observer("absolute"), n_studies=30, seed=task[7])
        here = evaluate_readings(out.correct, out.groups, out.repetitions, temps,
                                 answered=out.answers.sum(axis=-2))
        assert here.keys() == res["readings"].keys()
        for reading, verdicts in here.items():
            for cid, (stat, holds) in verdicts.items():
                np.testing.assert_array_equal(res["readings"][reading][cid][0], stat)
                np.testing.assert_array_equal(res["readings"][reading][cid][1], holds)
        assert res["proportions"].shape == (30, 2, 2, 4)


def _stamp(name: str, gate: str | None = None) -> tuple:
    """``(name, start)``, started once the file ``gate`` exists."""
    import os
    import time
    while gate is not None and not os.path.exists(gate):
        time.sleep(0.01)
    return name, time.monotonic()


def _stamp_study(name: str) -> tuple:
    """:func:`_stamp` as another function (dask groups the tasks of one function)."""
    return _stamp(name)


def _held(sweep, prefix: str, n: int) -> None:
    """Wait until the scheduler holds ``n`` tasks whose key starts with ``prefix``."""
    import time
    deadline = time.monotonic() + 60
    while sweep.client.run_on_scheduler(
            lambda dask_scheduler: sum(str(k).startswith(prefix + "-")
                                       for k in dask_scheduler.tasks)) < n:
        assert time.monotonic() < deadline, f"{n} {prefix} tasks not on the scheduler in 60 s"
        time.sleep(0.01)


@pytest.mark.slow   # starts a one-worker LocalCluster (~5 s)
def test_a_later_smaller_map_waits_for_the_queued_tasks_of_a_higher_priority(tmp_path):
    # reproduce figure9's sessions (priority SESSION_PRIORITY) against the studies and the
    # depth grid submitted beside them: with dask's default worker-saturation, a later group
    # of two tasks went straight to the worker and ran before the queued sessions. The
    # sessions wait for a gate opened once both maps are on the scheduler, so the one worker is
    # held by the first session until every task is there: the order does not depend on this
    # machine's speed.
    import threading

    from experiments.simulation.figure9.study import SESSION_PRIORITY
    from experiments.simulation.sweep import Sweep
    gate = tmp_path / "gate"
    with Sweep(workers=1) as sweep:
        sweep.scatter(0)                                          # the cluster started
        first, later = [], []
        sessions = threading.Thread(target=lambda: first.extend(sweep.map(
            _stamp, [(f"session {i}", str(gate)) for i in range(6)], priority=SESSION_PRIORITY)))
        sessions.start()
        _held(sweep, "_stamp", 6)
        studies = threading.Thread(target=lambda: later.extend(sweep.map(
            _stamp_study, [("study 0",), ("study 1",)])))
        studies.start()
        _held(sweep, "_stamp_study", 2)
        gate.touch()
        sessions.join()
        studies.join()
    order = [name for name, _ in sorted(first + later, key=lambda r: r[1])]
    assert sorted(order[-2:]) == ["study 0", "study 1"], order


def _thread_nices() -> list:
    """The nice value of every thread of this process (Linux: nice is per thread)."""
    import os
    return sorted(os.getpriority(os.PRIO_PROCESS, int(t))
                  for t in os.listdir(f"/proc/{os.getpid()}/task"))


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_lower_priority_lowers_every_thread_and_threads_started_later_inherit_it():
    import subprocess
    code = ("import os, threading, time\n"
            "from experiments.simulation.sweep import lower_priority\n"
            "stop = threading.Event()\n"
            "t = threading.Thread(target=stop.wait); t.start()\n"
            "base = os.getpriority(os.PRIO_PROCESS, 0)\n"
            "n = lower_priority(3)\n"
            "later = []\n"
            "u = threading.Thread(target=lambda: later.append(os.getpriority(os.PRIO_PROCESS, 0)))\n"
            "u.start(); u.join()\n"
            "tids = os.listdir(f'/proc/{os.getpid()}/task')\n"
            "print(base, n, sorted({os.getpriority(os.PRIO_PROCESS, int(i)) for i in tids}), later)\n"
            "stop.set(); t.join()\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    base, n, nices, later = out.stdout.split(" ", 3)
    want = min(19, int(base) + 3)
    assert int(n) == 2                                    # the main thread and the other one
    assert nices == f"[{want}]" and later.strip() == f"[{want}]", out.stdout


def _chores_ms(dask_worker=None, dask_scheduler=None) -> dict:
    """Period of each periodic callback of a dask server (a worker, the scheduler, a nanny), ms."""
    server = dask_worker if dask_worker is not None else dask_scheduler
    return {name: pc.callback_time for name, pc in server.periodic_callbacks.items()}


@pytest.mark.slow   # starts a one-worker LocalCluster (~5 s)
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_the_local_workers_run_below_this_process_and_at_a_quiet_pace():
    # this process's work on the results (claims, the emulated study's analysis) is what the
    # rest waits for: the workers yield the CPU to it (WORKER_NICE)
    import os

    from experiments.simulation.sweep import WORKER_NICE, Sweep
    here = os.getpriority(os.PRIO_PROCESS, 0)
    with Sweep(workers=1) as sweep:
        in_tasks = sweep.map(_thread_nices, [(), ()])      # two tasks: on the worker
        on_worker = sweep.client.run(_thread_nices)
        paces = [*sweep.client.run(_chores_ms).values(),
                 sweep.client.run_on_scheduler(_chores_ms),
                 *(_chores_ms(nanny) for nanny in sweep.cluster.workers.values())]
    # the servers' periodic chores at QUIET_CLUSTER's pace, on the worker, the scheduler and
    # the nanny (dask's defaults: a tick every 20 ms, the memory every 100 ms, the machine's
    # CPU and disks every 500 ms)
    for pace in paces:
        assert pace["tick"] == 1000 and pace["monitor"] == 2000, pace
        assert pace.get("memory_monitor", 1000) == 1000, pace
    assert "memory_monitor" in paces[0] and "memory_monitor" in paces[-1]
    want = min(19, here + WORKER_NICE)
    assert WORKER_NICE >= 1
    for nices in [*in_tasks, *on_worker.values()]:
        assert set(nices) == {want}, (here, nices)
    assert os.getpriority(os.PRIO_PROCESS, 0) == here    # this process is left as it was
