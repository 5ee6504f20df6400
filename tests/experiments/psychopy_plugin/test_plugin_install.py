"""``pip install thermocue[gui]`` ships the plugin: the wheel's metadata and files.

The wheel is built from this checkout (``pip wheel --no-deps``: only the build backend is fetched)
and inspected: PsychoPy's entry point groups, the ``gui`` extra that brings PsychoPy, and the
component's icons. PsychoPy finds plugins by these entry points alone (``scanPlugins``).
"""
from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow
REPO = Path(__file__).resolve().parents[3]


def test_the_wheel_carries_entry_points_extra_and_icons(tmp_path):
    out = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps",
                          "-w", str(tmp_path), str(REPO)], capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    (wheel,) = tmp_path.glob("thermocue-*.whl")
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        dist = next(n.split("/")[0] for n in names if n.endswith(".dist-info/METADATA"))
        eps = z.read(f"{dist}/entry_points.txt").decode()
        meta = z.read(f"{dist}/METADATA").decode()
    assert "[psychopy.hardware]\nThermalCueDevice = experiments.psychopy_plugin.device:ThermalCueDevice" in eps
    assert ("[psychopy.experiment.components]\n"
            "ThermalCueComponent = experiments.psychopy_plugin.component:ThermalCueComponent") in eps
    assert 'Requires-Dist: psychopy==2026.2.5; extra == "gui"' in meta
    for module in ("device", "cue", "clock_sync", "profiles", "compile", "component/__init__"):
        assert f"experiments/psychopy_plugin/{module}.py" in names
    for theme in ("light", "dark", "classic"):
        assert f"experiments/psychopy_plugin/component/{theme}/thermal_cue.png" in names
