"""Sweep.release_memory: the workers give their freed heap back between stages."""
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
