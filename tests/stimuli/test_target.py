"""target_profile: sampling, quantisation, error bound, content hash and the on-disk cache."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from stimuli.contact import Contact
from stimuli.errors import ModelInputError
from stimuli.materials import material
from stimuli.properties import Skin
from stimuli.roughness import contact_resistance
from stimuli.target import TargetProfile, target_profile

ARGS = dict(material="stainless_steel", roughness=12.5e-6, skin=Skin(650e-6), skin_temperature=35.5,
            material_temperature=20.0, duration=5.0, rate=100.0, resolution=0.01)


def test_rate_duration_and_quantisation(tmp_path):
    p = target_profile(**ARGS, cache_dir=tmp_path)
    assert isinstance(p, TargetProfile)
    assert p.times.size == 501 and p.times[0] == 0.0 and p.times[-1] == 5.0
    assert np.allclose(np.diff(p.times), 0.01, rtol=0, atol=1e-12)
    counts = p.temperature / 0.01
    assert np.max(np.abs(counts - np.round(counts))) < 1e-6          # multiples of the resolution
    # the exact interface temperature, computed here independently of target_profile
    steel = material("stainless_steel")
    R = contact_resistance(12.5e-6, skin=ARGS["skin"], material=steel)
    exact = Contact(ARGS["skin"], steel, resistance=R, skin_temperature=35.5,
                    material_temperature=20.0).interface_temperature(p.times, side="material")
    err = np.max(np.abs(p.temperature - exact))
    assert err <= 0.005 + 1e-9                                         # rounding only
    assert p.method == "exact" and err <= p.error_bound <= 0.005 + 1e-9
    assert p.parameters["resistance_m2K_per_W"] == pytest.approx(float(R), rel=1e-15)
    assert p.parameters["rate_Hz"] == 100.0 and p.parameters["skin"]["thickness_m"] == 650e-6


def test_coarser_display_resolution():
    p = target_profile(**{**ARGS, "resolution": 0.1}, cache=False)
    q = target_profile(**ARGS, cache=False)
    assert np.max(np.abs(p.temperature - q.temperature)) <= 0.05 + 0.005 + 1e-9
    assert len(np.unique(p.temperature)) < len(np.unique(q.temperature))


def test_error_bound_of_an_approximate_method_is_measured(tmp_path):
    p = target_profile(**ARGS, method="paper-as-printed", cache_dir=tmp_path)
    q = target_profile(**ARGS, method="exact", cache_dir=tmp_path)
    assert p.content_hash != q.content_hash
    gap = np.max(np.abs(p.temperature - q.temperature))
    assert gap > 0.01                                  # Eq. 7 really differs from the exact solution
    assert gap <= p.error_bound + q.error_bound


def test_rougher_sample_keeps_the_interface_cooler():
    smooth = target_profile(**{**ARGS, "roughness": 1.6e-6}, cache=False)
    rough = target_profile(**{**ARGS, "roughness": 100e-6}, cache=False)
    assert np.all(rough.temperature[1:] <= smooth.temperature[1:])
    assert rough.temperature[-1] < smooth.temperature[-1] - 0.1


def test_hash_depends_on_every_input_and_is_stable_across_processes(tmp_path):
    base = target_profile(**ARGS, cache=False).content_hash
    assert len(base) == 64 and int(base, 16) >= 0
    for change in (dict(roughness=50e-6), dict(skin=Skin(1000e-6)), dict(skin_temperature=36.0),
                   dict(material_temperature=24.0), dict(duration=4.0), dict(rate=50.0),
                   dict(resolution=0.02), dict(sample_thickness=3e-3), dict(material="copper"),
                   dict(method="numerical")):
        assert target_profile(**{**ARGS, **change}, cache=False).content_hash != base, change
    code = ("from stimuli.target import target_profile; from stimuli.properties import Skin;"
            "print(target_profile(material='stainless_steel', roughness=12.5e-6, skin=Skin(650e-6),"
            "skin_temperature=35.5, material_temperature=20.0, duration=5.0, rate=100.0,"
            "resolution=0.01, cache=False).content_hash)")
    env = {**os.environ, "PYTHONHASHSEED": "12345"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         check=True).stdout.strip()
    assert out == base


def test_cache_hit_env_override_and_corrupt_entry(tmp_path, monkeypatch):
    monkeypatch.setenv("THERMOCUE_CACHE", str(tmp_path / "env-cache"))
    first = target_profile(**ARGS)
    assert not first.cached
    files = list((tmp_path / "env-cache").iterdir())
    assert [f.name for f in files] == [f"target-{first.content_hash}.json"]   # no temp files left
    second = target_profile(**ARGS)
    assert second.cached and second == first
    assert np.array_equal(second.temperature, first.temperature)
    assert second.error_bound == first.error_bound and second.method == first.method
    # a damaged entry is a miss: recomputed and rewritten
    files[0].write_text("{not json", encoding="utf-8")
    third = target_profile(**ARGS)
    assert not third.cached and np.array_equal(third.temperature, first.temperature)
    assert json.loads(files[0].read_text(encoding="utf-8"))["content_hash"] == first.content_hash
    # an explicit directory wins over the environment
    other = target_profile(**ARGS, cache_dir=tmp_path / "explicit")
    assert not other.cached and (tmp_path / "explicit" / files[0].name).exists()


def test_to_dict_is_json_ready():
    p = target_profile(**{**ARGS, "duration": 0.5}, cache=False)
    d = json.loads(json.dumps(p.to_dict()))
    assert d["time_s"][:2] == [0.0, 0.01] and len(d["target_C"]) == 51
    assert d["error_bound_K"] == p.error_bound


@pytest.mark.parametrize("change, field", [
    (dict(duration=0.0), "duration"), (dict(rate=-1.0), "rate"), (dict(resolution=0.0), "resolution"),
    (dict(duration=1.005), "duration"), (dict(roughness=-1e-6), "roughness"),
    (dict(skin="thin"), "skin"), (dict(material=3), "material"),
    (dict(skin_temperature=float("nan")), "skin_temperature"),
])
def test_bad_input_names_the_field(change, field):
    with pytest.raises(ModelInputError, match=rf"target_profile: {field}: expected"):
        target_profile(**{**ARGS, **change}, cache=False)
