"""Fixtures for the display tests, and ``--display URL`` (default ``emulator://``).

As pyserial's own suite runs against ``loop://`` unless hardware is named, these tests run
against the in-process emulator unless ``--display`` names a device (a path or another URL);
tests that need the emulator's "sim" commands are skipped on a device without them. (pytest reads
this option when this folder is on the command line: ``pytest tests/experiments/hardware
--display /dev/ttyUSB0``.)
"""
from __future__ import annotations

import pytest

DEFAULT = "emulator://"


def pytest_addoption(parser):
    try:
        parser.addoption("--display", action="store", default=DEFAULT, metavar="URL",
                         help="pyserial URL of the thermal display for tests/experiments/hardware "
                              "(default emulator://)")
    except ValueError:       # already added by another conftest
        pass


@pytest.fixture
def display_url(request) -> str:
    """The display under test; the default emulator runs on a virtual clock for speed."""
    url = request.config.getoption("--display", default=DEFAULT)
    if url == DEFAULT:
        return "emulator://?clock=virtual&seed=20261122"
    return url


@pytest.fixture
def display(display_url):
    from experiments.hardware import open_display
    disp = open_display(display_url)
    yield disp
    disp.close()


@pytest.fixture
def sim_display(display):
    if "sim" not in display.info.capabilities:
        pytest.skip("needs the emulator's sim commands (capability 'sim')")
    return display
