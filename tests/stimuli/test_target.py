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


# --------------------------------------------------------------------------- sides and the pad
STEEL = material("stainless_steel")
R_SAMPLE = float(contact_resistance(12.5e-6, skin=ARGS["skin"], material=STEEL))
R_PAD = float(contact_resistance(0.4e-6, skin=ARGS["skin"], material=material("copper")))


def test_sides_are_the_contact_interface_temperatures():
    skin_side = target_profile(**ARGS, side="skin", cache=False)
    exact = Contact(ARGS["skin"], STEEL, R_SAMPLE, 35.5, 20.0).interface_temperature(skin_side.times, side="skin")
    assert np.max(np.abs(skin_side.temperature - exact)) <= skin_side.error_bound <= 0.005 + 1e-9
    material_side = target_profile(**ARGS, cache=False)
    assert np.all(skin_side.temperature[1:] > material_side.temperature[1:] + 1.0)   # R q is K-sized here
    assert skin_side.parameters["side"] == "skin" and material_side.parameters["side"] == "material"


def test_compensated_limits():
    skin_side = target_profile(**ARGS, side="skin", cache=False)
    material_side = target_profile(**ARGS, side="material", cache=False)
    zero = target_profile(**ARGS, side="compensated", pad_resistance=0.0, cache=False)
    none = target_profile(**ARGS, side="compensated", cache=False)
    full = target_profile(**ARGS, side="compensated", pad_resistance=R_SAMPLE, cache=False)
    assert np.array_equal(zero.temperature, skin_side.temperature)
    assert np.array_equal(none.temperature, skin_side.temperature)
    assert np.array_equal(full.temperature, material_side.temperature)
    assert zero.parameters["pad_resistance_m2K_per_W"] == 0.0
    assert full.parameters["pad_resistance_m2K_per_W"] == R_SAMPLE


def _dirichlet_impulse_peak(skin):
    """max_t of the receptor's impulse response k_D (1/s) for a surface held at g (no resistance).

    Independent closed form: the image series S_D = sum_n erfc(a_n- / 2 sqrt(alpha t)) -
    erfc(a_n+ / 2 sqrt(alpha t)), a_n-+ = (2n + 1) L -+ d, differentiated term by term:
    d/dt erfc(a / 2 sqrt(alpha t)) = a exp(-a^2 / 4 alpha t) / (2 sqrt(pi alpha) t^1.5); maximised on
    a fine grid (the peak is smooth; 1% margin).
    """
    L, d, alpha = skin.thickness, skin.dermis, skin.diffusivity
    t = np.geomspace(1e-4, 50.0, 200001)

    def term(a):
        return a * np.exp(-a * a / (4 * alpha * t)) / (2 * np.sqrt(np.pi * alpha) * t ** 1.5)

    k = sum(term((2 * n + 1) * L - d) - term((2 * n + 1) * L + d) for n in range(60))
    return 1.01 * float(np.max(k))


@pytest.mark.parametrize("roughness, resolution", [(12.5e-6, 0.01), (100e-6, 0.01), (12.5e-6, 1e-4)])
def test_compensated_profile_through_the_pad_gives_the_real_contact(roughness, resolution):
    # A display replaying the profile through the finger-pad resistance R_pad (a Robin boundary):
    # its receptor temperature must be the real contact's. Error bound (stated and checked):
    # the skin behind R_pad is linear, its receptor impulse response k is >= 0 with integral
    # gain = d / (L + R_pad lambda), and k = k_D * rho (the Dirichlet receptor response to the
    # skin-side surface temperature, which is g filtered by a kernel rho >= 0 of integral <= 1),
    # so max k <= max k_D. The display history g (quantised samples, linear in between) differs
    # from the exact pad temperature by <= E + e_j on interval j, E = profile.error_bound
    # (quantisation + model at the samples), e_j = the chord (interpolation) error, taken as twice
    # the deviation at the interval's midpoint. Hence, for any split m,
    # |error| <= gain E + dt max(k_D) sum_{j<m} e_j + gain max_{j>=m} e_j.
    from stimuli.display_response import skin_response
    skin = ARGS["skin"]
    args = {**ARGS, "roughness": roughness, "resolution": resolution, "rate": 1000.0, "duration": 5.0}
    R = float(contact_resistance(roughness, skin=skin, material=STEEL))
    assert R > R_PAD
    real = Contact(skin, STEEL, R, 35.5, 20.0)
    prof = target_profile(**args, side="compensated", pad_resistance=R_PAD, cache=False)
    t = prof.times
    dt = t[1]
    felt = skin_response(skin, t, prof.temperature, initial_temperature=35.5, resistance=R_PAD)
    truth = real.receptor_temperature(t)

    def pad(tt):   # the exact compensated pad temperature T_S(L-) - R_pad q
        Ts, Tm = real.interface_temperature(tt, side="skin"), real.interface_temperature(tt, side="material")
        return Ts - R_PAD * (Ts - Tm) / R

    ends = pad(t)
    ends[0] = pad(np.array([1e-12]))[0]        # the display jumps to the t -> 0+ value at t = 0
    e = 2.0 * np.abs(pad(0.5 * (t[:-1] + t[1:])) - 0.5 * (ends[:-1] + ends[1:]))
    gain = skin.dermis / (skin.thickness + R_PAD * skin.conductivity)
    early = np.concatenate([[0.0], dt * _dirichlet_impulse_peak(skin) * np.cumsum(e)])
    late = np.concatenate([gain * np.maximum.accumulate(e[::-1])[::-1], [0.0]])
    bound = gain * prof.error_bound + float(np.min(early + late))
    err = float(np.max(np.abs(felt - truth)))
    assert err <= bound, (err, bound)
    assert bound < 0.6 * resolution + 2e-4     # quantisation-limited (0.5 gain resolution + rest)
    # the paper's profile (material side) through the same pad feels colder than reality
    paper = target_profile(**args, side="material", cache=False)
    colder = skin_response(skin, t, paper.temperature, initial_temperature=35.5, resistance=R_PAD)
    assert np.all(colder[100:] < truth[100:]) and np.max(truth - colder) > 20 * bound


def test_side_and_pad_resistance_are_in_the_hash():
    base = target_profile(**ARGS, cache=False)
    assert base.parameters["side"] == "material" and base.parameters["pad_resistance_m2K_per_W"] == 0.0
    hashes = {base.content_hash,
              target_profile(**ARGS, side="skin", cache=False).content_hash,
              target_profile(**ARGS, side="compensated", pad_resistance=R_PAD, cache=False).content_hash,
              target_profile(**ARGS, side="compensated", pad_resistance=0.5 * R_PAD, cache=False).content_hash,
              target_profile(**ARGS, pad_resistance=R_PAD, cache=False).content_hash}
    assert len(hashes) == 5


def test_compensated_cache_round_trip(tmp_path):
    a = target_profile(**ARGS, side="compensated", pad_resistance=R_PAD, cache_dir=tmp_path)
    b = target_profile(**ARGS, side="compensated", pad_resistance=R_PAD, cache_dir=tmp_path)
    assert not a.cached and b.cached and a == b and b.error_bound == a.error_bound


@pytest.mark.parametrize("change, field", [
    (dict(side="pad"), "side"),
    (dict(pad_resistance=-1e-4), "pad_resistance"),
    (dict(pad_resistance=float("inf")), "pad_resistance"),
    (dict(side="compensated", pad_resistance=2 * R_SAMPLE), "pad_resistance"),
])
def test_bad_side_inputs_name_the_field(change, field):
    with pytest.raises(ModelInputError, match=rf"target_profile: {field}: expected"):
        target_profile(**{**ARGS, **change}, cache=False)


def test_compensated_with_an_approximate_method_bounds_its_error():
    p = target_profile(**ARGS, side="compensated", pad_resistance=R_PAD, method="numerical", cache=False)
    q = target_profile(**ARGS, side="compensated", pad_resistance=R_PAD, cache=False)
    assert p.method == "numerical" and q.method == "exact"
    assert np.max(np.abs(p.temperature - q.temperature)) <= p.error_bound + q.error_bound
