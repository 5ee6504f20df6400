"""The 2-D axisymmetric plate behind the lateral-spreading option (experiments.bench.lateral)."""
import numpy as np

from experiments.bench.lateral import axisymmetric_contact, lateral_check
from stimuli import Contact, Skin, contact_resistance, material


def test_contact_over_the_whole_plate_is_the_exact_insulated_slab():
    skin, steel = Skin(650e-6), material("stainless_steel")
    R = float(contact_resistance(12.5e-6, skin=skin, material=steel))
    t = np.array([1.0, 3.0, 8.0, 20.0])
    th_i, th_r = axisymmetric_contact(skin, steel, R, t, plate_radius=6.56e-3, contact_radius=6.56e-3,
                                      dr=1e-3)
    c = Contact(skin, steel.with_thickness(3e-3), R, 1.0, 0.0)
    np.testing.assert_allclose(th_i, c.interface_temperature(t), rtol=0, atol=2e-4)
    np.testing.assert_allclose(th_r, c.receptor_temperature(t), rtol=0, atol=2e-4)


def test_effective_thickness_follows_the_2d_plate_and_the_insulated_slab_does_not():
    t, rows = lateral_check()
    plate_i, plate_r = rows["2-D plate 20x23x3 mm (axisymmetric)"]
    eff = next(v for k, v in rows.items() if k.startswith("1-D slab, effective"))
    slab = rows["1-D insulated 3 mm slab"]
    late = t >= 3.0
    assert np.max(np.abs(eff[1] - plate_r)[late]) < 0.15           # receptor, K
    assert np.max(np.abs(eff[0] - plate_i)) < 0.3                   # interface (contact edge), K; 0.25 seen
    assert np.max(np.abs(slab[1] - plate_r)) > 1.0                  # the insulated slab is not it
