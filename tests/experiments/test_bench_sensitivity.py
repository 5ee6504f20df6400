"""The Figure 9 sensitivity table (experiments.bench.sensitivity) against stimuli.Contact."""
import numpy as np

from experiments.bench.sensitivity import sensitivity_markdown, sensitivity_rows
from stimuli import Contact, Skin, contact_resistance, material


def _contact_receptor(L, ra_um, t, force=2.0, D=3e-3):
    skin = Skin(L)                                       # receptors at 0.6 L from the core
    steel = material("stainless_steel", D)
    R = contact_resistance(ra_um * 1e-6, skin=skin, material=steel, force=force)
    return Contact(skin, steel, R, 35.5, 20.0).receptor_temperature([t])[0]


def test_default_and_force_rows_match_the_homogeneous_contact():
    rows = sensitivity_rows(variants=(("default", {}), ("2.5 N", {"force_N": 2.5}),
                                      ("half-space", {"geometry": "half-space"})), times=(8.0,))
    md = sensitivity_markdown(rows)
    assert md.count("\n") == 4 and "A-B 1# @8s" in md
    for row, force, D in ((rows[0], 2.0, 3e-3), (rows[1], 2.5, 3e-3), (rows[2], 2.0, None)):
        want = (_contact_receptor(650e-6, 1.6, 8.0, force, D) - _contact_receptor(1000e-6, 1.6, 8.0, force, D))
        np.testing.assert_allclose(row["A-B 1# @8s"], want, atol=1e-9)
        want12 = _contact_receptor(650e-6, 1.6, 8.0, force, D) - _contact_receptor(650e-6, 12.5, 8.0, force, D)
        np.testing.assert_allclose(row["A 1#-2# @8s"], want12, atol=1e-9)
