"""A display URL parsed once by its backend (experiments.display.url, registry.parse_display_url)."""
from __future__ import annotations

import pytest

from experiments.display import DisplayURL, ThermalDisplay, backend_for, open_display, parse_display_url
from experiments.display.registry import UnknownScheme
from experiments.emulators.backends import EmulatorDisplay
from experiments.errors import UserInputError


def test_the_registry_returns_the_url_parsed_by_its_backend():
    url = parse_display_url("emulator://?clock=virtual&seed=3")
    assert isinstance(url, DisplayURL)
    assert url.backend is EmulatorDisplay and url.scheme == "emulator"
    assert url.text == str(url) == "emulator://?clock=virtual&seed=3"
    assert url.clock == "virtual" and url.option("seed") == "3" and url.option("nope") is None
    assert parse_display_url(url) is url                  # parsed once, passed on as it is
    path = parse_display_url("/dev/ttyUSB0")
    assert path.backend is ThermalDisplay and path.scheme == "serial" and path.options == ()
    assert path.clock is None


def test_an_unknown_scheme_says_what_would_open_without_cutting_its_message():
    with pytest.raises(UnknownScheme) as ei:
        parse_display_url("nosuch://x")
    assert ei.value.expected.startswith("a serial device path or one of ")
    assert "emulator://" in ei.value.expected and str(ei.value).endswith(ei.value.expected)
    with pytest.raises(UnknownScheme) as ei:
        parse_display_url("tcs2:/tmp/x")          # a scheme without its two slashes
    assert str(ei.value).endswith(ei.value.expected) and "tcs2://..." in ei.value.expected


def test_the_backend_refuses_a_bad_url_when_it_is_parsed():
    with pytest.raises(UserInputError, match="emulator"):
        parse_display_url("emulator://?no_such_option=1")


def test_a_parsed_url_is_opened_without_a_second_check(monkeypatch):
    calls = []
    backend = backend_for("emulator://")
    real = backend.check_url.__func__

    def counting(cls, url):
        calls.append(url)
        return real(cls, url)

    monkeypatch.setattr(backend, "check_url", classmethod(counting))
    url = parse_display_url("emulator://?clock=virtual")
    with open_display(url) as d:
        assert d.info is not None
    assert calls == ["emulator://?clock=virtual"]
