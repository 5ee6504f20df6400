"""Fixtures for the display tests: ``display`` and ``sim_display``.

As pyserial's own suite runs against ``loop://`` unless hardware is named, these tests run
against the in-process emulator unless ``--display URL`` names a device (a path or another URL);
tests that need the emulator's "sim" commands are skipped on a device without them. The option
and the ``display_url`` fixture are defined in the rootdir ``tests/conftest.py`` (pytest only
honours ``pytest_addoption`` there for whole-suite runs).
"""
from __future__ import annotations

import pytest


@pytest.fixture
def display(display_url):
    from experiments.display import open_display
    disp = open_display(display_url)
    yield disp
    disp.close()


@pytest.fixture
def sim_display(display):
    if "sim" not in display.info.capabilities:
        pytest.skip("needs the emulator's sim commands (capability 'sim')")
    return display


#: The device checks that take more than a few seconds on the default emulator: marked slow
#: there only; against a device named with --display every check runs (none is deselected).
SLOW_ON_THE_EMULATOR = ("check_tracking", "check_neutral", "check_step")


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    if config.getoption("--display") != "emulator://":
        return
    for item in items:
        if item.name.startswith("test_device_check[") and any(
                s in item.name for s in SLOW_ON_THE_EMULATOR):
            item.add_marker(pytest.mark.slow)
