"""``thermocue explain [--quantity Q] [--tolerance-K X] ...``: which physics a scene needs, and why.

Builds a :class:`stimuli.scene.Scene` from the options (units in their names), runs the scene
planner (:func:`stimuli.planner.plan`) and prints the planned model, each effect kept or
neglected with the error its neglect causes at that scene, and the bound of the planned model
against the full one. ``--json`` prints the same as one JSON object.
"""
from __future__ import annotations

import json

from stimuli.paper import GROUP_TARGET_THICKNESS_UM, SAMPLE_MATERIAL

__all__ = ["register"]


def register(sub) -> None:
    p = sub.add_parser("explain", help="which physics a scene needs (the scene planner's decisions)",
                       description=__doc__.split("\n\n")[0])
    p.add_argument("--quantity", default="receptor",
                   choices=("receptor", "interface_material", "interface_skin"))
    p.add_argument("--duration-s", type=float, default=20.0)
    p.add_argument("--rate-Hz", type=float, default=100.0)
    p.add_argument("--tolerance-K", type=float, default=None,
                   help="accuracy needed (default: the perceptual floor, 0.3 K)")
    p.add_argument("--material", default=SAMPLE_MATERIAL)
    p.add_argument("--roughness-um", type=float, default=12.5)
    p.add_argument("--force-N", type=float, default=2.0, help="contact force for Eq. 5")
    p.add_argument("--skin-thickness-um", type=float, default=GROUP_TARGET_THICKNESS_UM["A"],
                   help="L, the effective depth of the isothermal core")
    p.add_argument("--receptor-depth-um", type=float, default=None,
                   help="below the surface (default: 0.4 L)")
    p.add_argument("--skin-temperature-C", type=float, default=35.5)
    p.add_argument("--material-temperature-C", type=float, default=20.0)
    p.add_argument("--geometry", default="slab", choices=("half-space", "slab", "slab-on-support"))
    p.add_argument("--sample-thickness-um", type=float, default=3000.0)
    p.add_argument("--support", default=None, help="material under the slab (slab-on-support)")
    p.add_argument("--effective-thickness-um", type=float, default=None,
                   help="lateral-spreading stand-in for the slab thickness")
    p.add_argument("--layered", action="store_true", help="epidermis and dermis properties")
    p.add_argument("--hypodermis-um", type=float, default=None)
    p.add_argument("--perfusion-per-s", type=float, default=0.0)
    p.add_argument("--sensor-time-constant-s", type=float, default=0.0)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_run)


def _um(v):
    return None if v is None else v * 1e-6


def _run(ns) -> int:
    from stimuli.planner import plan
    from stimuli.scene import PERCEPTUAL_FLOOR_K, Scene

    scene = Scene(quantity=ns.quantity, duration_s=ns.duration_s, rate_Hz=ns.rate_Hz,
                  tolerance_K=PERCEPTUAL_FLOOR_K if ns.tolerance_K is None else ns.tolerance_K,
                  material=ns.material, roughness_m=ns.roughness_um * 1e-6, force_N=ns.force_N,
                  skin_thickness_m=ns.skin_thickness_um * 1e-6,
                  receptor_depth_m=_um(ns.receptor_depth_um),
                  skin_temperature_C=ns.skin_temperature_C,
                  material_temperature_C=ns.material_temperature_C, geometry=ns.geometry,
                  sample_thickness_m=ns.sample_thickness_um * 1e-6, support=ns.support,
                  effective_thickness_m=_um(ns.effective_thickness_um), layered=ns.layered,
                  hypodermis_m=_um(ns.hypodermis_um), perfusion_per_s=ns.perfusion_per_s,
                  sensor_time_constant_s=ns.sensor_time_constant_s)
    p = plan(scene, screen=False)         # every effect evaluated, for the reader
    if ns.json:
        out = p.to_dict()
        out["scene"] = p.scene.to_dict()
        print(json.dumps(out, indent=2, default=float))
    else:
        for line in p.lines():
            print(line)
        print(f"contact resistance (Eq. 5 at {ns.force_N:g} N): {p.scene.resistance:.4g} m² K/W")
    return 0
