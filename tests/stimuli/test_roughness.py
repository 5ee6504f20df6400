import math

import numpy as np
import pytest

from stimuli import ModelInputError, Skin, contact_resistance, material
from stimuli.roughness import PAPER_HARDNESS


def test_hardness_is_gram_force_per_mm2_in_pa():
    assert PAPER_HARDNESS == pytest.approx(12.5 * 1e-3 * 9.80665 / 1e-6)


def test_eq5_by_hand():
    # R_a = 12.5 um on steel, paper defaults, every unit spelled out:
    rq = math.sqrt(21.69e-6 ** 2 + 12.5e-6 ** 2)              # m
    lam = 2 * 0.34 * 14.9 / (0.34 + 14.9)                      # W/(m K), lambda_a = steel
    h_over_p = (12.5 * 9.80665e-3 / 1e-6) / (2.0 / 135e-6)     # Pa / Pa
    expected = 0.8 * rq / (lam * 0.3) * h_over_p ** 0.95       # m^2 K / W
    assert contact_resistance(12.5e-6) == pytest.approx(expected, rel=1e-12)
    assert 5e-4 < expected < 1e-3


def test_monotone_in_roughness_and_force():
    r = contact_resistance(np.array([0.0, 0.4e-6, 1.6e-6, 12.5e-6, 50e-6, 100e-6]))
    assert np.all(np.diff(r) > 0)
    assert contact_resistance(1.6e-6, force=4.0) < contact_resistance(1.6e-6)


def test_lambda_a_is_the_material():
    skin = Skin(1e-3)
    assert contact_resistance(1.6e-6, skin, material("copper")) < contact_resistance(1.6e-6, skin, material("glass"))


def test_errors():
    with pytest.raises(ModelInputError, match="roughness"):
        contact_resistance(-1e-6)
    with pytest.raises(ModelInputError, match="roughness: expected metres"):
        contact_resistance(1.6)
    with pytest.raises(ModelInputError, match="force"):
        contact_resistance(1e-6, force=0)
