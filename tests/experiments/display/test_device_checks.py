"""The qualification checks (``thermocue check``) against the display under test.

By default the in-process emulator (virtual clock); ``./scripts/test --display /dev/ttyACM0
tests/experiments/display`` runs the same checks against a real device. A check the device
cannot run fails with its reason: nothing here is skipped. The known-weight test needs the
operator, whom a test run does not ask, so on a device without a scripted bench it fails
(run ``thermocue check`` for it).
"""
from __future__ import annotations

import pytest

from experiments.qualification.bench import Bench
from experiments.qualification.runner import CHECKS


@pytest.fixture(scope="module")
def bench(request, tmp_path_factory):
    from experiments.display import open_display
    url = request.config.getoption("--display")
    if url == "emulator://":
        url = "emulator://?clock=virtual&seed=20261122"
    d = open_display(url)
    yield Bench(d, url, tmp_path_factory.mktemp("check"))
    d.close()


@pytest.mark.parametrize("check", [fn for fn, _ in CHECKS], ids=lambda fn: fn.__name__)
def test_device_check(bench, check):
    res = check(bench)
    assert res.passed, f"{res.name}: {res.reason} (look at: {res.look_at}; measured: {res.measured})"
