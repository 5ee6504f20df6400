import pytest

from stimuli import MATERIALS, MATERIAL_SOURCES, Material, ModelInputError, Skin, material


def test_table1_effusivities():
    # Table 1 of the paper prints beta = 7253.71 (SS) and 1167.36 (skin).
    assert material("stainless_steel").effusivity == pytest.approx(7253.71, abs=0.01)
    assert Skin(1e-3).effusivity == pytest.approx(1167.36, abs=0.01)


def test_required_materials_with_sources():
    for name in ("stainless_steel", "copper", "aluminium", "glass", "wood", "pmma", "polystyrene_foam"):
        assert name in MATERIALS and len(MATERIAL_SOURCES[name]) > 20
        assert MATERIALS[name].thickness is None


def test_copper_far_more_and_foam_far_less_effusive_than_skin():
    skin = Skin(1e-3).effusivity
    assert material("copper").effusivity > 20 * skin
    assert material("foam").effusivity < skin / 20


def test_thickness_and_errors():
    assert material("ss", thickness=3e-3).thickness == 3e-3
    with pytest.raises(ModelInputError, match="name: expected one of"):
        material("unobtainium")
    with pytest.raises(ModelInputError, match="thickness"):
        material("ss", thickness=-1.0)
    with pytest.raises(ModelInputError, match="conductivity"):
        Material(0.0, 1.0, 1.0)


def test_skin_validation():
    assert Skin(1e-3).dermis == pytest.approx(0.6e-3)
    with pytest.raises(ModelInputError, match="dermis"):
        Skin(1e-3, dermis=1e-3)
    with pytest.raises(ModelInputError, match="thickness"):
        Skin(650.0)   # micrometres by mistake
