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
