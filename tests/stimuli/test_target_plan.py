"""target_profile goes through the scene planner; its decisions travel with the profile."""
import json

import numpy as np
import pytest

from stimuli import Contact, Skin, contact_resistance, material, target_profile
from stimuli.scene import Model, Scene, evaluate

pytestmark = pytest.mark.filterwarnings("error")


def test_default_profile_is_planned_and_unchanged(tmp_path):
    skin = Skin(650e-6)
    p = target_profile(roughness=12.5e-6, skin=skin, duration=20.0, rate=100.0,
                       sample_thickness=3e-3, cache=False)
    plan = p.parameters["plan"]
    d = {x["effect"]: x for x in plan["decisions"]}
    assert d["slab"]["included"] and plan["tolerance_K"] == 0.005     # half the 0.01 K resolution
    json.dumps(p.parameters, allow_nan=False)
    # the planned model is the exact slab contact: the same numbers as before the planner
    R = contact_resistance(12.5e-6, skin=skin, material=material("stainless_steel", 3e-3))
    ref = Contact(skin, material("stainless_steel", 3e-3), R, 35.5, 20.0).interface_temperature(p.times)
    np.testing.assert_array_equal(p.temperature, np.round(ref / 0.01) * 0.01)


def test_plan_survives_the_cache(tmp_path):
    kw = dict(roughness=1.6e-6, duration=2.0, rate=10.0, cache_dir=tmp_path)
    first = target_profile(**kw)
    again = target_profile(**kw)
    assert again.cached and again.parameters["plan"] == first.parameters["plan"]


def test_physics_options_are_computed_and_bounded():
    # layered, perfused skin on a slab resting on wood: the planner keeps what matters at 0.005 K
    phys = {"layered": True, "perfusion_per_s": 1.25e-3, "geometry": "slab-on-support", "support": "wood"}
    p = target_profile(roughness=12.5e-6, duration=20.0, rate=100.0, sample_thickness=3e-3,
                       physics=phys, cache=False)
    kept = {x["effect"] for x in p.parameters["plan"]["decisions"] if x["included"]}
    assert {"layered", "support"} <= kept
    R = contact_resistance(12.5e-6, skin=Skin(650e-6), material=material("stainless_steel"))
    full = Scene(quantity="interface_material", duration_s=20.0, rate_Hz=100.0, resistance=R,
                 layered=True, perfusion_per_s=1.25e-3, geometry="slab-on-support", support="wood",
                 receptor_depth_m=260e-6)
    ref = evaluate(full, full.full_model())
    assert np.max(np.abs(p.temperature - ref)) <= p.error_bound + 1e-12
    # ... and the options change the profile by more than the display resolution
    plain = target_profile(roughness=12.5e-6, duration=20.0, rate=100.0, sample_thickness=3e-3, cache=False)
    assert np.max(np.abs(p.temperature - plain.temperature)) > 0.1


def test_force_goes_through_eq5_and_is_recorded():
    a = target_profile(roughness=1.6e-6, duration=5.0, rate=10.0, force=1.5, cache=False)
    b = target_profile(roughness=1.6e-6, duration=5.0, rate=10.0, force=2.5, cache=False)
    assert a.parameters["force_N"] == 1.5 and b.parameters["force_N"] == 2.5
    assert a.parameters["resistance_m2K_per_W"] > b.parameters["resistance_m2K_per_W"]
    assert a.content_hash != b.content_hash


def test_unknown_physics_option_names_the_field():
    from stimuli import ModelInputError
    with pytest.raises(ModelInputError, match="physics"):
        target_profile(physics={"colour": "red"}, cache=False)


def test_physics_needs_the_planner_and_a_slab_thickness():
    from stimuli import ModelInputError
    with pytest.raises(ModelInputError, match="physics"):
        target_profile(physics={"layered": True}, method="paper", cache=False)
    with pytest.raises(ModelInputError, match="physics"):
        target_profile(physics={"layered": True}, tolerance=0.1, cache=False)
    with pytest.raises(ModelInputError, match="sample_thickness"):
        target_profile(physics={"geometry": "slab-on-support", "support": "wood"}, cache=False)
