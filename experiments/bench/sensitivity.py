"""Sensitivity of Figure 9's headline inputs to the scene's physics.

Figure 9 compares recognition between the thin- (group A, L = 650 µm) and thick-skinned (group B,
1000 µm) participants; what the simulated observer recognises are the receptor temperatures of
the four samples in a real contact (``stimuli.scene``, quantity "receptor"). The headline inputs
are therefore the receptor temperature *differences*: between neighbouring samples
(1#-2#, 3#-4#, per group) and between the groups (A - B, per sample). This module recomputes them
under each documented option of the scene -- the sample's geometry, the contact force and the
receptor depth -- against the project's default (3 mm insulated steel slab, 2 N, receptors at 0.4 L
below the surface), exactly (Bromwich inversion), and writes a Markdown table
(``python -m experiments.bench.sensitivity``; docs/scene-physics.md holds its output).
"""
from __future__ import annotations

import numpy as np

from stimuli.paper import GROUP_TARGET_THICKNESS_UM, SAMPLE_ROUGHNESS_UM

__all__ = ["sensitivity_rows", "sensitivity_markdown", "VARIANTS"]

ROUGHNESS_UM = SAMPLE_ROUGHNESS_UM
GROUPS_UM = GROUP_TARGET_THICKNESS_UM
TIMES_S = (3.0, 8.0)

#: (label, Scene options) -- the first is the default every other row is compared with.
VARIANTS = (
    ("default: 3 mm slab (insulated), 2 N, depth 0.4 L", {}),
    ("half-space sample", {"geometry": "half-space"}),
    ("3 mm slab on wood", {"geometry": "slab-on-support", "support": "wood"}),
    ("3 mm slab on aluminium", {"geometry": "slab-on-support", "support": "aluminium"}),
    ("lateral spreading: 17.3 mm effective slab (20 s)", {"effective_thickness_m": 17.3e-3}),
    ("force 1.5 N", {"force_N": 1.5}),
    ("force 2.5 N (the emulated finger)", {"force_N": 2.5}),
    ("receptors at 160 µm (Hensel)", {"receptor_depth_m": 160e-6}),
    ("receptors at 0.25 L", {"receptor_fraction": 0.25}),
    ("receptors at 0.6 L", {"receptor_fraction": 0.6}),
    ("layered skin (epidermis/dermis)", {"layered": True}),
    ("layered + perfusion 1.25e-3 /s", {"layered": True, "perfusion_per_s": 1.25e-3}),
)


def _receptor(options, L_um, ra_um, times):
    from stimuli.scene import Scene, evaluate
    scene = Scene(quantity="receptor", skin_thickness_m=L_um * 1e-6, roughness_m=ra_um * 1e-6,
                  duration_s=max(times), rate_Hz=10.0, **options)
    return evaluate(scene, scene.full_model(), np.asarray(times))


def sensitivity_rows(variants=VARIANTS, times=TIMES_S) -> list:
    """One dict per variant: the receptor temperature differences (K) at each time."""
    rows = []
    for label, options in variants:
        T = {(g, ra): _receptor(options, L, ra, times) for g, L in GROUPS_UM.items() for ra in ROUGHNESS_UM}
        row = {"variant": label}
        for i, t in enumerate(times):
            for g in GROUPS_UM:
                row[f"{g} 1#-2# @{t:g}s"] = float(T[(g, 1.6)][i] - T[(g, 12.5)][i])
                row[f"{g} 3#-4# @{t:g}s"] = float(T[(g, 50.0)][i] - T[(g, 100.0)][i])
            row[f"A-B 1# @{t:g}s"] = float(T[("A", 1.6)][i] - T[("B", 1.6)][i])
            row[f"A-B 4# @{t:g}s"] = float(T[("A", 100.0)][i] - T[("B", 100.0)][i])
        rows.append(row)
    return rows


def sensitivity_markdown(rows) -> str:
    keys = [k for k in rows[0] if k != "variant"]
    lines = ["| variant | " + " | ".join(keys) + " |", "|---" * (len(keys) + 1) + "|"]
    for r in rows:
        lines.append(f"| {r['variant']} | " + " | ".join(f"{r[k]:+.3f}" for k in keys) + " |")
    return "\n".join(lines)


if __name__ == "__main__":   # pragma: no cover
    print(sensitivity_markdown(sensitivity_rows()))
