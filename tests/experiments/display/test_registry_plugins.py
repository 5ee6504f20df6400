"""The registry refuses what it cannot trust: hostile plugins and hostile URLs.

Each plugin is a real module in a temporary site folder, registered as a real
``thermocue.displays`` entry point (a ``.dist-info`` with ``entry_points.txt`` on the path), and
``thermocue displays`` or the registry runs in a fresh interpreter that finds it as it would
find an installed package.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

from experiments.display.registry import (MAX_URL_SHOWN, PYSERIAL_SCHEMES, backend_for,
                                          open_display, register, scheme_of)
from experiments.display.thermocue.driver import ThermalDisplay
from experiments.errors import UserInputError

_NO_CAPS = '''
from experiments.display.base import Display


class NoCaps(Display, scheme="nocaps"):
    description = "a backend that states no capabilities"
'''
_RAISES = '''
from experiments.display.base import Display


class HalfDone(Display, scheme="halfdone"):
    description = "registered, then its module failed"

raise RuntimeError("boom from the plugin")
'''
_EXITS = '''
import sys
sys.exit(0)
'''
_PYSERIAL = '''
from experiments.display.base import Display


class Thief(Display, scheme="loop"):
    description = "claims pyserial's loop://"
'''


def _site(tmp_path, plugins: dict) -> str:
    """A site folder with each plugin's module and one dist-info naming them as entry points."""
    site = tmp_path / "site"
    site.mkdir()
    lines = ["[thermocue.displays]"]
    for name, source in plugins.items():
        (site / f"plugin_{name}.py").write_text(textwrap.dedent(source), encoding="utf-8")
        lines.append(f"{name} = plugin_{name}")
    dist = site / "hostile_plugins-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: hostile-plugins\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text("\n".join(lines) + "\n")
    return str(site)


def _run(site: str, *args: str, code: str | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([site] + sys.path))
    cmd = [sys.executable, "-c", code] if code else [sys.executable, "-m", "experiments", *args]
    return subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=120)


def test_hostile_plugins_are_listed_as_broken_and_the_others_still_work(tmp_path):
    site = _site(tmp_path, {"nocaps": _NO_CAPS, "raises": _RAISES, "exits": _EXITS,
                            "pyserial": _PYSERIAL})
    out = _run(site, "displays", "--json")
    assert out.returncode == 0, out.stderr[-2000:]
    rows = json.loads(out.stdout)
    by_scheme = {r["scheme"]: r for r in rows if r["scheme"]}
    plugins = {r["plugin"]: r for r in rows if r["scheme"] is None}
    # the built-in backends and the emulator's entry point still work
    assert {"serial", "emulator", "tcs2", "qemu-firmware"} <= set(by_scheme)
    assert by_scheme["emulator"]["capabilities"]["scripted_bench"] is True
    # a backend without declared_capabilities: listed, broken, named -- not fatal
    assert by_scheme["nocaps"]["broken"].startswith("plugin_nocaps.NoCaps: NotImplementedError")
    # a plugin whose import raises: refused by name, its half-made registration undone
    assert set(plugins) == {"raises", "exits", "pyserial"}
    assert "halfdone" not in by_scheme
    assert plugins["raises"]["broken"] == ("its import failed: RuntimeError: boom from the "
                                           "plugin")
    assert plugins["raises"]["module"] == "plugin_raises"
    # a plugin that exits is refused, and the listing goes on
    assert plugins["exits"]["broken"] == "its import called sys.exit(0); refused"
    # pyserial's schemes are reserved
    assert "reserved" in plugins["pyserial"]["broken"] and by_scheme.get("loop") is None
    # the warnings name each plugin
    for name in plugins:
        assert f"plugin {name!r} (plugin_{name}" in out.stderr
    text = _run(site, "displays")
    assert text.returncode == 0, text.stderr[-2000:]
    assert "plugin raises (plugin_raises)  (broken: its import failed" in text.stdout
    assert "nocaps  (broken: plugin_nocaps.NoCaps: NotImplementedError" in text.stdout
    assert "emulator  (available)" in text.stdout


def test_a_plugin_that_exits_does_not_end_the_program_that_opens_a_display(tmp_path):
    site = _site(tmp_path, {"exits": _EXITS})
    code = ("import warnings; warnings.simplefilter('ignore')\n"
            "from experiments.display import open_display\n"
            "with open_display('emulator://?clock=virtual') as d:\n"
            "    print('opened', d.info.device_id, d.status().state)\n")
    out = _run(site, code=code)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.startswith("opened ") and out.stdout.split()[-1] == "IDLE"


@pytest.mark.parametrize("scheme", PYSERIAL_SCHEMES)
def test_pyserial_schemes_are_reserved(scheme):
    with pytest.raises(ValueError, match="reserved"):
        register(scheme, ThermalDisplay)
    assert backend_for(f"{scheme}://x") is ThermalDisplay


_TAIL = "TAIL-OF-THE-URL"


@pytest.mark.parametrize("url", [
    "nosuch://" + "x" * 100_000 + _TAIL,                       # an unknown scheme
    "emulator://?" + "faults=" + "y" * 100_000 + _TAIL,        # a bad option of a known one
    "tcs2://emulator?zones=" + "9" * 100_000 + _TAIL,
    "qemu-firmware://?image=" + "/z" * 50_000 + "&colour=1" + _TAIL,
    "nosuch://" + "a\nb" * 50_000 + _TAIL,                     # newlines in it
])
def test_every_url_error_is_one_line_with_at_most_200_characters_of_the_url(url):
    with pytest.raises(UserInputError) as exc:
        open_display(url)
    text = str(exc.value)
    assert "\n" not in text and "\r" not in text
    assert _TAIL not in text and len(text) < 2 * MAX_URL_SHOWN + 400
    if url.startswith("nosuch"):               # the registry's own message: how long it was
        assert f"({len(url)} characters)" in text


def test_a_bad_hwgrep_pattern_is_one_clear_line_not_a_regex_error():
    with pytest.raises(UserInputError) as exc:
        open_display("hwgrep://[")
    assert type(exc.value) is UserInputError
    assert str(exc.value).startswith("display: hwgrep://: expected a regular expression for the "
                                     "port, got '['")
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize("url", ["tcs2:/tmp/x", "emulator:", "qemu-firmware:/x", "TCS2:COM3"])
def test_a_scheme_without_two_slashes_is_refused_not_read_as_a_path(url):
    with pytest.raises(UserInputError, match=r"expected \S+://\.\.\. \(a scheme is followed by two "
                                             r"slashes"):
        scheme_of(url)
    with pytest.raises(UserInputError):
        open_display(url)


def test_paths_and_ports_are_still_serial():
    for url in ("/dev/ttyUSB0", "COM3", "/dev/pts/7", "C:\\dev\\x", "./pty-link"):
        assert scheme_of(url) == "serial", url
